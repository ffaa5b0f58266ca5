//! Wedges in the build (see [`crate::vtree::Wedges`]): a mesh with texture coordinates or
//! materials is built on its welded positions, one leaf per place, and its vertices ride along as
//! wedges, joined where a merge closes a triangle between two of them.
//!
//! What prices a merge is each slot's *principal* wedge (its heaviest): its attribute quadric
//! stands for the slot's appearance. Two principals that a merge will join (an edge, one texture,
//! their best coordinates at the merged place within a chart's reach of each other) are priced as
//! one quadric, as Garland and Heckbert do; two that stay apart (the sides of a seam, a merge
//! across a gap) each by its own residual at the merged place, which is how far each side's
//! texture slides, and never by the mismatch between their charts.

use super::CHART_UV_DISTANCE;
use crate::mesh::{Mesh, NO_TEXTURE, Part};
use crate::simplify::attribute_quadric::LocalAttributeQuadric;
use crate::simplify::metric::{Candidate, PairEnd, Pricing};
use crate::vtree::{NONE, Wedges};
use glam::{DVec3, Vec2, Vec3};
use smallvec::SmallVec;

/// A mesh's positions welded, with each corner's wedge.
pub(super) struct Welded {
    /// The geometry the tree is built on: one vertex per place (with the mean of its wedges'
    /// normals and colours), the triangles whose corners stay apart.
    pub geometry: Mesh,
    /// Per triangle of `geometry`, its corners' wedges: the input's vertices.
    pub corners: Vec<[u32; 3]>,
    /// Per wedge, its leaf.
    pub leaf: Vec<u32>,
    /// How many leaves (places) there are.
    pub leaves: usize,
}

/// Welds `mesh`'s vertices that share a position (bit for bit). A triangle whose corners weld
/// together (two wedges of one place, a sliver of no area) is left out.
pub(super) fn weld(mesh: &Mesh) -> Welded {
    let mut ids: rustc_hash::FxHashMap<[u32; 3], u32> = Default::default();
    let mut positions = Vec::new();
    let leaf: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            *ids.entry(p.to_array().map(f32::to_bits))
                .or_insert_with(|| {
                    positions.push(*p);
                    positions.len() as u32 - 1
                })
        })
        .collect();
    drop(ids);
    let n = positions.len();
    let mut triangles = Vec::with_capacity(mesh.triangles.len());
    let mut corners = Vec::with_capacity(mesh.triangles.len());
    let mut keep = |range: std::ops::Range<u32>| {
        let start = triangles.len() as u32;
        for t in &mesh.triangles[range.start as usize..range.end as usize] {
            let g = t.map(|w| leaf[w as usize]);
            if g[0] != g[1] && g[1] != g[2] && g[0] != g[2] {
                triangles.push(g);
                corners.push(*t);
            }
        }
        start..triangles.len() as u32
    };
    let parts = if mesh.parts.is_empty() {
        keep(0..mesh.triangles.len() as u32);
        Vec::new()
    } else {
        mesh.parts
            .iter()
            .map(|p| Part {
                name: p.name.clone(),
                triangles: keep(p.triangles.clone()),
            })
            .collect()
    };
    let mean = |values: &[Vec3]| {
        let mut sum = vec![(Vec3::ZERO, 0u32); n];
        for (w, &l) in leaf.iter().enumerate() {
            sum[l as usize].0 += values[w];
            sum[l as usize].1 += 1;
        }
        sum.into_iter()
            .map(|(s, k)| s / k.max(1) as f32)
            .collect::<Vec<_>>()
    };
    let geometry = Mesh {
        colors: mesh.colors.as_deref().map(mean),
        normals: mesh.normals.as_deref().map(|ns| {
            mean(ns)
                .into_iter()
                .map(|v| v.normalize_or_zero())
                .collect()
        }),
        positions,
        triangles,
        parts,
        one_sided: mesh.one_sided,
        ..Mesh::default()
    };
    Welded {
        geometry,
        corners,
        leaf,
        leaves: n,
    }
}

/// The wedges as a build grows them.
///
/// A live wedge's attribute quadric (about where its node stands) is held once: a slot's
/// principal wedge's is the slot's, in the array pricing reads (the builder's `colors`, passed
/// in), and only the others' are here. Most slots have one wedge, so that is most of them: on the
/// textured dragon a copy of every principal's beside every wedge's was 54 MB more memory, which
/// this machine pays for in time (fresh memory is cleared by the kernel as it is first touched).
pub(super) struct WedgeState {
    /// Per triangle of the geometry, its corners' leaf wedges.
    pub corners: Vec<[u32; 3]>,
    /// The quadrics of live wedges that are not their slot's principal (default, of no area,
    /// when appearance is not weighed), each about `at`, with a list of places let go.
    quadric: Vec<LocalAttributeQuadric>,
    at: Vec<Vec3>,
    free: Vec<u32>,
    /// Per wedge, its place in `quadric` and `at`; [`PRINCIPAL`] for a principal.
    held: Vec<u32>,
    /// Per slot, where its node stands: what its principal's quadric is about.
    slot_at: Vec<Vec3>,
    node: Vec<u32>,
    parent: Vec<u32>,
    /// Towards the wedge that stands for this one now (a union-find's, compressed as it is read).
    rep: Vec<u32>,
    texture: Vec<u32>,
    material: Vec<u32>,
    uv: Vec<[f32; 2]>,
    color: Vec<[f32; 3]>,
    /// Tints of textures (empty when the input has none).
    tint: Vec<[f32; 3]>,
    /// Unit normals (zero where the input has none).
    normal: Vec<[f32; 3]>,
    /// Each live slot's wedges, its principal (heaviest) first.
    of_slot: Vec<SmallVec<[u32; 2]>>,
    /// Per texture, its length per unit of texture space (see `texture_scales`).
    scales: Vec<f32>,
    /// Each node's first wedge (its principal), in node order.
    first: Vec<u32>,
    color_scale: f32,
}

impl WedgeState {
    /// The leaf wedges of `mesh` (the input, one wedge a vertex) over the welded leaves `leaf`,
    /// with their attribute quadrics (`quadrics`, about each vertex; empty when appearance is not
    /// weighed). Returns the state and each slot's principal wedge's quadric (empty when
    /// appearance is not weighed): what pricing reads, and what every call below is given back.
    pub fn new(
        mesh: &Mesh,
        welded: Welded,
        quadrics: Vec<LocalAttributeQuadric>,
        scales: Vec<f32>,
        color_scale: f32,
    ) -> (WedgeState, Vec<LocalAttributeQuadric>) {
        let count = mesh.positions.len();
        let leaves = welded.leaves;
        let mut of_slot: Vec<SmallVec<[u32; 2]>> = vec![SmallVec::new(); leaves];
        for (w, &l) in welded.leaf.iter().enumerate() {
            of_slot[l as usize].push(w as u32);
        }
        let weight = |w: u32| quadrics.get(w as usize).map_or(0.0, |q| q.weight());
        for list in &mut of_slot {
            principal_first(list, weight);
        }
        let principals: Vec<LocalAttributeQuadric> = if quadrics.is_empty() {
            Vec::new()
        } else {
            of_slot
                .iter()
                .map(|l| {
                    l.first()
                        .map_or_else(Default::default, |&w| quadrics[w as usize])
                })
                .collect()
        };
        let mut held = vec![PRINCIPAL; count];
        let (mut quadric, mut at) = (Vec::new(), Vec::new());
        for list in &of_slot {
            for &w in list.iter().skip(1) {
                held[w as usize] = quadric.len() as u32;
                quadric.push(quadrics.get(w as usize).copied().unwrap_or_default());
                at.push(mesh.positions[w as usize]);
            }
        }
        drop(quadrics);
        let texture: Vec<u32> = match &mesh.texture_of {
            Some(t) => t.clone(),
            None => vec![NO_TEXTURE; count],
        };
        let first = of_slot
            .iter()
            .map(|l| l.first().copied().unwrap_or(NONE))
            .collect();
        let slot_at = of_slot
            .iter()
            .map(|l| {
                l.first()
                    .map_or(Vec3::ZERO, |&w| mesh.positions[w as usize])
            })
            .collect();
        let mut state = WedgeState {
            corners: welded.corners,
            quadric,
            at,
            free: Vec::new(),
            held,
            slot_at,
            node: welded.leaf,
            parent: vec![NONE; count],
            rep: (0..count as u32).collect(),
            texture,
            material: mesh.material_of.clone().unwrap_or_else(|| vec![0; count]),
            uv: match &mesh.uvs {
                Some(uvs) => uvs.iter().map(|t| t.to_array()).collect(),
                None => vec![[0.0; 2]; count],
            },
            normal: match &mesh.normals {
                Some(n) => n.iter().map(|v| v.normalize_or_zero().to_array()).collect(),
                None => vec![[0.0; 3]; count],
            },
            color: match &mesh.colors {
                Some(c) => c
                    .iter()
                    .map(|&c| super::input_color(c).to_array())
                    .collect(),
                None => vec![[1.0; 3]; count],
            },
            tint: mesh
                .tints
                .as_ref()
                .map_or_else(Vec::new, |t| t.iter().map(|c| c.to_array()).collect()),
            of_slot,
            scales,
            first,
            color_scale,
        };
        state.reserve(leaves + leaves / 2);
        (state, principals)
    }

    /// Room for `more` wedges in every per-wedge array: the merges add about 1.3 a node (1.29 on
    /// the textured dragon), and growing by doubling past the input's count left up to half of
    /// 1.07 million wedges' arrays (124 bytes of quadric each) unused.
    fn reserve(&mut self, more: usize) {
        self.held.reserve_exact(more);
        self.node.reserve_exact(more);
        self.parent.reserve_exact(more);
        self.rep.reserve_exact(more);
        self.texture.reserve_exact(more);
        self.material.reserve_exact(more);
        self.uv.reserve_exact(more);
        self.color.reserve_exact(more);
        self.normal.reserve_exact(more);
    }

    /// Each slot's principal wedge's texture, as pricing reads it.
    pub fn charts(&self) -> Vec<u32> {
        self.of_slot
            .iter()
            .map(|l| l.first().map_or(NO_TEXTURE, |&w| self.texture[w as usize]))
            .collect()
    }

    /// Asks for what merging slots `a` and `b` will read, in the stages of
    /// `Builder::prefetch_merge`: their lists of wedges, then those wedges' data (a principal's
    /// quadric is pricing's, which asks for it itself). Only a hint.
    pub fn prefetch_merge(&self, a: u32, b: u32, stage: u32) {
        for s in [a as usize, b as usize] {
            if stage == 1 {
                crate::prefetch(&self.of_slot[s]);
                crate::prefetch(&self.slot_at[s]);
            } else if stage == 2 {
                for &w in self.of_slot[s].iter().take(4) {
                    let place = self.held[w as usize] as usize;
                    if let Some(q) = self.quadric.get(place) {
                        let q = q as *const LocalAttributeQuadric as usize;
                        // Every cache line of the quadric (124 bytes may span three).
                        for line in
                            (q..q + std::mem::size_of::<LocalAttributeQuadric>()).step_by(64)
                        {
                            crate::prefetch_address(line);
                        }
                        crate::prefetch_address(
                            q + std::mem::size_of::<LocalAttributeQuadric>() - 1,
                        );
                        crate::prefetch(&self.at[place]);
                    }
                    let w = w as usize;
                    crate::prefetch(&self.texture[w]);
                    crate::prefetch(&self.uv[w]);
                    crate::prefetch(&self.color[w]);
                    crate::prefetch(&self.normal[w]);
                    crate::prefetch(&self.material[w]);
                }
            }
        }
    }

    /// The live wedge that leaf wedge `w` has become.
    fn find(&mut self, mut w: u32) -> u32 {
        while self.rep[w as usize] != w {
            let up = self.rep[self.rep[w as usize] as usize];
            self.rep[w as usize] = up;
            w = up;
        }
        w
    }

    /// Slot `a` and slot `b` merge into node `u` at `position`, `vanished` the triangles that
    /// vanish: the wedges of the two become node `u`'s, those at the two merging corners of a
    /// vanishing triangle joined. Returns the new principal's quadric (about `position`) and
    /// texture, and the merge's texture slide: the most any joined wedge's coordinates differ,
    /// times its texture's scale, from those its new wedge's map gives at the wedge's old place
    /// (a chart whose map is linear over the surface slides nothing).
    ///
    /// `joined`: a triangle that vanished had corners at both (a degenerate one). When each slot
    /// has one wedge, that alone says whether they join, without following the triangles' leaf
    /// wedges through the union-find (a walk of cache misses: 5 % of the textured dragon's
    /// build). `principals`: each slot's principal's quadric as it was before this merge (see
    /// [`WedgeState`]); the new principal's, returned, is the caller's to store for slot `a`.
    #[allow(clippy::too_many_arguments)]
    pub fn merge(
        &mut self,
        (a, b): (u32, u32),
        u: u32,
        position: Vec3,
        vanished: impl Iterator<Item = u32>,
        joined: bool,
        principals: &[LocalAttributeQuadric],
    ) -> (LocalAttributeQuadric, u32, f32) {
        let wa = std::mem::take(&mut self.of_slot[a as usize]);
        let wb = std::mem::take(&mut self.of_slot[b as usize]);
        // Each wedge with its slot: where its quadric is.
        let all: SmallVec<[(u32, u32); 4]> = (wa.iter().map(|&w| (w, a)))
            .chain(wb.iter().map(|&w| (w, b)))
            .collect();
        // A union-find over `all`'s indices.
        let mut group: SmallVec<[usize; 4]> = (0..all.len()).collect();
        if wa.len() == 1 && wb.len() == 1 {
            if joined {
                group[1] = 0;
            }
        } else {
            self.join_by_triangles(&wa, &wb, &mut group, vanished);
        }
        let held = Held {
            state: self,
            principals,
        };
        // Wedges of one chart whose maps agree at the merged place are one wedge now, whether a
        // triangle joined them or not (a merge across a gap inside a chart): kept apart, the
        // lists of wedges would grow with every such merge up the tree.
        if wa.len() * wb.len() <= ATTRIBUTE_JOINS {
            for i in 0..wa.len() {
                for j in wa.len()..all.len() {
                    let (ri, rj) = (root(&group, i), root(&group, j));
                    if ri != rj && held.agree(all[i], all[j], position) {
                        group[ri.max(rj)] = ri.min(rj);
                    }
                }
            }
        }
        // The groups, each a run of `all`'s indices sorted by their root.
        let mut order: SmallVec<[(usize, (u32, u32)); 4]> =
            (0..all.len()).map(|i| (root(&group, i), all[i])).collect();
        order.sort_unstable();
        let p = position.as_dvec3();
        let mut joins: SmallVec<[Join; 2]> = SmallVec::new();
        let mut members: SmallVec<[(u32, u32); 4]> = SmallVec::new();
        for (k, &(r, w)) in order.iter().enumerate() {
            members.push(w);
            if order.get(k + 1).is_none_or(|&(next, _)| next != r) {
                joins.push(held.join(&members, p));
                members.clear();
            }
        }
        // The members' quadrics are read; their places go free for the new wedges'.
        for &(w, _) in &all {
            let place = self.held[w as usize];
            if place != PRINCIPAL {
                self.free.push(place);
            }
        }
        let slide = joins.iter().map(|j| j.slide).fold(0f32, f32::max);
        let mut made: SmallVec<[u32; 2]> = joins.iter().map(|j| self.push(j, u)).collect();
        // The new wedges are numbered in the order of `joins`.
        let first = made[0];
        principal_first(&mut made, |w| joins[(w - first) as usize].quadric.weight());
        let principal = made[0];
        let quadric = joins[(principal - first) as usize].quadric;
        for &w in &made[1..] {
            self.hold(w, joins[(w - first) as usize].quadric, position);
        }
        self.slot_at[a as usize] = position;
        self.first.push(principal);
        self.of_slot[a as usize] = made;
        (quadric, self.texture[principal as usize], slide)
    }

    /// Keeps the quadric `q` (about `position`) of wedge `w`, not its slot's principal, in a
    /// place let go or a new one.
    fn hold(&mut self, w: u32, q: LocalAttributeQuadric, position: Vec3) {
        let place = match self.free.pop() {
            Some(place) => {
                self.quadric[place as usize] = q;
                self.at[place as usize] = position;
                place
            }
            None => {
                self.quadric.push(q);
                self.at.push(position);
                self.quadric.len() as u32 - 1
            }
        };
        self.held[w as usize] = place;
    }

    /// Records the wedge that `j` makes at node `u` (its quadric's place is the caller's to
    /// set): its attributes, and its members' parent.
    fn push(&mut self, j: &Join, u: u32) -> u32 {
        let w = self.node.len() as u32;
        self.held.push(PRINCIPAL);
        self.node.push(u);
        self.parent.push(NONE);
        self.rep.push(w);
        self.texture.push(j.texture);
        self.material.push(j.material);
        self.uv.push(j.uv.to_array());
        self.color.push(j.color.to_array());
        if let Some(tint) = j.tint {
            self.tint.push(tint.to_array());
        }
        self.normal.push(j.normal.normalize_or_zero().to_array());
        for &m in &j.members {
            self.parent[m as usize] = w;
            self.rep[m as usize] = w;
        }
        w
    }

    /// Joins, in `group` (a union-find over `wa` then `wb`), the wedges at the two merging
    /// corners of each triangle of `vanished`.
    fn join_by_triangles(
        &mut self,
        wa: &[u32],
        wb: &[u32],
        group: &mut [usize],
        vanished: impl Iterator<Item = u32>,
    ) {
        for f in vanished {
            let live = self.corners[f as usize].map(|w| self.find(w));
            let at_a = live.iter().find_map(|w| wa.iter().position(|x| x == w));
            let at_b = live.iter().find_map(|w| wb.iter().position(|x| x == w));
            if let (Some(i), Some(j)) = (at_a, at_b) {
                let (ri, rj) = (root(group, i), root(group, wa.len() + j));
                group[ri.max(rj)] = ri.min(rj);
            }
        }
    }

    /// Each node's first wedge (leaves, then internal nodes in order).
    pub fn firsts(&self) -> &[u32] {
        &self.first
    }

    /// The finished wedges, with the corners of `vanished` (the tree's triangles, by geometry
    /// triangle index, in tree order).
    pub fn finish(self, vanished: &[u32]) -> Wedges {
        Wedges {
            corners: vanished.iter().map(|&f| self.corners[f as usize]).collect(),
            node: self.node,
            parent: self.parent,
            uv: self.uv,
            texture: self.texture,
            material: self.material,
            color: self.color,
            normal: self.normal,
            tint: self.tint,
        }
    }
}

/// Marks a wedge whose quadric is its slot's principal's (see [`WedgeState`]).
const PRINCIPAL: u32 = u32::MAX;

/// A wedge's quadric of no area: what every wedge has when appearance is not weighed.
static NO_QUADRIC: std::sync::LazyLock<LocalAttributeQuadric> =
    std::sync::LazyLock::new(LocalAttributeQuadric::default);

/// What a merge reads of the wedges before it changes any: the state, and the slots' principal
/// quadrics. Wedges come with their slots, `(wedge, slot)`.
struct Held<'a> {
    state: &'a WedgeState,
    principals: &'a [LocalAttributeQuadric],
}

/// A wedge a merge makes, before it is recorded: its members (wedges) and what they make.
struct Join {
    members: SmallVec<[u32; 4]>,
    quadric: LocalAttributeQuadric,
    texture: u32,
    material: u32,
    uv: Vec2,
    color: Vec3,
    normal: Vec3,
    tint: Option<Vec3>,
    /// How far it slides its members' texture (see [`WedgeState::merge`]).
    slide: f32,
}

impl Held<'_> {
    /// A wedge's quadric, and where it is about.
    fn quadric_of(&self, (w, slot): (u32, u32)) -> (&LocalAttributeQuadric, Vec3) {
        let s = self.state;
        match s.held[w as usize] {
            PRINCIPAL => (
                self.principals.get(slot as usize).unwrap_or(&NO_QUADRIC),
                s.slot_at[slot as usize],
            ),
            place => (&s.quadric[place as usize], s.at[place as usize]),
        }
    }

    fn weight(&self, w: (u32, u32)) -> f64 {
        self.quadric_of(w).0.weight()
    }

    /// Whether wedges `x` and `y` show one texture and material, normals on one side of a
    /// crease, and their quadrics' best coordinates at `position` lie within a chart's reach of
    /// each other (their stored ones, without quadrics).
    fn agree(&self, x: (u32, u32), y: (u32, u32), position: Vec3) -> bool {
        let s = self.state;
        let (i, j) = (x.0 as usize, y.0 as usize);
        let texture = s.texture[i];
        if texture != s.texture[j] || s.material[i] != s.material[j] {
            return false;
        }
        // A crease's sides keep their own normals (no normals: nothing to keep).
        let (ni, nj) = (Vec3::from_array(s.normal[i]), Vec3::from_array(s.normal[j]));
        if ni != Vec3::ZERO && nj != Vec3::ZERO && ni.dot(nj) < CREASE_COS {
            return false;
        }
        let p = position.as_dvec3();
        let at = |w: (u32, u32)| {
            let (q, at) = self.quadric_of(w);
            q.texture_at(p - at.as_dvec3())
        };
        match (at(x), at(y)) {
            (Some(tx), Some(ty)) => {
                let scale = s.scales.get(texture as usize).copied().unwrap_or(0.0) as f64;
                tx.distance(ty) <= scale * CHART_UV_DISTANCE as f64
            }
            _ => Vec2::from_array(s.uv[i]).distance(Vec2::from_array(s.uv[j])) <= CHART_UV_DISTANCE,
        }
    }

    /// The wedge at `position` joining `members`, and how far it slides their texture (see
    /// [`WedgeState::merge`]).
    fn join(&self, members: &[(u32, u32)], p: DVec3) -> Join {
        let s = self.state;
        let mut sum = {
            let (q, at) = self.quadric_of(members[0]);
            q.about(at, p)
        };
        for &m in &members[1..] {
            let (q, at) = self.quadric_of(m);
            sum += q.about(at, p);
        }
        let q = LocalAttributeQuadric::new(&sum);
        let heaviest = *members
            .iter()
            .max_by(|x, y| {
                let (wx, wy) = (self.weight(**x), self.weight(**y));
                wx.total_cmp(&wy).then(y.0.cmp(&x.0))
            })
            .unwrap_or(&members[0]);
        let heaviest = heaviest.0 as usize;
        let texture = s.texture[heaviest];
        let total: f64 = members.iter().map(|&m| self.weight(m)).sum();
        let share = |m: (u32, u32)| {
            if total > 0.0 {
                (self.weight(m) / total) as f32
            } else {
                1.0 / members.len() as f32
            }
        };
        let mean = |values: &[[f32; 3]]| -> Vec3 {
            members
                .iter()
                .map(|&m| Vec3::from_array(values[m.0 as usize]) * share(m))
                .sum()
        };
        let mean_uv: Vec2 = members
            .iter()
            .map(|&m| Vec2::from_array(s.uv[m.0 as usize]) * share(m))
            .sum();
        let one_texture = members.iter().all(|&m| s.texture[m.0 as usize] == texture);
        let scale = s.scales.get(texture as usize).copied().unwrap_or(0.0);
        let uv = match q.best_texture() {
            Some(t) if one_texture && scale > 0.0 => Some(t / scale).filter(|t| t.is_finite()),
            _ => None,
        }
        .unwrap_or(mean_uv);
        let slide = if one_texture && scale > 0.0 {
            members
                .iter()
                .filter_map(|&m| {
                    let mapped = q.texture_at(self.quadric_of(m).1.as_dvec3() - p)?;
                    let own = Vec2::from_array(s.uv[m.0 as usize]).as_dvec2() * scale as f64;
                    Some(mapped.distance(own) as f32)
                })
                .filter(|d| d.is_finite())
                .fold(0f32, f32::max)
        } else {
            0.0
        };
        let color_scale = super::color_scale_of(s.color_scale, texture != NO_TEXTURE);
        Join {
            members: members.iter().map(|m| m.0).collect(),
            color: q.best_color(color_scale as f64).unwrap_or(mean(&s.color)),
            quadric: q,
            texture,
            material: s.material[heaviest],
            uv,
            normal: mean(&s.normal),
            tint: (!s.tint.is_empty()).then(|| mean(&s.tint)),
            slide,
        }
    }
}

/// A merge compares each wedge of one side with each of the other for [`Held::agree`] when
/// there are at most this many pairs (lists stay short where it runs; a node of many charts
/// costs no quadratic time).
const ATTRIBUTE_JOINS: usize = 64;

/// Two wedges whose normals are further apart than this cosine's angle (about 37°) are the sides
/// of a crease, which no join by attributes closes.
const CREASE_COS: f32 = 0.8;

/// The root of `i` in a union-find `group` (each entry its parent, a root its own).
fn root(group: &[usize], mut i: usize) -> usize {
    while group[i] != i {
        i = group[i];
    }
    i
}

/// Puts the heaviest wedge of `list` first (the lowest id among equals), the rest in id order.
fn principal_first(list: &mut [u32], weight: impl Fn(u32) -> f64) {
    list.sort_unstable();
    let best = (0..list.len())
        .max_by(|&i, &j| {
            let (wi, wj) = (weight(list[i]), weight(list[j]));
            wi.total_cmp(&wj).then(j.cmp(&i))
        })
        .unwrap_or(0);
    list[..=best].rotate_right(1);
}

/// Whether the edge `u`–`v` between the geometry's faces `f` is a seam: a corner of one face at
/// `u` or `v` shows another wedge than the other face's corner there.
pub(super) fn is_seam(welded: &Welded, t: &[[u32; 3]], f: [u32; 2], edge: [u32; 2]) -> bool {
    let wedge = |f: u32, v: u32| {
        let k = t[f as usize].iter().position(|&x| x == v).unwrap_or(0);
        welded.corners[f as usize][k]
    };
    edge.iter().any(|&v| wedge(f[0], v) != wedge(f[1], v))
}

/// Each node's texture coordinates, texture and material: its first wedge's.
pub(super) fn node_appearance(
    input: &Mesh,
    wedges: &Wedges,
    firsts: &[u32],
) -> (
    Option<crate::vtree::Appearance>,
    Option<crate::vtree::Materials>,
) {
    let appearance = input.uvs.as_ref().map(|_| crate::vtree::Appearance {
        uvs: firsts.iter().map(|&w| wedges.uv[w as usize]).collect(),
        texture_of: firsts.iter().map(|&w| wedges.texture[w as usize]).collect(),
        textures: input.textures.clone(),
    });
    let materials = input.material_of.as_ref().map(|_| crate::vtree::Materials {
        list: input.materials.clone(),
        of: firsts
            .iter()
            .map(|&w| wedges.material[w as usize])
            .collect(),
    });
    (appearance, materials)
}

/// What merging two slots costs with wedges (`(end, principal quadric, principal texture)` each;
/// no quadrics when appearance is not weighed), `scales` each texture's (see the module's text):
/// two principals expected to join (an edge, one texture, their best coordinates at the merged
/// place within a chart's reach) are priced as one quadric; two that stay apart each by its own
/// residual there.
pub(super) fn price(
    pricing: &Pricing,
    (a, ca, chart_a): (&PairEnd, Option<&LocalAttributeQuadric>, u32),
    (b, cb, chart_b): (&PairEnd, Option<&LocalAttributeQuadric>, u32),
    edge: bool,
    scales: &[f32],
) -> Candidate {
    let mut cand = pricing.price(a, b, edge, None);
    let (Some(ca), Some(cb)) = (ca, cb) else {
        return cand;
    };
    let x = cand.position.as_dvec3();
    let (xa, xb) = (x - a.position.as_dvec3(), x - b.position.as_dvec3());
    let reach =
        scales.get(chart_a as usize).copied().unwrap_or(0.0) as f64 * CHART_UV_DISTANCE as f64;
    let joined = edge
        && chart_a == chart_b
        && match (ca.texture_at(xa), cb.texture_at(xb)) {
            (Some(ta), Some(tb)) => ta.distance(tb) <= reach,
            _ => true,
        };
    cand.cost += if joined {
        LocalAttributeQuadric::pair_mean_residual(ca, xa, cb, xb)
    } else {
        let w = ca.weight() + cb.weight();
        if w > 0.0 {
            (ca.residual_at(xa) + cb.residual_at(xb)) / w
        } else {
            0.0
        }
    };
    cand
}

/// What a node's colour error is weighed by, and its colour: its attribute quadric's (`color`)
/// best, in the quadric's scale (a share of `color_scale` on a textured principal wedge, see
/// `color_scale_of`). The error keeps the whole `color_scale`: the colour of a textured node is the
/// texture's mean there, and how far it changes is how much texture detail a cut would swim over,
/// which the screen-space test should see (the textured bunny's fly-in at τ = 1 px: 42.5 dB mean on
/// 7,860 triangles with the share, 49.2 on 16,837 without).
pub(super) fn node_color(
    color_scale: f32,
    color: Option<LocalAttributeQuadric>,
    principal: Option<(LocalAttributeQuadric, u32)>,
) -> (f32, Option<Vec3>) {
    let textured = principal.is_some_and(|(_, texture)| texture != NO_TEXTURE);
    let scale = super::color_scale_of(color_scale, textured);
    (color_scale, color.and_then(|c| c.best_color(scale as f64)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat strip of three unit squares, one chart mapped by `map` from the plane:
    ///
    /// ```text
    ///   4 ─ 5 ─ 6 ─ 7    y = 1
    ///   │ ╱ │ ╱ │ ╱ │
    ///   0 ─ 1 ─ 2 ─ 3    y = 0
    /// ```
    ///
    /// with vertices 1 and 2 merged at their midpoint; returns the merge's texture slide.
    fn slide_of_merge(map: impl Fn(Vec3) -> Vec2) -> f32 {
        let positions: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i % 4) as f32, (i / 4) as f32, 0.0))
            .collect();
        let mut triangles = Vec::new();
        for x in 0..3 {
            triangles.push([x, x + 1, x + 5]);
            triangles.push([x, x + 5, x + 4]);
        }
        let mut mesh = Mesh::from_triangles(positions, triangles);
        mesh.uvs = Some(mesh.positions.iter().map(|&p| map(p)).collect());
        mesh.colors = Some(vec![Vec3::ONE; 8]);
        mesh.texture_of = Some(vec![0; 8]);
        mesh.textures = vec![std::sync::Arc::new(Vec::new())];
        let welded = weld(&mesh);
        let scales = super::super::texture_scales(&mesh);
        let quadrics = super::super::attribute_quadrics(&mesh, &[Vec3::ONE; 8], 1.0, &scales);
        let (mut state, principals) = WedgeState::new(&mesh, welded, quadrics, scales, 1.0);
        // Triangle 2 = [1, 2, 6] holds the edge 1–2 and vanishes.
        let (_, _, slide) = state.merge(
            (1, 2),
            8,
            Vec3::new(1.5, 0.0, 0.0),
            [2].into_iter(),
            false,
            &principals,
        );
        slide
    }

    /// A linear chart slides nowhere; a bent one (u = (x / 3)²: the strip's middle is mapped
    /// narrower than its ends) slides, by less than the coordinates' whole spread.
    #[test]
    fn a_merge_slides_a_bent_chart_and_not_a_linear_one() {
        let linear = slide_of_merge(|p| Vec2::new(p.x / 3.0, p.y));
        assert!(linear < 1e-5, "{linear}");
        let bent = slide_of_merge(|p| Vec2::new((p.x / 3.0).powi(2), p.y));
        // The texture's scale: the strip's area 3 over its texture area (Σ of the squares' u
        // widths 1/9 + 3/9 + 5/9, times 1), so about 1.73 lengths per unit of u.
        assert!(bent > 0.01 && bent < 1.73, "{bent}");
    }
}

//! The working mesh of a simplification: the paper's current vertex and triangle sets and the merge
//! operation on them (Tao et al. §2.3, steps 3–6).
//!
//! Vertices live in *slots*, one per input vertex. `unify(a, b)` merges slot `b` into slot `a` (any two
//! slots: no edge is needed), so a slot stands for a growing cluster; `find` is the paper's map
//! `g(v)` over the table `VI` (eq. 4), with path compression.

use glam::Vec3;
use smallvec::SmallVec;

/// Marks an entry of [`Collapser::extras`] as a loose edge (left behind by a vanished triangle) rather
/// than a proximity pair.
const LOOSE_EDGE: u32 = 1 << 31;
const SLOT_MASK: u32 = !LOOSE_EDGE;
const ALIVE: u32 = u32::MAX;

/// A merge "flips" a triangle when it turns the triangle's normal by more than acos(0.2) ≈ 78°, not only
/// past 90°: a near-fold leaves a sliver standing across the surface. With 0 (a strict flip test, as
/// meshoptimizer's) cessna's mean error at 1 % of its triangles is 1.13–1.26× meshoptimizer's from run to
/// run of tuning; with 0.2, 1.10×; with 0.5 too many merges wait and thin parts suffer (1.29×).
const FOLD_COS: f32 = 0.2;

/// Why a triangle vanished in a merge (Tao et al.'s Fig. 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Vanish {
    /// Two of its corners became one vertex.
    Degenerate,
    /// It now has the same three corners as a surviving triangle.
    Coincident,
}

pub struct Collapser {
    /// Current position of each slot.
    pub positions: Vec<Vec3>,
    /// Current slot corners of each triangle (meaningless once it has vanished).
    corners: Vec<[u32; 3]>,
    alive_face: Vec<bool>,
    /// Triangles around each live slot (exact: a vanished triangle is unlinked from every corner).
    faces: Vec<FaceList>,
    /// Other partners of each slot: proximity pairs and loose edges, possibly naming merged slots.
    /// Boxed, because most slots have none: an empty `Vec` would cost 24 bytes a slot, `None` costs 8.
    #[allow(clippy::box_collection)] // deliberate: 8 bytes a slot instead of 24
    extras: Vec<Option<Box<Vec<u32>>>>,
    /// `VI`: the slot a merged slot went into, or `ALIVE`.
    merged_into: Vec<u32>,
    live: usize,
    /// Scratch: third corners of the triangles a merge made degenerate.
    loose: Vec<u32>,
}

/// The triangles around a slot: up to 14 in the list's own cache line, together with its length, so
/// that reading a list is one miss, not two (header, then contents); longer lists (high valence,
/// coarse levels) spill to the heap.
#[derive(Clone, Default)]
#[repr(align(64))]
struct FaceList(SmallVec<[u32; 14]>);

impl std::ops::Deref for FaceList {
    type Target = SmallVec<[u32; 14]>;
    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

impl std::ops::DerefMut for FaceList {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.0
    }
}

/// A partner of a slot, and whether an edge joins them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Neighbor {
    pub slot: u32,
    pub edge: bool,
}

impl Collapser {
    pub fn new(positions: Vec<Vec3>, triangles: &[[u32; 3]]) -> Collapser {
        let n = positions.len();
        let mut degree = vec![0u32; n];
        for t in triangles {
            for &v in t {
                degree[v as usize] += 1;
            }
        }
        let mut faces: Vec<FaceList> = degree
            .iter()
            .map(|&d| FaceList(SmallVec::with_capacity(d as usize)))
            .collect();
        for (f, t) in triangles.iter().enumerate() {
            for &v in t {
                faces[v as usize].push(f as u32);
            }
        }
        Collapser {
            positions,
            corners: triangles.to_vec(),
            alive_face: vec![true; triangles.len()],
            faces,
            extras: vec![None; n],
            merged_into: vec![ALIVE; n],
            live: n,
            loose: Vec::new(),
        }
    }

    pub fn live_count(&self) -> usize {
        self.live
    }

    /// Asks the memory system for what a merge or flip test of `slot` will read, a few merges
    /// ahead, in stages, each needing the previous one's data in cache to find its addresses: 0, the
    /// slot's list of triangles, position and extra partners; 1, the list's triangles' corners and
    /// liveness; 2, the corners' positions. Only a hint.
    pub fn prefetch(&self, slot: u32, stage: u32) {
        let s = slot as usize;
        match stage {
            0 => {
                crate::prefetch(&self.faces[s]);
                crate::prefetch(&self.positions[s]);
                crate::prefetch(&self.extras[s]);
            }
            1 => {
                for &f in self.faces[s].iter().take(16) {
                    crate::prefetch(&self.corners[f as usize]);
                    crate::prefetch(&self.alive_face[f as usize]);
                }
            }
            _ => {
                for &f in self.faces[s].iter().take(16) {
                    for v in self.corners[f as usize] {
                        crate::prefetch(&self.positions[v as usize]);
                    }
                }
            }
        }
    }

    /// [`Collapser::prefetch`] of both slots of a merge, plus, at stage 2 and later, the lists of
    /// the third corners of the triangles the merge will make degenerate (it unlinks them there).
    pub fn prefetch_pair(&self, a: u32, b: u32, stage: u32) {
        self.prefetch(a, stage);
        self.prefetch(b, stage);
        if stage < 2 {
            return;
        }
        for &f in self.faces[b as usize].iter().take(16) {
            let c = self.corners[f as usize];
            if c.contains(&a) {
                for v in c {
                    if v != a && v != b {
                        let list = &self.faces[v as usize];
                        crate::prefetch(list);
                        if stage > 2
                            && let Some(first) = list.first()
                        {
                            crate::prefetch(first);
                        }
                    }
                }
            }
        }
    }

    pub fn is_live(&self, slot: u32) -> bool {
        self.merged_into[slot as usize] == ALIVE
    }

    pub fn live_slots(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.merged_into.len() as u32).filter(|&s| self.is_live(s))
    }

    /// `g(v)`: the live slot that slot `v` has been merged into.
    pub fn find(&mut self, v: u32) -> u32 {
        let mut root = v;
        while self.merged_into[root as usize] != ALIVE {
            root = self.merged_into[root as usize];
        }
        let mut x = v;
        while self.merged_into[x as usize] != ALIVE {
            let next = self.merged_into[x as usize];
            self.merged_into[x as usize] = root;
            x = next;
        }
        root
    }

    fn extras_mut(&mut self, v: u32) -> &mut Vec<u32> {
        self.extras[v as usize].get_or_insert_with(Default::default)
    }

    /// Records a proximity pair (no edge between them) as a merge candidate.
    pub fn add_proximity_pair(&mut self, a: u32, b: u32) {
        self.extras_mut(a).push(b);
        self.extras_mut(b).push(a);
    }

    /// Every live triangle, as its index and current slot corners.
    pub fn live_faces(&self) -> impl Iterator<Item = (u32, [u32; 3])> + '_ {
        self.alive_face
            .iter()
            .enumerate()
            .filter(|&(_, &alive)| alive)
            .map(|(f, _)| (f as u32, self.corners[f]))
    }

    /// The live triangles around a live slot, as current slot corners.
    pub fn faces_of(&self, slot: u32) -> impl Iterator<Item = (u32, [u32; 3])> + Clone + '_ {
        // Lists are exact: `unify` unlinks a vanished triangle from all its corners at once.
        self.faces[slot as usize].iter().map(|&f| {
            debug_assert!(self.alive_face[f as usize]);
            (f, self.corners[f as usize])
        })
    }

    /// Removes triangle `f` from the list of slot `v` (keeping the order of the rest).
    fn unlink(&mut self, v: u32, f: u32) {
        let list = &mut self.faces[v as usize];
        if let Some(i) = list.iter().position(|&x| x == f) {
            list.remove(i);
        }
    }

    /// `g(v)` without path compression, for readers that share the collapser across threads.
    pub fn root(&self, v: u32) -> u32 {
        let mut r = v;
        while self.merged_into[r as usize] != ALIVE {
            r = self.merged_into[r as usize];
        }
        r
    }

    /// How many triangles are listed around a live slot (some may have vanished since it last merged):
    /// a cheap estimate of its valence.
    pub fn face_count(&self, slot: u32) -> usize {
        self.faces[slot as usize].len()
    }

    /// Every slot joined to `slot` by a triangle, a loose edge or a proximity pair, once
    /// ([`dedup_neighbors`]: the order carries no meaning).
    pub fn neighbors(&self, slot: u32, out: &mut Vec<Neighbor>) {
        let triangles = self.faces_of(slot).map(|(_, c)| c);
        gather_neighbors(slot, triangles, self.extra_neighbors(slot), out);
    }

    /// The partners of `slot` by loose edges and proximity pairs (possibly also joined by a
    /// triangle, possibly repeated).
    pub fn extra_neighbors(&self, slot: u32) -> impl Iterator<Item = Neighbor> + '_ {
        self.extras[slot as usize]
            .as_deref()
            .map_or(&[][..], |v| &v[..])
            .iter()
            .map(|&e| Neighbor {
                slot: self.root(e & SLOT_MASK),
                edge: e & LOOSE_EDGE != 0,
            })
            .filter(move |n| n.slot != slot)
    }

    /// `vunify`: merges live slot `b` into live slot `a`, which moves to `position`. Triangles that
    /// vanish are appended to `removed` with the reason. Returns nothing else: the caller reads the
    /// new neighbourhood with [`Collapser::neighbors`].
    pub fn unify(&mut self, a: u32, b: u32, position: Vec3, removed: &mut Vec<(u32, Vanish)>) {
        debug_assert!(a != b && self.is_live(a) && self.is_live(b));
        let (ai, bi) = (a as usize, b as usize);
        self.positions[ai] = position;
        let mut around_a = std::mem::take(&mut self.faces[ai]);
        let first_moved = around_a.len();
        let around_b = std::mem::take(&mut self.faces[bi]);
        for f in around_b.0 {
            let fi = f as usize;
            let c = &mut self.corners[fi];
            if c.contains(&a) {
                // Degenerate (Fig. 3a). Its third corner keeps an edge to the merged vertex, which must
                // stay a candidate even if no other triangle carries that edge (checked below).
                self.alive_face[fi] = false;
                removed.push((f, Vanish::Degenerate));
                let other = c
                    .iter()
                    .copied()
                    .find(|&v| v != a && v != b)
                    .expect("a triangle has 3 distinct corners");
                self.loose.push(other);
                self.unlink(other, f);
                continue;
            }
            for v in c.iter_mut() {
                if *v == b {
                    *v = a;
                }
            }
            around_a.push(f);
        }
        // Coincident triangles (Fig. 3b): a new duplicate has the merged vertex as a corner and came
        // from `b` (the triangles around `a` were distinct, as were those around `b`). Of equal
        // triangles the first in the list survives, the one that was around `a`; the others vanish in
        // the order of their sorted corners.
        let others = |c: [u32; 3]| {
            let [x, y] = match c.iter().position(|&v| v == a) {
                Some(0) => [c[1], c[2]],
                Some(1) => [c[0], c[2]],
                _ => [c[0], c[1]],
            };
            [x.min(y), x.max(y)]
        };
        let pairs: SmallVec<[[u32; 2]; 24]> = around_a
            .iter()
            .map(|&f| others(self.corners[f as usize]))
            .collect();
        let mut coincident: SmallVec<[([u32; 3], u32); 4]> = SmallVec::new();
        for i in first_moved..around_a.len() {
            if pairs[..i].contains(&pairs[i]) {
                let mut key = self.corners[around_a[i] as usize];
                key.sort_unstable();
                coincident.push((key, around_a[i]));
            }
        }
        coincident.sort_unstable();
        for &(_, f) in &coincident {
            self.alive_face[f as usize] = false;
            removed.push((f, Vanish::Coincident));
            for v in self.corners[f as usize] {
                if v != a {
                    self.unlink(v, f);
                }
            }
        }
        around_a.retain(|f| self.alive_face[*f as usize]);
        // A loose edge only where no surviving triangle still carries the edge: almost always one does,
        // and redundant entries would be re-sorted and re-searched at every later merge.
        let mut loose = std::mem::take(&mut self.loose);
        for &other in &loose {
            if !around_a
                .iter()
                .any(|&f| self.corners[f as usize].contains(&other))
            {
                self.extras_mut(a).push(other | LOOSE_EDGE);
                self.extras_mut(other).push(a | LOOSE_EDGE);
            }
        }
        loose.clear();
        self.loose = loose;
        self.faces[ai] = around_a;

        let moved = self.extras[bi].take();
        if let Some(moved) = moved {
            self.extras_mut(a).extend(moved.iter().copied());
        }
        self.merged_into[bi] = a;
        self.live -= 1;
        // Canonical extras: live slots, no self, one entry per partner (edge wins).
        let Some(mut extras) = self.extras[ai].take() else {
            return;
        };
        for e in extras.iter_mut() {
            *e = self.find(*e & SLOT_MASK) | (*e & LOOSE_EDGE);
        }
        extras.retain(|&e| e & SLOT_MASK != a);
        extras.sort_unstable_by_key(|&e| (e & SLOT_MASK, e & LOOSE_EDGE == 0));
        extras.dedup_by_key(|e| *e & SLOT_MASK);
        if !extras.is_empty() {
            self.extras[ai] = Some(extras);
        }
    }

    /// Would moving slots `a` and `b` to `p` turn any surviving triangle around them upside down?
    pub fn flips(&self, a: u32, b: u32, p: Vec3) -> bool {
        for s in [a, b] {
            for (_, c) in self.faces_of(s) {
                if c.contains(&a) && c.contains(&b) {
                    continue; // vanishes
                }
                let q = c.map(|v| self.positions[v as usize]);
                let before = (q[1] - q[0]).cross(q[2] - q[0]);
                let moved = c.map(|v| {
                    if v == a || v == b {
                        p
                    } else {
                        self.positions[v as usize]
                    }
                });
                let after = (moved[1] - moved[0]).cross(moved[2] - moved[0]);
                // cos(before, after) < FOLD_COS, without the square roots.
                let dot = before.dot(after);
                if dot < 0.0
                    || dot * dot
                        < FOLD_COS * FOLD_COS * before.length_squared() * after.length_squared()
                {
                    return true;
                }
            }
        }
        false
    }
}

/// Into `out` (emptied first): the other corners of `triangles` around `slot`, joined to it by edges,
/// and its `extras`, each slot once ([`dedup_neighbors`]). What [`Collapser::neighbors`] reads from
/// the working mesh, from copies of it.
pub fn gather_neighbors(
    slot: u32,
    triangles: impl Iterator<Item = [u32; 3]>,
    extras: impl Iterator<Item = Neighbor>,
    out: &mut Vec<Neighbor>,
) {
    out.clear();
    out.extend(
        triangles
            .flatten()
            .filter(|&v| v != slot)
            .map(|v| Neighbor {
                slot: v,
                edge: true,
            }),
    );
    out.extend(extras);
    dedup_neighbors(out);
}

/// Keeps each slot of `list` once, as an edge if any of its entries is one. A vertex's partners
/// (each met twice around its fan) are few: a scan of those kept, in the order first met, is
/// cheaper than sorting them; long lists are sorted by slot.
pub fn dedup_neighbors(list: &mut Vec<Neighbor>) {
    if list.len() > 48 {
        // Edges sort before non-edges of the same slot, so dedup keeps the edge.
        list.sort_unstable_by_key(|n| (n.slot, !n.edge));
        list.dedup_by_key(|n| n.slot);
        return;
    }
    let mut kept = 0;
    // One bit per slot modulo 64 of those kept: a clear bit means a new slot, no scan needed.
    let mut seen = 0u64;
    for i in 0..list.len() {
        let n = list[i];
        let bit = 1u64 << (n.slot % 64);
        let known = if seen & bit != 0 {
            list[..kept].iter_mut().rev().find(|k| k.slot == n.slot)
        } else {
            None
        };
        match known {
            Some(k) => k.edge |= n.edge,
            None => {
                list[kept] = n;
                kept += 1;
                seen |= bit;
            }
        }
    }
    list.truncate(kept);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tao et al.'s Fig. 2 ([`crate::fixtures::fig2`]): a tetrahedron 0 1 2 3 (faces 0-3) beside a
    /// separate triangle 4 5 6 (face 4).
    /// `vunify(2, 3)` collapses the tetrahedron to the triangle 0 1 2: faces 0-2-3 and 1-2-3 degenerate,
    /// face 0-1-3 becomes 0-1-2, coincident with face 0-1-2. So 1 vertex, 3 edges (2-3 vanishes, 0-3
    /// and 1-3 fold onto 0-2 and 1-2) and 3 triangles vanish. The paper counts 4 triangles and 4 edges
    /// for its figure; with a triangle left over, as the paper says there is, 3 is the count that holds.
    #[test]
    fn fig2_tetrahedron_collapses_to_a_triangle() {
        let fig2 = crate::fixtures::fig2();
        let mut c = Collapser::new(fig2.positions, &fig2.triangles);
        let mut removed = Vec::new();
        c.unify(2, 3, Vec3::new(1.5, 0.0, 0.5), &mut removed);
        removed.sort_unstable_by_key(|r| r.0);
        assert_eq!(
            removed,
            vec![
                (1, Vanish::Coincident),
                (2, Vanish::Degenerate),
                (3, Vanish::Degenerate)
            ]
        );
        assert_eq!(c.live_count(), 6);
        let left: Vec<_> = (0..7)
            .filter(|&s| c.is_live(s))
            .flat_map(|s| c.faces_of(s).map(|f| f.0).collect::<Vec<_>>())
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        assert_eq!(left, vec![0, 4]);
        let mut n = Vec::new();
        c.neighbors(2, &mut n);
        n.sort_unstable_by_key(|n| n.slot);
        assert_eq!(
            n,
            vec![
                Neighbor {
                    slot: 0,
                    edge: true
                },
                Neighbor {
                    slot: 1,
                    edge: true
                }
            ]
        );
        // Vertex 3 was merged into 2: g(3) = 2.
        assert_eq!(c.find(3), 2);
    }

    /// Merging across a gap: vertex 2 of one triangle with vertex 3 of another (no edge) joins the two
    /// parts at one vertex, and no triangle vanishes.
    /// ```text
    ///   1        4             1     4
    ///   | \    / |             | \ / |
    ///   0--2  3--5     →       0--2--5
    /// ```
    #[test]
    fn merge_without_an_edge_changes_topology() {
        let p = vec![
            Vec3::ZERO,
            Vec3::Y,
            Vec3::X,
            Vec3::X * 1.1,
            Vec3::new(2.0, 1.0, 0.0),
            Vec3::X * 2.0,
        ];
        let mut c = Collapser::new(p, &[[0, 2, 1], [3, 5, 4]]);
        c.add_proximity_pair(2, 3);
        let mut n = Vec::new();
        c.neighbors(2, &mut n);
        n.sort_unstable_by_key(|n| n.slot);
        assert_eq!(
            n[2],
            Neighbor {
                slot: 3,
                edge: false
            }
        );
        let mut removed = Vec::new();
        c.unify(2, 3, Vec3::X * 1.05, &mut removed);
        assert!(removed.is_empty());
        c.neighbors(2, &mut n);
        n.sort_unstable_by_key(|n| n.slot);
        assert_eq!(
            n.iter().map(|n| n.slot).collect::<Vec<_>>(),
            vec![0, 1, 4, 5]
        );
        assert!(n.iter().all(|n| n.edge));
    }

    #[test]
    fn a_degenerate_triangle_leaves_a_loose_edge() {
        // One triangle; merging 0 and 1 leaves the segment 0-2, still a candidate edge.
        let mut c = Collapser::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], &[[0, 1, 2]]);
        let mut removed = Vec::new();
        c.unify(0, 1, Vec3::ZERO, &mut removed);
        assert_eq!(removed, vec![(0, Vanish::Degenerate)]);
        let mut n = Vec::new();
        c.neighbors(0, &mut n);
        n.sort_unstable_by_key(|n| n.slot);
        assert_eq!(
            n,
            vec![Neighbor {
                slot: 2,
                edge: true
            }]
        );
        c.neighbors(2, &mut n);
        n.sort_unstable_by_key(|n| n.slot);
        assert_eq!(
            n,
            vec![Neighbor {
                slot: 0,
                edge: true
            }]
        );
    }
}

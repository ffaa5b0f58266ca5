//! Liu Xuehui and Wu Enhua's simplification of radiosity meshes ( *A simplification
//! method for radiosity global-illumination meshes*): coplanar patches of similar radiosity merge
//! into **superfaces**; the chains of edges between superfaces are straightened where colour and
//! shape allow; each superface is triangulated anew (holes bridged, then ear clipping: `earclip`).
//!
//! Readings of the paper, as vunify implements them:
//! - A patch is a triangle; its radiosity `B` is the mean of its corners' display colours (0–255),
//!   the C0 interpolation the lit mesh carries. Radiosities below one display step count as one, so
//!   black patches do not divide by zero.
//! - `C_i = max_j |B_i − B_j| / ((A_i + A_j) · B_i)` over the coplanar edge neighbours `j`, with
//!   areas in units of the mesh's **mean triangle area**, which makes ε free of the scene's units
//!   (the paper's 0.06–0.8 then means "a change of 6–80 % across two average patches").
//! - Superfaces are planar: only coplanar patches (normals within 10⁻⁶, planes within 10⁻⁶ of the
//!   diagonal) merge. Seeds are taken in increasing `C` (largest of R, G, B); a merged patch is never a
//!   seed again. A boundary patch `P` joins superface `S` when, in every channel,
//!   `C_P < ε` and `(C_P A_P + C_S A_S) / (A_P + A_S) < ε`, or else
//!   `C'_P = max(|B_P − B_S| / (2 A_P B_P), |B_P − B_S| / (2 A_P B_S)) < ε` — the text's `C_P` in
//!   the first test, where the paper's pseudo-code reads `C'_P`. One departure: the paper's `C'_P`
//!   divides by `A_P + A_S`, which shrinks as the superface grows until every patch passes (on the
//!   Cornell box, each wall became one superface at every ε); vunify measures the patch against the
//!   superface's mean radiosity at the patch's own scale, `2 A_P`.
//! - A superface may close round a region, which becomes a hole (first touching the outer ring at
//!   the corner where it closed). Each superface's triangulation is checked (counter-clockwise in
//!   exact arithmetic, the rings' area); the few that fail are grown again as discs, where a patch
//!   whose third corner already lies on the superface waits until it joins along two edges.
//! - Boundary chains (runs of edges between the same two superfaces, or on the mesh's border) are
//!   simplified once and shared by both sides, so no crack opens between them.

mod promise;

use super::earclip::{bridge, ear_clip};
use crate::mesh::Mesh;
use glam::{DVec2, DVec3, Vec3};
use promise::{Fit, colour_error};
use std::collections::{HashMap, HashSet};

/// Settings of a superface simplification.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SuperfaceOptions {
    /// ε: the merge threshold on the normalised relative radiosity change.
    pub epsilon: f64,
    /// δ: the largest colour error (0–255 display units, any channel) of a removed boundary vertex.
    pub delta: f64,
    /// The largest distance of a removed boundary vertex from its new edge, as a share of the
    /// mesh's diagonal (0: only vertices on a straight line go).
    pub distance: f64,
    /// Keep every superface a disc (no holes): more triangles, but no long triangles bridging a
    /// hole's colours to the outer ring's (about 3–5 dB of PSNR on the bundled scenes).
    pub discs: bool,
}

/// What a run did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SuperfaceStats {
    pub triangles_in: usize,
    pub triangles_out: usize,
    pub superfaces: usize,
    /// Holes in superfaces (a superface that grew round another), bridged to their outer rings.
    pub holes: usize,
    /// Output triangles over input triangles.
    pub ratio: f64,
    pub seconds: f64,
    /// The colour error of the result against the lit mesh at the lit mesh's vertices: the
    /// largest and the mean over vertices of `|drawn − lit| / max(lit, floor)`, largest channel,
    /// on linear radiosity where the mesh has it (else on display colour). The merge test keeps the
    /// largest at most ε (see `promise.rs`).
    pub color_error_max: f64,
    pub color_error_mean: f64,
}

/// Why a mesh cannot be simplified this way.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum SuperfaceError {
    #[error("the mesh has no vertex colours: superfaces need a lit mesh (vunify radiosity)")]
    NoColours,
    #[error("the mesh has no triangles")]
    Empty,
    #[error("{0} must be at least 0 and finite")]
    Negative(&'static str),
}

/// The superfaces of a mesh: which superface each triangle joined (the first growth, where any
/// superface may close round a hole).
pub fn superfaces(mesh: &Mesh, epsilon: f64) -> Result<Vec<u32>, SuperfaceError> {
    let patches = Patches::new(mesh)?;
    Ok(patches.grow(epsilon))
}

/// Simplifies a lit mesh: superfaces, boundary chains, triangulation.
pub fn simplify_superfaces(
    mesh: &Mesh,
    options: &SuperfaceOptions,
) -> Result<(Mesh, SuperfaceStats), SuperfaceError> {
    simplify_superfaces_owned(mesh, options).map(|(out, stats, _)| (out, stats))
}

/// [`simplify_superfaces`], also telling which superface each input triangle ended in (after any
/// superfaces were grown again as discs, unlike [`superfaces`]).
pub fn simplify_superfaces_owned(
    mesh: &Mesh,
    options: &SuperfaceOptions,
) -> Result<(Mesh, SuperfaceStats, Vec<u32>), SuperfaceError> {
    let start = std::time::Instant::now();
    for (name, v) in [
        ("epsilon", options.epsilon),
        ("delta", options.delta),
        ("distance", options.distance),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(SuperfaceError::Negative(name));
        }
    }
    let patches = Patches::new(mesh)?;
    // Superfaces may close round a hole, touching themselves at a corner first; the few whose
    // rings then touch in ways the triangulation cannot cut cleanly (holes touching holes, a hole
    // pinched in two) are grown again as discs. Each round only adds seeds to `discs`; the last
    // keeps every superface a disc, which always triangulates.
    let mut discs: HashSet<u32> = HashSet::new();
    let mut round = 0;
    let (count, triangles, holes, owner) = loop {
        let all_discs = options.discs || round == MAX_ROUNDS;
        let mut seeds: Vec<u32> = Vec::new();
        let owner = patches.grow_with(
            options.epsilon,
            &|seed| all_discs || discs.contains(&seed),
            &mut |s, p| {
                if seeds.len() == s as usize {
                    seeds.push(p);
                }
            },
        );
        let (triangles, failed, holes) = triangulate_all(&patches, &owner, seeds.len(), options);
        if failed.is_empty() || all_discs {
            break (seeds.len(), triangles, holes, owner);
        }
        discs.extend(failed.iter().map(|&s| seeds[s]));
        round += 1;
    };
    let out = compact(mesh, triangles);
    let (color_error_max, color_error_mean) = colour_error(&patches, &out);
    let stats = SuperfaceStats {
        triangles_in: mesh.triangle_count(),
        triangles_out: out.triangle_count(),
        superfaces: count,
        holes,
        ratio: out.triangle_count() as f64 / mesh.triangle_count().max(1) as f64,
        seconds: start.elapsed().as_secs_f64(),
        color_error_max,
        color_error_mean,
    };
    Ok((out, stats, owner))
}

/// Rounds of growth before every superface is kept a disc (the Cornell box, the room and the
/// office need at most two).
const MAX_ROUNDS: usize = 4;

/// Boundary chains simplified and every superface triangulated; with the superfaces whose
/// triangulation failed its check (an inverted triangle, or area other than the rings'), and the
/// number of holes.
fn triangulate_all(
    patches: &Patches,
    owner: &[u32],
    count: usize,
    options: &SuperfaceOptions,
) -> (Vec<[u32; 3]>, Vec<usize>, usize) {
    let mesh = patches.mesh;
    let loops = boundary_loops(mesh, owner, count);
    let mut kept = simplify_chains(patches, &loops, options);
    // A ring straightened to fewer than 3 corners (a superface between only two chains) keeps three
    // corners of its hull, which span a triangle; `kept` is shared, so the superface across keeps
    // them too.
    for ring in loops.iter().flatten() {
        if ring.iter().filter(|e| kept[e.from as usize]).count() < 3 && ring.len() >= 3 {
            let at = |i: usize| mesh.positions[ring[i].from as usize].as_dvec3();
            for i in hull_corners(ring.len(), at) {
                kept[ring[i].from as usize] = true;
            }
        }
    }
    // A lit mesh keeps each polygon's vertices apart (they carry its own colours), so where two
    // polygons meet along a crease, each side's chain is decided on its own: a corner kept on one
    // side is kept on the other, or the other's straightened edge would pass by it (a T-junction).
    let at = |v: u32| mesh.positions[v as usize].to_array().map(f32::to_bits);
    let mut kept_at: HashMap<[u32; 3], bool> = HashMap::new();
    for e in loops.iter().flatten().flatten() {
        *kept_at.entry(at(e.from)).or_default() |= kept[e.from as usize];
    }
    for e in loops.iter().flatten().flatten() {
        kept[e.from as usize] |= kept_at[&at(e.from)];
    }
    let mut triangles = Vec::new();
    let mut failed = Vec::new();
    let mut holes = 0;
    for (s, rings) in loops.iter().enumerate() {
        let rings: Vec<Vec<u32>> = rings
            .iter()
            .map(|r| {
                r.iter()
                    .map(|e| e.from)
                    .filter(|v| kept[*v as usize])
                    .collect::<Vec<_>>()
            })
            .filter(|r| r.len() >= 3)
            .collect();
        let (tris, ok) = triangulate(patches, s, owner, &rings);
        if !ok {
            failed.push(s);
        }
        triangles.extend(tris);
        holes += rings.len().saturating_sub(1);
    }
    (triangles, failed, holes)
}

/// The mesh's triangles as patches: radiosity, normalised area, plane, neighbours.
struct Patches<'a> {
    mesh: &'a Mesh,
    /// Each vertex's display colour, 0–255 (what δ is measured in).
    colour: Vec<DVec3>,
    /// Each vertex's value for the merge test: linear radiosity where the mesh has it, else the
    /// display colour (0–255).
    value: Vec<DVec3>,
    /// Values below this count as it in relative terms (one display step at the bright end), so
    /// black patches do not divide by zero.
    floor: f64,
    b: Vec<DVec3>,
    area: Vec<f64>,
    normal: Vec<DVec3>,
    neighbours: Vec<Vec<u32>>,
    diagonal: f64,
}

impl<'a> Patches<'a> {
    fn new(mesh: &'a Mesh) -> Result<Patches<'a>, SuperfaceError> {
        let colours = mesh.colors.as_ref().ok_or(SuperfaceError::NoColours)?;
        if mesh.triangles.is_empty() {
            return Err(SuperfaceError::Empty);
        }
        let colour: Vec<DVec3> = colours.iter().map(|c| c.as_dvec3() * 255.0).collect();
        let value: Vec<DVec3> = match &mesh.radiosity {
            Some(r) => r.iter().map(|c| c.as_dvec3()).collect(),
            None => colour.clone(),
        };
        let floor = match &mesh.radiosity {
            // One 8-bit step of the 99th percentile of the brightest channel (emitters, far
            // brighter than what they light, left out by the percentile).
            Some(_) => {
                let mut bright: Vec<f64> = value.iter().map(|v| v.max_element()).collect();
                let k = (bright.len() * 99 / 100).min(bright.len().saturating_sub(1));
                let (_, at, _) = bright.select_nth_unstable_by(k, f64::total_cmp);
                (*at / 255.0).max(f64::MIN_POSITIVE)
            }
            None => 1.0,
        };
        let p = |v: u32| mesh.positions[v as usize].as_dvec3();
        let mut area = Vec::with_capacity(mesh.triangles.len());
        let mut normal = Vec::with_capacity(mesh.triangles.len());
        let mut b = Vec::with_capacity(mesh.triangles.len());
        let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
        for (f, t) in mesh.triangles.iter().enumerate() {
            let n = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
            area.push(0.5 * n.length());
            normal.push(n.normalize_or_zero());
            b.push(t.iter().map(|&v| value[v as usize]).sum::<DVec3>() / 3.0);
            for k in 0..3 {
                let (x, y) = (t[k], t[(k + 1) % 3]);
                edges
                    .entry((x.min(y), x.max(y)))
                    .or_default()
                    .push(f as u32);
            }
        }
        let mean = area.iter().sum::<f64>() / area.len() as f64;
        for a in &mut area {
            *a /= mean.max(f64::MIN_POSITIVE);
        }
        let mut neighbours = vec![Vec::new(); mesh.triangles.len()];
        for faces in edges.values() {
            for &f in faces {
                for &g in faces {
                    if f != g {
                        neighbours[f as usize].push(g);
                    }
                }
            }
        }
        // In face order, whatever order the edge map gave: the growth (and so the output) is the
        // same on every run.
        for list in &mut neighbours {
            list.sort_unstable();
            list.dedup();
        }
        let (lo, hi) = mesh.bounds();
        Ok(Patches {
            mesh,
            colour,
            value,
            floor,
            b,
            area,
            normal,
            neighbours,
            diagonal: (hi.as_dvec3() - lo.as_dvec3()).length(),
        })
    }

    fn coplanar(&self, f: u32, g: u32) -> bool {
        let (f, g) = (f as usize, g as usize);
        if self.normal[f].dot(self.normal[g]) < 1.0 - 1e-6 {
            return false;
        }
        let t = self.mesh.triangles[g];
        let origin = self.mesh.positions[self.mesh.triangles[f][0] as usize].as_dvec3();
        t.iter().all(|&v| {
            (self.mesh.positions[v as usize].as_dvec3() - origin)
                .dot(self.normal[f])
                .abs()
                <= 1e-6 * self.diagonal
        })
    }

    /// `C_i` per channel.
    fn change(&self) -> Vec<DVec3> {
        (0..self.b.len())
            .map(|i| {
                self.neighbours[i]
                    .iter()
                    .filter(|&&j| self.coplanar(i as u32, j))
                    .map(|&j| {
                        let j = j as usize;
                        (self.b[i] - self.b[j]).abs()
                            / ((self.area[i] + self.area[j])
                                * self.b[i].max(DVec3::splat(self.floor)))
                    })
                    .fold(DVec3::ZERO, DVec3::max)
            })
            .collect()
    }

    /// Grows the superfaces; returns each triangle's superface.
    fn grow(&self, epsilon: f64) -> Vec<u32> {
        self.grow_with(epsilon, &|_| false, &mut |_, _| {})
    }

    /// [`Patches::grow`], keeping the superfaces grown from the seeds `disc` picks discs, and
    /// telling `joined(superface, patch)` of each patch as it joins, each superface's seed first (the
    /// tests replay the merges against the paper's rule).
    fn grow_with(
        &self,
        epsilon: f64,
        disc: &dyn Fn(u32) -> bool,
        joined: &mut dyn FnMut(u32, u32),
    ) -> Vec<u32> {
        let c = self.change();
        let mut order: Vec<u32> = (0..self.b.len() as u32).collect();
        order.sort_by(|&x, &y| {
            c[x as usize]
                .max_element()
                .total_cmp(&c[y as usize].max_element())
                .then(x.cmp(&y))
        });
        let mut owner = vec![u32::MAX; self.b.len()];
        let mut tried = vec![u32::MAX; self.b.len()];
        // The superface each vertex was last reached by, to keep a superface a disc.
        let mut reached = vec![u32::MAX; self.mesh.positions.len()];
        let mut count = 0u32;
        for seed in order {
            if owner[seed as usize] != u32::MAX {
                continue;
            }
            let s = count;
            count += 1;
            let keep_disc = disc(seed);
            owner[seed as usize] = s;
            joined(s, seed);
            for v in self.mesh.triangles[seed as usize] {
                reached[v as usize] = s;
            }
            let i = seed as usize;
            let (mut bs, mut cs, mut a_s) = (self.b[i], c[i], self.area[i]);
            let mut fit = Fit::new(self, seed, epsilon);
            let mut frontier: Vec<u32> = self.neighbours[i].clone();
            while let Some(p) = frontier.pop() {
                let pi = p as usize;
                if owner[pi] != u32::MAX || tried[pi] == s || !self.coplanar(seed, p) {
                    continue;
                }
                // A disc stays a disc when the patch joins along one edge with its third corner
                // new, or along two: a third corner already on the superface pinches it, and
                // closes it round a hole.
                let shared_edges = self.neighbours[pi]
                    .iter()
                    .filter(|&&g| owner[g as usize] == s)
                    .count();
                let shared_corners = self.mesh.triangles[pi]
                    .iter()
                    .filter(|&&v| reached[v as usize] == s)
                    .count();
                if keep_disc && shared_edges == 1 && shared_corners == 3 {
                    continue;
                }
                tried[pi] = s;
                let (bp, cp, ap) = (self.b[pi], c[pi], self.area[pi]);
                let diff = (bp - bs).abs();
                // The paper divides by (A_P + A_S); with A_S the whole superface, that test passes
                // any patch once a superface is large (a whole wall merged at every ε), so the
                // superface enters at the patch's own scale: 2 A_P.
                let floor = DVec3::splat(self.floor);
                let c_prime =
                    (diff / (2.0 * ap * bp.max(floor))).max(diff / (2.0 * ap * bs.max(floor)));
                let joint = (cp * ap + cs * a_s) / (ap + a_s);
                let passes =
                    (0..3).all(|k| (cp[k] < epsilon && joint[k] < epsilon) || c_prime[k] < epsilon);
                if !passes {
                    continue;
                }
                // And the superface's promise: every value on it stays in its window.
                if !fit.join(self, p) {
                    continue;
                }
                owner[pi] = s;
                joined(s, p);
                for v in self.mesh.triangles[pi] {
                    reached[v as usize] = s;
                }
                bs = (bs * a_s + bp * ap) / (a_s + ap);
                cs = joint;
                a_s += ap;
                frontier.extend(self.neighbours[pi].iter().copied());
            }
        }
        owner
    }
}

/// A directed boundary edge of a superface and what lies across it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Edge {
    from: u32,
    to: u32,
    /// The superface across, or `u32::MAX` on the mesh's border.
    across: u32,
}

/// Each superface's boundary loops (directed as its triangles wind).
fn boundary_loops(mesh: &Mesh, owner: &[u32], count: usize) -> Vec<Vec<Vec<Edge>>> {
    let mut faces_on: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (f, t) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let (x, y) = (t[k], t[(k + 1) % 3]);
            faces_on
                .entry((x.min(y), x.max(y)))
                .or_default()
                .push(f as u32);
        }
    }
    let mut edges: Vec<Vec<Edge>> = vec![Vec::new(); count];
    for (f, t) in mesh.triangles.iter().enumerate() {
        let s = owner[f];
        for k in 0..3 {
            let (x, y) = (t[k], t[(k + 1) % 3]);
            let others: Vec<u32> = faces_on[&(x.min(y), x.max(y))]
                .iter()
                .copied()
                .filter(|&g| g != f as u32)
                .collect();
            if others.iter().any(|&g| owner[g as usize] == s) {
                continue;
            }
            let across = others.first().map_or(u32::MAX, |&g| owner[g as usize]);
            edges[s as usize].push(Edge {
                from: x,
                to: y,
                across,
            });
        }
    }
    edges
        .into_iter()
        .map(|list| {
            let mut next: HashMap<u32, Vec<usize>> = HashMap::new();
            for (i, e) in list.iter().enumerate() {
                next.entry(e.from).or_default().push(i);
            }
            let mut used = vec![false; list.len()];
            let mut loops = Vec::new();
            for first in 0..list.len() {
                if used[first] {
                    continue;
                }
                let mut ring = Vec::new();
                let mut i = first;
                loop {
                    used[i] = true;
                    ring.push(list[i]);
                    let Some(&j) = next
                        .get(&list[i].to)
                        .and_then(|c| c.iter().find(|&&j| !used[j]))
                    else {
                        break;
                    };
                    i = j;
                }
                loops.push(ring);
            }
            loops
        })
        .collect()
}

/// Three corners of the convex hull of points `0..len` (by `at`), found alike from any starting
/// point: the lexicographically largest, the one farthest from it, the one farthest from their line.
fn hull_corners(len: usize, at: impl Fn(usize) -> DVec3) -> [usize; 3] {
    let first = (0..len)
        .max_by(|&a, &b| {
            let (p, q) = (at(a), at(b));
            p.x.total_cmp(&q.x)
                .then(p.y.total_cmp(&q.y))
                .then(p.z.total_cmp(&q.z))
        })
        .unwrap_or(0);
    let far =
        |d: &dyn Fn(usize) -> f64| (0..len).max_by(|&a, &b| d(a).total_cmp(&d(b))).unwrap_or(0);
    let second = far(&|i| at(i).distance_squared(at(first)));
    let axis = (at(second) - at(first)).normalize_or_zero();
    let third = far(&|i| {
        let r = at(i) - at(first);
        (r - axis * r.dot(axis)).length_squared()
    });
    [first, second, third]
}

/// Which vertices stay after boundary simplification: chain ends always; inner chain vertices where
/// the recursive straightening needs them. Every chain is decided once, in a direction that does
/// not depend on the side it is seen from.
fn simplify_chains(
    patches: &Patches,
    loops: &[Vec<Vec<Edge>>],
    options: &SuperfaceOptions,
) -> Vec<bool> {
    let n = patches.mesh.positions.len();
    let mut kept = vec![false; n];
    let mut boundary = vec![false; n];
    for rings in loops {
        // Chain ends: where what lies across changes, or a vertex the superface's rings pass twice
        // (where a hole touches the outer ring, or a ring itself).
        let mut seen: HashMap<u32, usize> = HashMap::new();
        for e in rings.iter().flatten() {
            *seen.entry(e.from).or_default() += 1;
        }
        for ring in rings {
            for e in ring {
                boundary[e.from as usize] = true;
            }
            let len = ring.len();
            let mut ends: Vec<usize> = (0..len)
                .filter(|&i| {
                    ring[(i + len - 1) % len].across != ring[i].across || seen[&ring[i].from] > 1
                })
                .collect();
            if ends.is_empty() {
                // A closed loop with one neighbour: cut it at three corners of its convex hull (the
                // lexicographically largest vertex, the one farthest from it, the one farthest from
                // their line), which both sides of the loop find alike.
                let at = |i: usize| patches.mesh.positions[ring[i].from as usize].as_dvec3();
                ends = hull_corners(len, at).to_vec();
                ends.sort_unstable();
                ends.dedup();
            }
            for (k, &a) in ends.iter().enumerate() {
                let b = ends[(k + 1) % ends.len()];
                let mut chain: Vec<u32> = Vec::new();
                let mut i = a;
                loop {
                    chain.push(ring[i].from);
                    i = (i + 1) % len;
                    if i == b {
                        chain.push(ring[i].from);
                        break;
                    }
                }
                if chain.first() > chain.last() {
                    chain.reverse();
                }
                for v in straighten(patches, &chain, options) {
                    kept[v as usize] = true;
                }
            }
        }
    }
    // Interior vertices of superfaces are gone either way; keep every non-boundary vertex marked
    // false.
    for v in 0..n {
        if !boundary[v] {
            kept[v] = false;
        }
    }
    kept
}

/// The vertices of `chain` that stay: its ends, and recursively the worst inner vertex while some
/// inner vertex is farther than δ in colour, or than the distance bound in space, from the segment.
fn straighten(patches: &Patches, chain: &[u32], options: &SuperfaceOptions) -> Vec<u32> {
    let mut keep = vec![chain[0], chain[chain.len() - 1]];
    let mut stack = vec![(0usize, chain.len() - 1)];
    // A distance bound of 0 still tolerates rounding (10⁻⁹ of the diagonal), and keeps distances
    // ordered so that the farthest vertex is the one split at.
    let limit = (options.distance * patches.diagonal).max(1e-9 * patches.diagonal);
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let (pa, pb) = (
            patches.mesh.positions[chain[a] as usize].as_dvec3(),
            patches.mesh.positions[chain[b] as usize].as_dvec3(),
        );
        let (ca, cb) = (
            patches.colour[chain[a] as usize],
            patches.colour[chain[b] as usize],
        );
        let ab = pb - pa;
        let mut worst = (0.0, a);
        for (k, &v) in chain.iter().enumerate().take(b).skip(a + 1) {
            let p = patches.mesh.positions[v as usize].as_dvec3();
            let t = if ab.length_squared() > 0.0 {
                ((p - pa).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let colour = (patches.colour[v as usize] - ca.lerp(cb, t))
                .abs()
                .max_element();
            let distance = p.distance(pa + ab * t);
            // Scores over 1 fail; the worst is split at.
            let score = (colour / options.delta.max(1e-12)).max(distance / limit);
            if score > worst.0 {
                worst = (score, k);
            }
        }
        if worst.0 >= 1.0 {
            keep.push(chain[worst.1]);
            stack.push((a, worst.1));
            stack.push((worst.1, b));
        }
    }
    keep
}

/// Triangles of superface `s` from its rings (counter-clockwise outer, clockwise holes), and whether
/// they pass the check: all counter-clockwise, and covering the rings' area.
fn triangulate(
    patches: &Patches,
    s: usize,
    owner: &[u32],
    rings: &[Vec<u32>],
) -> (Vec<[u32; 3]>, bool) {
    let Some(f) = owner.iter().position(|&o| o as usize == s) else {
        return (Vec::new(), true);
    };
    let n = patches.normal[f];
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let mut points: Vec<DVec2> = Vec::new();
    let mut ids: Vec<u32> = Vec::new();
    let mut local: HashMap<u32, u32> = HashMap::new();
    let flat: Vec<Vec<u32>> = rings
        .iter()
        .map(|r| {
            r.iter()
                .map(|&g| {
                    *local.entry(g).or_insert_with(|| {
                        let p = patches.mesh.positions[g as usize].as_dvec3();
                        points.push(DVec2::new(p.dot(u), p.dot(v)));
                        ids.push(g);
                        ids.len() as u32 - 1
                    })
                })
                .collect()
        })
        .collect();
    let signed = |r: &[u32]| -> f64 {
        (0..r.len())
            .map(|i| points[r[i] as usize].perp_dot(points[r[(i + 1) % r.len()] as usize]))
            .sum::<f64>()
            * 0.5
    };
    let Some(outer) =
        (0..flat.len()).max_by(|&a, &b| signed(&flat[a]).total_cmp(&signed(&flat[b])))
    else {
        return (Vec::new(), true);
    };
    let holes: Vec<Vec<u32>> = (0..flat.len())
        .filter(|&i| i != outer && signed(&flat[i]) < 0.0)
        .map(|i| flat[i].clone())
        .collect();
    let polygon = bridge(&points, &flat[outer], &holes);
    let tris = ear_clip(&points, &polygon);
    // The check: every triangle counter-clockwise (exactly), and their area the rings' area.
    let twice = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| points[i as usize]);
        (b - a).perp_dot(c - a)
    };
    let want: f64 = signed(&flat[outer]) + holes.iter().map(|h| signed(h)).sum::<f64>();
    let got: f64 = tris.iter().map(|t| 0.5 * twice(t).abs()).sum();
    let ok = tris.iter().all(|t| {
        let [a, b, c] = t.map(|i| robust::Coord {
            x: points[i as usize].x,
            y: points[i as usize].y,
        });
        robust::orient2d(a, b, c) > 0.0
    }) && (got - want).abs() <= 1e-9 * want.abs();
    let tris = tris
        .into_iter()
        .map(|t| t.map(|i| ids[i as usize]))
        .collect();
    (tris, ok)
}

/// The output mesh: only the vertices the triangles use, with their colours.
fn compact(mesh: &Mesh, triangles: Vec<[u32; 3]>) -> Mesh {
    let mut index = vec![u32::MAX; mesh.positions.len()];
    let mut positions: Vec<Vec3> = Vec::new();
    let mut colours: Vec<Vec3> = Vec::new();
    let source = mesh.colors.as_deref().unwrap_or(&[]);
    let mut radiosity: Vec<Vec3> = Vec::new();
    let triangles: Vec<[u32; 3]> = triangles
        .into_iter()
        .map(|t| {
            t.map(|v| {
                if index[v as usize] == u32::MAX {
                    index[v as usize] = positions.len() as u32;
                    positions.push(mesh.positions[v as usize]);
                    colours.push(source.get(v as usize).copied().unwrap_or(Vec3::ONE));
                    if let Some(r) = &mesh.radiosity {
                        radiosity.push(r[v as usize]);
                    }
                }
                index[v as usize]
            })
        })
        .collect();
    let mut out = Mesh::from_triangles(positions, triangles);
    out.colors = Some(colours);
    out.radiosity = mesh.radiosity.is_some().then_some(radiosity);
    out.one_sided = mesh.one_sided;
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every merge passes the paper's test, replayed from the merge order alone with the formulas
    /// written out again here: on a flat 12 × 12 grid lit by a gradient, a soft shadow and a few
    /// dark squares, at small, middle and large ε, each patch that joins a superface shares an edge
    /// with it and, in every channel, has `C_P < ε` with the area-weighted mean of `C` below ε, or
    /// `C'_P < ε` (against the superface's mean radiosity, at the patch's scale `2 A_P`).
    #[test]
    fn every_merge_passes_the_papers_test() {
        let n = 12u32;
        let mut positions = Vec::new();
        let mut colours = Vec::new();
        for y in 0..=n {
            for x in 0..=n {
                let (fx, fy) = (x as f32 / n as f32, y as f32 / n as f32);
                positions.push(Vec3::new(fx, fy, 0.0));
                let shadow = if (fx - 0.6).hypot(fy - 0.4) < 0.25 {
                    0.4
                } else {
                    1.0
                };
                let dark = if (x / 3 + y / 3) % 4 == 0 { 0.7 } else { 1.0 };
                let g = (0.3 + 0.5 * fx) * shadow * dark;
                colours.push(Vec3::new(g, 0.9 * g, 0.6 + 0.2 * fy));
            }
        }
        let idx = |x: u32, y: u32| y * (n + 1) + x;
        let mut triangles = Vec::new();
        for y in 0..n {
            for x in 0..n {
                triangles.push([idx(x, y), idx(x + 1, y), idx(x + 1, y + 1)]);
                triangles.push([idx(x, y), idx(x + 1, y + 1), idx(x, y + 1)]);
            }
        }
        let mut mesh = Mesh::from_triangles(positions, triangles);
        mesh.colors = Some(colours);
        let patches = Patches::new(&mesh).unwrap();

        // The paper's quantities, from the mesh: B (0–255), A (in mean areas), C_i over edge
        // neighbours (the grid is flat: all coplanar).
        let m = &mesh;
        let b: Vec<DVec3> = m
            .triangles
            .iter()
            .map(|t| {
                t.iter()
                    .map(|&v| m.colors.as_ref().unwrap()[v as usize].as_dvec3() * 255.0)
                    .sum::<DVec3>()
                    / 3.0
            })
            .collect();
        let area = vec![1.0; m.triangles.len()]; // equal triangles: the mean area each
        let shares_edge = |f: usize, g: usize| {
            m.triangles[f]
                .iter()
                .filter(|v| m.triangles[g].contains(v))
                .count()
                == 2
        };
        let c: Vec<DVec3> = (0..b.len())
            .map(|i| {
                (0..b.len())
                    .filter(|&j| j != i && shares_edge(i, j))
                    .map(|j| (b[i] - b[j]).abs() / ((area[i] + area[j]) * b[i].max(DVec3::ONE)))
                    .fold(DVec3::ZERO, DVec3::max)
            })
            .collect();

        for epsilon in [0.02, 0.1, 0.8] {
            let mut log = Vec::new();
            let owner =
                patches.grow_with(epsilon, &|_| false, &mut |s, p| log.push((s, p as usize)));
            let mut members: HashMap<u32, Vec<usize>> = HashMap::new();
            let mut state: HashMap<u32, (DVec3, DVec3, f64)> = HashMap::new();
            let mut merges = 0;
            for (s, p) in log {
                assert_eq!(owner[p], s);
                let Some(&(bs, cs, a_s)) = state.get(&s) else {
                    state.insert(s, (b[p], c[p], area[p]));
                    members.entry(s).or_default().push(p);
                    continue;
                };
                assert!(members[&s].iter().any(|&q| shares_edge(p, q)));
                let (bp, cp, ap) = (b[p], c[p], area[p]);
                let diff = (bp - bs).abs();
                let c_prime = (diff / (2.0 * ap * bp.max(DVec3::ONE)))
                    .max(diff / (2.0 * ap * bs.max(DVec3::ONE)));
                let joint = (cp * ap + cs * a_s) / (ap + a_s);
                for k in 0..3 {
                    assert!(
                        (cp[k] < epsilon && joint[k] < epsilon) || c_prime[k] < epsilon,
                        "ε = {epsilon}: patch {p} joined superface {s} against the rule"
                    );
                }
                state.insert(s, ((bs * a_s + bp * ap) / (a_s + ap), joint, a_s + ap));
                members.entry(s).or_default().push(p);
                merges += 1;
            }
            assert!(merges > 0, "ε = {epsilon}: nothing merged");
        }
    }
}

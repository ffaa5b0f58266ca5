//! Certified one-sided Hausdorff distances: a lower and an upper bound that the true distance is
//! proven to lie between, within a stated tolerance — the referee of anything that promises a bound
//! (`vunify measure --certified`).
//!
//! # The method: branch and bound over triangles
//! `h(A → B) = max over points p of A of d(p, B)`. The surface of A is cut into pieces (A's
//! triangles, then their four-way midpoint subdivisions), each with an upper bound on `d(p, B)` over
//! the piece; the largest lower bound seen so far is kept beside them.
//!
//! - **Lower bound**: `d(v, B)` at actual points v of A (piece corners and centroids), each found
//!   exactly by a nearest-triangle search through a BVH, in `f64` (the input's `f32` coordinates are
//!   exact in `f64`; the only error left is `f64` rounding, which a relative slack of 10⁻¹² covers).
//! - **Upper bound of a piece**: for any one triangle t of B, `d(p, B) ≤ d(p, t)`, and `d(·, t)` is a
//!   convex function (t is convex), so over the piece (a triangle, also convex) it is largest at a
//!   corner: `max over the piece of d(p, B) ≤ min over candidates t of max over corners of d(c, t)`.
//!   The candidates are the triangles of B nearest to the piece's corners and centroid, and its
//!   parent's. Where one triangle of B is nearest to the whole piece, this bound is exact.
//! - Before a piece is split, the **prism partition** of `partition.rs` is tried: the piece cut
//!   along the prisms of B's triangles near it, each part bounded against its own triangle. Exact
//!   where the piece lies over several of B's faces at once (a flat region), which splitting only
//!   approaches.
//! - The piece with the largest upper bound is split until that bound is within the tolerance of the
//!   lower bound: `upper − lower ≤ max(relative · lower, absolute · diagonal)`. Pieces far from the
//!   maximum are never split, so real meshes converge after few subdivisions.
//!
//! Across a convex crease of B, where the nearest point is on an edge, the bound overstates by up to
//! the piece's size times the angle between the triangles, and pieces there are split more; the
//! absolute floor (10⁻⁵ of the diagonal by default) ends the search where nothing else would.

use super::{Bvh, partition};
use crate::mesh::Mesh;
use glam::DVec3;
use rayon::prelude::*;
use std::collections::BinaryHeap;

/// What the search aims for, and how far it may go.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CertifyOptions {
    /// Stop when the bounds are this close, relative to the lower bound. Default 1 %.
    pub relative: f64,
    /// ... or this close as a fraction of the diagonal (for distances near 0). Default 10⁻⁵.
    pub absolute: f64,
    /// Give up after splitting this many pieces in one direction; the bounds still hold, but are
    /// farther apart than asked (`converged` is false). Default 500,000 (about 250 MB of pieces).
    pub max_splits: usize,
    /// A question instead of a measurement: is the distance at most this (a fraction of the
    /// diagonal)? The search then runs until the upper bound is at most it or the lower bound
    /// above it (`converged` means decided), however close the bounds must get — the tolerances
    /// above no longer end it, but the absolute floor still does (the answer is then undecided).
    pub epsilon: Option<f64>,
}

impl Default for CertifyOptions {
    fn default() -> Self {
        CertifyOptions {
            relative: 0.01,
            absolute: 1e-5,
            max_splits: 500_000,
            epsilon: None,
        }
    }
}

/// Bounds on one one-sided Hausdorff distance, as fractions of the reference diagonal.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Bounds {
    pub lower: f64,
    pub upper: f64,
    /// The bounds met the tolerance (else `max_splits` ran out).
    pub converged: bool,
    /// Pieces split on the way.
    pub splits: usize,
    /// A point of the `from` surface where the lower bound was found.
    pub lower_at: [f64; 3],
    /// With [`CertifyOptions::epsilon`]: `Some(true)` when the distance is proven at most ε,
    /// `Some(false)` when proven above it, `None` when the search could not decide.
    pub within: Option<bool>,
}

/// Both directions: `forward` is A → B (how far A's points are from B), `backward` B → A.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Certified {
    pub forward: Bounds,
    pub backward: Bounds,
    /// A's bounding-box diagonal, the unit of the bounds.
    pub diagonal: f64,
    pub options: CertifyOptions,
}

/// Why a certified measurement cannot be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CertifyError {
    #[error("the first mesh has no triangles")]
    FirstEmpty,
    #[error("the second mesh has no triangles")]
    SecondEmpty,
}

/// Certified bounds on both one-sided Hausdorff distances between `a` and `b`, as fractions of
/// `a`'s bounding-box diagonal.
pub fn certified_hausdorff(
    a: &Mesh,
    b: &Mesh,
    options: &CertifyOptions,
) -> Result<Certified, CertifyError> {
    if a.triangles.is_empty() {
        return Err(CertifyError::FirstEmpty);
    }
    if b.triangles.is_empty() {
        return Err(CertifyError::SecondEmpty);
    }
    // In f64 from the exact corners, so that the unit adds no rounding of its own.
    let (lo, hi) = a.bounds();
    let diagonal = (hi.as_dvec3() - lo.as_dvec3())
        .length()
        .max(f64::MIN_POSITIVE);
    let (bvh_a, bvh_b) = rayon::join(
        || Bvh::new(&a.positions, &a.triangles),
        || Bvh::new(&b.positions, &b.triangles),
    );
    let (forward, backward) = rayon::join(
        || one_sided(a, &bvh_b, options, diagonal),
        || one_sided(b, &bvh_a, options, diagonal),
    );
    Ok(Certified {
        forward,
        backward,
        diagonal,
        options: *options,
    })
}

/// How many candidate triangles a piece keeps for its upper bound.
const CANDIDATES: usize = 6;

/// Relative slack for `f64` rounding in the distances (the inputs are exact).
const ROUNDING: f64 = 1e-12;

/// A piece of the `from` surface: its corners, the nearest triangle of the `to` mesh to each, and
/// the candidates its upper bound was taken over.
#[derive(Clone, Debug)]
struct Piece {
    corners: [DVec3; 3],
    nearest: [u32; 3],
    /// The best candidates first; `u32::MAX` pads.
    candidates: [u32; CANDIDATES],
    upper: f64,
    /// Its bound was tried by a prism partition.
    partitioned: bool,
}

/// A piece in the queue, by its upper bound.
struct Queued(f64, usize);

impl PartialEq for Queued {
    fn eq(&self, o: &Self) -> bool {
        self.0.total_cmp(&o.0).is_eq() && self.1 == o.1
    }
}
impl Eq for Queued {}
impl PartialOrd for Queued {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Queued {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0).then(o.1.cmp(&self.1))
    }
}

/// The largest distance found at a point so far, and where.
#[derive(Clone, Copy)]
struct Lower {
    distance: f64,
    at: DVec3,
}

impl Lower {
    fn see(&mut self, distance: f64, at: DVec3) {
        if distance > self.distance {
            *self = Lower { distance, at };
        }
    }
}

/// Certified bounds on `h(from → to)`, `to` given by its BVH.
fn one_sided(from: &Mesh, to: &Bvh, options: &CertifyOptions, unit: f64) -> Bounds {
    let nearest = |p: DVec3| to.nearest64(p).expect("the mesh has triangles");
    let p64: Vec<DVec3> = from.positions.iter().map(|p| p.as_dvec3()).collect();
    // Each vertex's nearest triangle, once.
    let at_vertex: Vec<(f64, usize)> = p64.par_iter().map(|&p| nearest(p)).collect();
    let mut lower = Lower {
        distance: 0.0,
        at: p64.first().copied().unwrap_or_default(),
    };
    let mut pieces: Vec<Piece> = from
        .triangles
        .par_iter()
        .map(|t| {
            let corners = t.map(|v| p64[v as usize]);
            let near = t.map(|v| at_vertex[v as usize].1 as u32);
            let (_, tc) = nearest((corners[0] + corners[1] + corners[2]) / 3.0);
            piece(to, corners, near, tc as u32, &[])
        })
        .collect();
    for (i, &(d, _)) in at_vertex.iter().enumerate() {
        lower.see(d, p64[i]);
    }
    for p in &pieces {
        let centroid = (p.corners[0] + p.corners[1] + p.corners[2]) / 3.0;
        lower.see(nearest(centroid).0, centroid);
    }
    let mut queue: BinaryHeap<Queued> = pieces
        .iter()
        .enumerate()
        .map(|(i, p)| Queued(p.upper, i))
        .collect();
    let floor = options.absolute * unit;
    let question = options.epsilon.map(|e| e * unit);
    let mut splits = 0;
    let (upper, converged) = loop {
        let Some(&Queued(top, i)) = queue.peek() else {
            break (lower.distance, true);
        };
        match question {
            Some(e) if top * (1.0 + ROUNDING) <= e || lower.distance * (1.0 - ROUNDING) > e => {
                break (top, true);
            }
            Some(_) if top - lower.distance <= floor => break (top, false),
            Some(_) => {}
            None if top - lower.distance <= (options.relative * lower.distance).max(floor) => {
                break (top, true);
            }
            None => {}
        }
        if splits >= options.max_splits {
            break (top, false);
        }
        queue.pop();
        // Before a piece is split, its bound is tried by a prism partition (once).
        if !pieces[i].partitioned {
            pieces[i].partitioned = true;
            let u = partitioned_bound(&pieces[i], to);
            if u < pieces[i].upper {
                pieces[i].upper = u;
                queue.push(Queued(u, i));
                continue;
            }
        }
        splits += 1;
        let parent = pieces[i].candidates;
        let [a, b, c] = pieces[i].corners;
        let [na, nb, nc] = pieces[i].nearest;
        let mids = [(a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5];
        let mid_near = mids.map(|m| {
            let (d, t) = nearest(m);
            lower.see(d, m);
            t as u32
        });
        let [ab, bc, ca] = mids;
        let [nab, nbc, nca] = mid_near;
        for (k, (corners, near)) in [
            ([a, ab, ca], [na, nab, nca]),
            ([ab, b, bc], [nab, nb, nbc]),
            ([ca, bc, c], [nca, nbc, nc]),
            ([ab, bc, ca], [nab, nbc, nca]),
        ]
        .into_iter()
        .enumerate()
        {
            let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
            let (d, tc) = nearest(centroid);
            lower.see(d, centroid);
            let child = piece(to, corners, near, tc as u32, &parent);
            // The first child takes its parent's place.
            let slot = if k == 0 {
                pieces[i] = child;
                i
            } else {
                pieces.push(child);
                pieces.len() - 1
            };
            queue.push(Queued(pieces[slot].upper, slot));
        }
    };
    let within = question.and_then(|e| {
        if upper * (1.0 + ROUNDING) <= e {
            Some(true)
        } else if lower.distance * (1.0 - ROUNDING) > e {
            Some(false)
        } else {
            None
        }
    });
    Bounds {
        lower: lower.distance * (1.0 - ROUNDING) / unit,
        upper: (upper * (1.0 + ROUNDING)).max(lower.distance) / unit,
        converged,
        splits,
        lower_at: lower.at.to_array(),
        within,
    }
}

/// The prism-partition bound of a meter's piece (rounding slack included; infinite when it cannot be
/// taken): against its candidates, or, for a piece large beside its bound, against every triangle
/// within that bound of it — exact where the piece lies over several faces at once, which
/// splitting only approaches.
fn partitioned_bound(p: &Piece, to: &Bvh) -> f64 {
    let mut ids: Vec<u32> = p
        .candidates
        .iter()
        .copied()
        .filter(|&t| t != u32::MAX)
        .collect();
    if diameter(&p.corners) > LARGE * p.upper {
        let mut near = Vec::new();
        if near_triangles(&p.corners, to, p.upper, &mut near) {
            ids = near;
        }
    }
    let geometry: Vec<[DVec3; 3]> = ids.iter().map(|&t| to.triangle64(t as usize)).collect();
    partition::upper_bound(
        &p.corners,
        &geometry,
        p.upper,
        f64::INFINITY,
        PARTITION_PARTS,
        &mut Vec::new(),
    )
    .map_or(f64::INFINITY, |u| u + partition::slack(&p.corners))
}

/// A piece with its candidates (the corners' and centroid's nearest triangles, then the parent's)
/// and its upper bound over them.
fn piece(
    to: &Bvh,
    corners: [DVec3; 3],
    nearest: [u32; 3],
    centroid_nearest: u32,
    parent: &[u32],
) -> Piece {
    let mut candidates: Vec<u32> = Vec::with_capacity(CANDIDATES + 4);
    for t in [centroid_nearest]
        .into_iter()
        .chain(nearest)
        .chain(parent.iter().copied().filter(|&t| t != u32::MAX))
    {
        if !candidates.contains(&t) {
            candidates.push(t);
        }
    }
    // The candidates' bounds, best first; keep the best few for the children.
    let mut scored: Vec<(f64, u32)> = candidates
        .iter()
        .map(|&t| {
            let [x, y, z] = to.triangle64(t as usize);
            let worst = corners
                .iter()
                .map(|&c| super::bvh::closest_point_on_triangle64(c, x, y, z).distance(c))
                .fold(0.0, f64::max);
            (worst, t)
        })
        .collect();
    scored.sort_by(|p, q| p.0.total_cmp(&q.0));
    let mut kept = [u32::MAX; CANDIDATES];
    for (slot, &(_, t)) in kept.iter_mut().zip(&scored) {
        *slot = t;
    }
    Piece {
        corners,
        nearest,
        upper: scored[0].0,
        candidates: kept,
        partitioned: false,
    }
}

/// Triangles of the other mesh a prism partition may cut a piece by; a piece near more is split
/// instead (its parts see fewer).
const PARTITION_CANDIDATES: usize = 4096;

/// Parts a prism partition may carry at once before it gives up.
const PARTITION_PARTS: usize = 256;

/// What a certified check measures distances to: the nearest triangle to a point, and the triangles
/// themselves, in `f64`.
pub trait Target {
    /// The nearest triangle to `p` and its distance; `None` when there are none.
    fn nearest(&self, p: DVec3) -> Option<(f64, u32)>;
    fn triangle(&self, t: u32) -> [DVec3; 3];
    /// Appends to `out` every triangle whose box overlaps the box `lo..hi` (and perhaps others).
    fn overlapping(&self, lo: DVec3, hi: DVec3, out: &mut Vec<u32>);
}

impl Target for Bvh {
    fn nearest(&self, p: DVec3) -> Option<(f64, u32)> {
        self.nearest64(p).map(|(d, t)| (d, t as u32))
    }
    fn triangle(&self, t: u32) -> [DVec3; 3] {
        self.triangle64(t as usize)
    }
    fn overlapping(&self, lo: DVec3, hi: DVec3, out: &mut Vec<u32>) {
        self.any_overlapping(lo, hi, |t| {
            out.push(t as u32);
            false
        });
    }
}

/// A handful of triangles, searched one by one (a local ring of faces).
pub struct Triangles<'a>(pub &'a [[DVec3; 3]]);

impl Target for Triangles<'_> {
    fn nearest(&self, p: DVec3) -> Option<(f64, u32)> {
        self.0
            .iter()
            .enumerate()
            .map(|(i, &[a, b, c])| {
                let q = super::bvh::closest_point_on_triangle64(p, a, b, c);
                (q.distance(p), i as u32)
            })
            .min_by(|x, y| x.0.total_cmp(&y.0))
    }
    fn triangle(&self, t: u32) -> [DVec3; 3] {
        self.0[t as usize]
    }
    fn overlapping(&self, lo: DVec3, hi: DVec3, out: &mut Vec<u32>) {
        out.extend((0..self.0.len() as u32).filter(|&t| {
            let [a, b, c] = self.0[t as usize];
            let (tlo, thi) = (a.min(b).min(c), a.max(b).max(c));
            !(tlo.cmpgt(hi).any() || lo.cmpgt(thi).any())
        }));
    }
}

/// Whether every point of `pieces` is proven within `eps` of `to`: the same bounds as
/// [`certified_hausdorff`], splitting pieces until each one's upper bound is at most `eps` (true) or a
/// point farther than `eps` is found (false). Conservative: when `budget` splits do not settle it,
/// the answer is false.
pub fn within(pieces: &[[DVec3; 3]], to: &impl Target, eps: f64, budget: usize) -> bool {
    within_by(pieces, to, eps, budget, &mut Vec::new())
}

/// [`within`], naming the triangles of `to` the proof rests on: when it returns true, every point of
/// `pieces` is within `eps` of the triangles it added to `witnesses` alone (with repeats).
pub fn within_by(
    pieces: &[[DVec3; 3]],
    to: &impl Target,
    eps: f64,
    budget: usize,
    witnesses: &mut Vec<u32>,
) -> bool {
    let accept = |upper: f64| upper * (1.0 + ROUNDING) <= eps;
    // Each entry: a piece's corners, their distances and their nearest triangles.
    let mut stack: Vec<([DVec3; 3], [f64; 3], [u32; 3])> = Vec::new();
    for &corners in pieces {
        // A piece small beside ε is settled by its centroid alone (the distance is 1-Lipschitz).
        let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
        let radius = corners
            .iter()
            .map(|c| c.distance(centroid))
            .fold(0.0, f64::max);
        if radius < 0.5 * eps {
            let Some((d, t)) = to.nearest(centroid) else {
                return false;
            };
            if accept(d + radius) {
                witnesses.push(t);
                continue;
            }
        }
        let mut near = [0u32; 3];
        let mut dist = [0f64; 3];
        for k in 0..3 {
            let Some((d, t)) = to.nearest(corners[k]) else {
                return false;
            };
            if d > eps {
                return false;
            }
            (dist[k], near[k]) = (d, t);
        }
        stack.push((corners, dist, near));
    }
    let mut splits = 0;
    let mut scratch = Scratch::default();
    while let Some((corners, dist, near)) = stack.pop() {
        // The distance is 1-Lipschitz: every point of the piece is within its distance from a
        // corner of that corner's distance. Settles most small pieces without another query.
        let (lipschitz, k) = (0..3)
            .map(|i| {
                let reach = (0..3)
                    .map(|j| corners[i].distance(corners[j]))
                    .fold(0.0, f64::max);
                (dist[i] + reach, i)
            })
            .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a });
        if accept(lipschitz) {
            witnesses.push(near[k]);
            continue;
        }
        let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
        let Some((dc, tc)) = to.nearest(centroid) else {
            return false;
        };
        if dc > eps {
            return false;
        }
        // One triangle for the whole piece (the nearest to its centroid or to a corner) ...
        let (upper, best) = [tc]
            .into_iter()
            .chain(near)
            .map(|t| {
                let [x, y, z] = to.triangle(t);
                let worst = corners
                    .iter()
                    .map(|&c| super::bvh::closest_point_on_triangle64(c, x, y, z).distance(c))
                    .fold(0.0, f64::max);
                (worst, t)
            })
            .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a });
        if accept(upper) {
            witnesses.push(best);
            continue;
        }
        // ... or the piece cut along the prisms of those few, or, for a piece large beside ε, of
        // every triangle near it.
        let (mut local, mut count) = ([tc; 4], 1);
        for t in near {
            if !local[..count].contains(&t) {
                local[count] = t;
                count += 1;
            }
        }
        if (count > 1 && scratch.partition(&corners, to, &local[..count], eps, witnesses))
            || (diameter(&corners) > LARGE * eps
                && scratch.partition_near(&corners, to, eps, witnesses))
        {
            continue;
        }
        splits += 1;
        if splits > budget {
            return false;
        }
        let [a, b, c] = corners;
        let mids = [(a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5];
        let mut mid_near = [0u32; 3];
        let mut mid_dist = [0f64; 3];
        for k in 0..3 {
            let Some((d, t)) = to.nearest(mids[k]) else {
                return false;
            };
            if d > eps {
                return false;
            }
            (mid_dist[k], mid_near[k]) = (d, t);
        }
        let [ab, bc, ca] = mids;
        let ([na, nb, nc], [da, db, dc3]) = (near, dist);
        let ([nab, nbc, nca], [dab, dbc, dca]) = (mid_near, mid_dist);
        stack.extend([
            ([a, ab, ca], [da, dab, dca], [na, nab, nca]),
            ([ab, b, bc], [dab, db, dbc], [nab, nb, nbc]),
            ([ca, bc, c], [dca, dbc, dc3], [nca, nbc, nc]),
            ([ab, bc, ca], [dab, dbc, dca], [nab, nbc, nca]),
        ]);
    }
    true
}

/// A piece whose longest edge is this many times ε is cut along the prisms of every triangle near
/// it before it is split: splitting a large flat piece until its parts are smaller than ε costs far
/// more (a 20 × 20 flat grid at ε = 1 %: 2.2 s instead of 7.9 s), while on curved surfaces, where
/// pieces are nearer ε in size, the search mostly fails and costs more than splitting (the cow at
/// 1 %: 1.5 s with this gate, 2.5 s with none).
const LARGE: f64 = 16.0;

fn diameter(c: &[DVec3; 3]) -> f64 {
    c[0].distance(c[1])
        .max(c[1].distance(c[2]))
        .max(c[2].distance(c[0]))
}

/// Fills `ids` with the triangles of `to` whose boxes come within `reach` of the piece's box, nearest
/// to its centroid first — the candidates of a wide prism partition; false when there are none or
/// more than [`PARTITION_CANDIDATES`].
fn near_triangles(corners: &[DVec3; 3], to: &impl Target, reach: f64, ids: &mut Vec<u32>) -> bool {
    let [a, b, c] = *corners;
    ids.clear();
    to.overlapping(
        a.min(b).min(c) - DVec3::splat(reach),
        a.max(b).max(c) + DVec3::splat(reach),
        ids,
    );
    if ids.is_empty() || ids.len() > PARTITION_CANDIDATES {
        return false;
    }
    let centroid3 = a + b + c;
    ids.sort_by_cached_key(|&t| {
        let g = to.triangle(t);
        // Ordered as integers: the squared distance is non-negative, so its bits sort alike.
        (g[0] + g[1] + g[2]).distance_squared(centroid3).to_bits()
    });
    true
}

/// Buffers of the prism partitions of one check.
#[derive(Default)]
struct Scratch {
    ids: Vec<u32>,
    geometry: Vec<[DVec3; 3]>,
    used: Vec<usize>,
}

impl Scratch {
    /// Whether the prism partition of `corners` against the triangles `ids` (in that order) bounds
    /// it within `eps`; if so, the triangles it used join `witnesses`.
    fn partition(
        &mut self,
        corners: &[DVec3; 3],
        to: &impl Target,
        ids: &[u32],
        eps: f64,
        witnesses: &mut Vec<u32>,
    ) -> bool {
        self.geometry.clear();
        self.geometry.extend(ids.iter().map(|&t| to.triangle(t)));
        self.used.clear();
        let bound = partition::upper_bound(
            corners,
            &self.geometry,
            eps,
            eps,
            PARTITION_PARTS,
            &mut self.used,
        );
        let ok = bound.is_some_and(|u| (u + partition::slack(corners)) * (1.0 + ROUNDING) <= eps);
        if ok {
            witnesses.extend(self.used.iter().map(|&i| ids[i]));
        }
        ok
    }

    /// [`Scratch::partition`] against every triangle of `to` whose box comes within `eps` of the
    /// piece's box, nearest to its centroid first (at most [`PARTITION_CANDIDATES`]).
    fn partition_near(
        &mut self,
        corners: &[DVec3; 3],
        to: &impl Target,
        eps: f64,
        witnesses: &mut Vec<u32>,
    ) -> bool {
        let mut ids = std::mem::take(&mut self.ids);
        if !near_triangles(corners, to, eps, &mut ids) {
            self.ids = ids;
            return false;
        }
        let ok = self.partition(corners, to, &ids, eps, witnesses);
        self.ids = ids;
        ok
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn check(b: &Bounds, exact: f64, what: &str) {
        assert!(b.converged, "{what}: {b:?}");
        assert!(
            b.lower <= exact * (1.0 + 1e-9) + 1e-15 && exact <= b.upper * (1.0 + 1e-9) + 1e-15,
            "{what}: {exact} outside {b:?}"
        );
        assert!(
            b.upper - b.lower <= 0.01 * b.lower + 1e-5 + 1e-12,
            "{what}: bounds too far apart: {b:?}"
        );
    }

    fn triangle(z: f32) -> Mesh {
        Mesh::from_triangles(
            vec![
                Vec3::new(0.0, 0.0, z),
                Vec3::X + Vec3::Z * z,
                Vec3::Y + Vec3::Z * z,
            ],
            vec![[0, 1, 2]],
        )
    }

    /// Two parallel triangles, one exactly over the other at height d: every point of each is d
    /// from the other.
    #[test]
    fn parallel_triangles_are_their_gap_apart() {
        let d = 0.25;
        let c = certified_hausdorff(&triangle(0.0), &triangle(d), &Default::default()).unwrap();
        let exact = d as f64 / c.diagonal;
        check(&c.forward, exact, "forward");
        check(&c.backward, exact, "backward");
    }

    /// A unit square against both of its triangulations:
    /// ```text
    ///   3 ---- 2      3 ---- 2
    ///   | \    |      |    / |
    ///   |   \  |      |  /   |
    ///   0 ---- 1      0 ---- 1
    /// ```
    /// The same surface: 0 both ways, with B's diagonal crossing A's faces.
    #[test]
    fn a_square_against_both_of_its_triangulations() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let a = Mesh::from_triangles(p.clone(), vec![[0, 1, 3], [1, 2, 3]]);
        let b = Mesh::from_triangles(p, vec![[0, 1, 2], [0, 2, 3]]);
        for other in [&a, &b] {
            let c = certified_hausdorff(&a, other, &Default::default()).unwrap();
            check(&c.forward, 0.0, "forward");
            check(&c.backward, 0.0, "backward");
            // Proven 0 (up to the rounding slack) by the prism partition, not left at the floor.
            assert!(c.forward.upper < 1e-9 && c.backward.upper < 1e-9, "{c:?}");
        }
    }

    /// A regular tetrahedron (vertices (±1, ±1, ±1) with an even number of minus signs) against a
    /// copy shrunk by half about its centre. Forward, A's farthest points are its vertices, each
    /// (1 − s)·√3 from B's vertex; backward, B's face centres are (1 − s)·r_in from A's faces
    /// (r_in = 1/√3). The diagonal of A's box is 2√3.
    #[test]
    fn a_tetrahedron_against_a_shrunken_copy() {
        let tetra = |s: f32| {
            Mesh::from_triangles(
                vec![
                    Vec3::new(1.0, 1.0, 1.0) * s,
                    Vec3::new(1.0, -1.0, -1.0) * s,
                    Vec3::new(-1.0, 1.0, -1.0) * s,
                    Vec3::new(-1.0, -1.0, 1.0) * s,
                ],
                vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]],
            )
        };
        let s = 0.5;
        let c = certified_hausdorff(&tetra(1.0), &tetra(s as f32), &Default::default()).unwrap();
        let diagonal = 2.0 * 3f64.sqrt();
        assert!((c.diagonal - diagonal).abs() < 1e-6);
        check(&c.forward, (1.0 - s) * 3f64.sqrt() / diagonal, "forward");
        check(&c.backward, (1.0 - s) / 3f64.sqrt() / diagonal, "backward");
    }

    #[test]
    fn a_mesh_against_itself_is_zero() {
        let m = crate::fixtures::fig2();
        let c = certified_hausdorff(&m, &m, &Default::default()).unwrap();
        // (Centroids are a third of a sum: off the plane by an ulp.)
        assert!(c.forward.upper < 1e-12 && c.backward.upper < 1e-12, "{c:?}");
    }

    #[test]
    fn empty_meshes_are_errors() {
        let empty = Mesh::default();
        let t = triangle(0.0);
        assert_eq!(
            certified_hausdorff(&empty, &t, &Default::default()),
            Err(CertifyError::FirstEmpty)
        );
        assert_eq!(
            certified_hausdorff(&t, &empty, &Default::default()),
            Err(CertifyError::SecondEmpty)
        );
    }
}

//! Simplification within a certified distance (`vunify simplify --method bounded`): the fewest
//! triangles we can find whose Hausdorff distance to the input is proven at most ε **in both
//! directions** — no point of the output is farther than ε from the input, and no point of the
//! input is farther than ε from the output.
//!
//! Edge collapses in quadric order (Garland and Heckbert), each accepted only after two certified
//! checks (`measure::within`, the branch and bound of `vunify measure --certified`):
//!
//! 1. **output → input**: the triangles around the merged vertex lie within ε of the *original*
//!    surface (not the current one, so errors cannot accumulate from step to step);
//! 2. **input → output**: every original triangle that was certified against a face the collapse
//!    changes is within ε of the faces it can still rely on plus the new ones.
//!
//! Both hold for every output triangle and every input triangle after every accepted collapse, so
//! they hold for the result. See docs/ENVELOPES.md.

use crate::measure::{Bvh, Triangles, within, within_by};
use crate::mesh::Mesh;
use crate::simplify::DistanceError;
use crate::simplify::quadric::Quadric;
use glam::DVec3;
use std::collections::BinaryHeap;

/// Settings of a bounded simplification.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundedOptions {
    /// ε, as a fraction of the input's bounding-box diagonal.
    pub epsilon: f64,
    /// Stop at this many triangles (or when no collapse can be certified).
    pub target_triangles: usize,
}

/// What a run did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct BoundedStats {
    pub triangles: usize,
    pub collapses_tried: usize,
    pub collapses_accepted: usize,
    /// Certified checks run (two per tried placement, until one fails).
    pub checks: usize,
    pub seconds: f64,
}

/// What the certified checks leave below ε (relative).
const MARGIN: f64 = 1e-3;

/// Splits a certified check may make before it gives up (and the collapse is refused).
const CHECK_BUDGET: usize = 2_000;

/// Boundary edges get a constraint plane of this weight times their squared length, so the quadric
/// order keeps outlines until last (the certified checks guard the distance either way).
const BOUNDARY_WEIGHT: f64 = 10.0;

/// A face turned by more than this (cosine between its normals before and after) is a fold: refused.
const FOLD_COS: f64 = 0.0;

struct Work {
    positions: Vec<DVec3>,
    faces: Vec<[u32; 3]>,
    alive: Vec<bool>,
    /// Faces around each vertex (may list dead faces, skipped).
    around: Vec<Vec<u32>>,
    quadric: Vec<Quadric>,
    /// Version of each vertex: a queued pair is stale once either end changed.
    version: Vec<u32>,
    /// Each live face's original triangles that were certified against it, and each original
    /// triangle's certifying faces.
    covers: Vec<Vec<u32>>,
    certified_by: Vec<Vec<u32>>,
    live_faces: usize,
}

/// A collapse waiting in the queue, cheapest first.
#[derive(PartialEq)]
struct Candidate {
    cost: f64,
    a: u32,
    b: u32,
    versions: [u32; 2],
}

impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Candidate {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        o.cost
            .total_cmp(&self.cost)
            .then(o.a.cmp(&self.a))
            .then(o.b.cmp(&self.b))
    }
}

/// Simplifies `mesh` within `options.epsilon` of it, both ways; `progress(triangles now)` is called
/// now and then.
pub fn simplify_bounded(
    mesh: &Mesh,
    options: &BoundedOptions,
    progress: &mut dyn FnMut(usize),
) -> Result<(Mesh, BoundedStats), DistanceError> {
    simplify_watched(mesh, options, progress, &mut |_| {})
}

/// [`simplify_bounded`], showing the working mesh to `watch` after every accepted collapse (the
/// tests check the bookkeeping there).
fn simplify_watched(
    mesh: &Mesh,
    options: &BoundedOptions,
    progress: &mut dyn FnMut(usize),
    watch: &mut dyn FnMut(&Work),
) -> Result<(Mesh, BoundedStats), DistanceError> {
    let start = std::time::Instant::now();
    if mesh.triangles.is_empty() {
        return Err(DistanceError::Empty);
    }
    if !(options.epsilon > 0.0 && options.epsilon < 1.0) {
        return Err(DistanceError::Epsilon(options.epsilon));
    }
    let (lo, hi) = mesh.bounds();
    // A thousandth below ε, so that an independent meter (`measure --certified`, whose bounds close
    // to a tolerance) can confirm the result is under ε rather than only near it.
    let eps = options.epsilon * (1.0 - MARGIN) * (hi.as_dvec3() - lo.as_dvec3()).length();
    let original = Bvh::new(&mesh.positions, &mesh.triangles);
    let originals: Vec<[DVec3; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| mesh.positions[v as usize].as_dvec3()))
        .collect();
    let mut w = Work::new(mesh);
    let mut queue = BinaryHeap::new();
    // Every edge once, boundary edges included (their one face may name them either way round).
    let mut edges: Vec<(u32, u32)> = w
        .faces
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]))))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    for (a, b) in edges {
        queue.push(w.candidate(a, b));
    }
    let mut stats = BoundedStats::default();
    while w.live_faces > options.target_triangles {
        let Some(c) = queue.pop() else { break };
        if w.version[c.a as usize] != c.versions[0] || w.version[c.b as usize] != c.versions[1] {
            continue;
        }
        stats.collapses_tried += 1;
        if let Some(merged) = w.try_collapse(c.a, c.b, eps, &original, &originals, &mut stats) {
            stats.collapses_accepted += 1;
            watch(&w);
            for n in w.neighbours(merged) {
                queue.push(w.candidate(merged.min(n), merged.max(n)));
            }
            if stats.collapses_accepted % 256 == 0 {
                progress(w.live_faces);
            }
        }
    }
    stats.triangles = w.live_faces;
    stats.seconds = start.elapsed().as_secs_f64();
    progress(w.live_faces);
    Ok((w.into_mesh(mesh), stats))
}

impl Work {
    fn new(mesh: &Mesh) -> Work {
        let n = mesh.positions.len();
        let positions: Vec<DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
        let mut around = vec![Vec::new(); n];
        let mut quadric = vec![Quadric::default(); n];
        for (f, t) in mesh.triangles.iter().enumerate() {
            let q = Quadric::from_triangle(
                mesh.positions[t[0] as usize],
                mesh.positions[t[1] as usize],
                mesh.positions[t[2] as usize],
            );
            for &v in t {
                around[v as usize].push(f as u32);
                quadric[v as usize] += q;
            }
        }
        let mut w = Work {
            positions,
            faces: mesh.triangles.clone(),
            alive: vec![true; mesh.triangles.len()],
            around,
            quadric,
            version: vec![0; n],
            covers: (0..mesh.triangles.len() as u32).map(|f| vec![f]).collect(),
            certified_by: (0..mesh.triangles.len() as u32).map(|f| vec![f]).collect(),
            live_faces: mesh.triangles.len(),
        };
        w.add_boundary_constraints();
        w
    }

    /// Constraint planes through boundary edges (an edge with one face), perpendicular to the face.
    fn add_boundary_constraints(&mut self) {
        for f in 0..self.faces.len() {
            let t = self.faces[f];
            let [p0, p1, p2] = t.map(|v| self.positions[v as usize]);
            let normal = (p1 - p0).cross(p2 - p0).normalize_or_zero();
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if self.faces_with_edge(a, b) != 1 {
                    continue;
                }
                let (pa, pb) = (self.positions[a as usize], self.positions[b as usize]);
                let side = (pb - pa).cross(normal).normalize_or_zero();
                if side == DVec3::ZERO {
                    continue;
                }
                let q = Quadric::constraint(side, pa, BOUNDARY_WEIGHT * pa.distance_squared(pb));
                self.quadric[a as usize] += q;
                self.quadric[b as usize] += q;
            }
        }
    }

    fn live_around(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        self.around[v as usize]
            .iter()
            .copied()
            .filter(|&f| self.alive[f as usize])
    }

    fn faces_with_edge(&self, a: u32, b: u32) -> usize {
        self.live_around(a)
            .filter(|&f| self.faces[f as usize].contains(&b))
            .count()
    }

    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut n: Vec<u32> = self
            .live_around(v)
            .flat_map(|f| self.faces[f as usize])
            .filter(|&u| u != v)
            .collect();
        n.sort_unstable();
        n.dedup();
        n
    }

    fn candidate(&self, a: u32, b: u32) -> Candidate {
        let q = self.quadric[a as usize] + self.quadric[b as usize];
        let p = self.placements(a, b)[0];
        Candidate {
            cost: q.eval(p),
            a,
            b,
            versions: [self.version[a as usize], self.version[b as usize]],
        }
    }

    /// Where the merged vertex may go, best first: the quadric's optimum, then the ends and the
    /// midpoint by their cost. Each is rounded to `f32` first, as the output stores it, so that what
    /// is certified is exactly what is written.
    fn placements(&self, a: u32, b: u32) -> Vec<DVec3> {
        let q = self.quadric[a as usize] + self.quadric[b as usize];
        let (pa, pb) = (self.positions[a as usize], self.positions[b as usize]);
        let mut out: Vec<DVec3> = q.optimum().into_iter().collect();
        let mut ends = [pa, pb, (pa + pb) * 0.5];
        ends.sort_by(|x, y| q.eval(*x).total_cmp(&q.eval(*y)));
        out.extend(ends);
        out.into_iter().map(|p| p.as_vec3().as_dvec3()).collect()
    }

    /// Tries `vunify(a, b)` at each placement in turn; applies the first whose result is certified
    /// within `eps` both ways. Returns the surviving vertex.
    fn try_collapse(
        &mut self,
        a: u32,
        b: u32,
        eps: f64,
        original: &Bvh,
        originals: &[[DVec3; 3]],
        stats: &mut BoundedStats,
    ) -> Option<u32> {
        let mut touched: Vec<u32> = self.live_around(a).chain(self.live_around(b)).collect();
        touched.sort_unstable();
        touched.dedup();
        let dying: Vec<u32> = touched
            .iter()
            .copied()
            .filter(|&f| {
                let t = self.faces[f as usize];
                t.contains(&a) && t.contains(&b)
            })
            .collect();
        let kept: Vec<u32> = touched
            .iter()
            .copied()
            .filter(|f| !dying.contains(f))
            .collect();
        // Two faces that would become one (the same three vertices): not a manifold collapse.
        let mut keys: Vec<[u32; 3]> = kept
            .iter()
            .map(|&f| {
                let mut k = self.faces[f as usize].map(|v| if v == b { a } else { v });
                k.sort_unstable();
                k
            })
            .collect();
        keys.sort_unstable();
        if keys.windows(2).any(|w| w[0] == w[1]) {
            return None;
        }
        // The original triangles to re-certify: those whose proof rests on a face the collapse
        // changes (a face's list may still name originals that have since left it).
        let (covers, certified_by) = (&self.covers, &self.certified_by);
        let mut affected: Vec<u32> = touched
            .iter()
            .flat_map(|&f| {
                covers[f as usize]
                    .iter()
                    .copied()
                    .filter(move |&o| certified_by[o as usize].contains(&f))
            })
            .collect();
        affected.sort_unstable();
        affected.dedup();
        for p in self.placements(a, b) {
            let ring: Vec<[DVec3; 3]> = kept
                .iter()
                .map(|&f| {
                    self.faces[f as usize].map(|v| {
                        if v == a || v == b {
                            p
                        } else {
                            self.positions[v as usize]
                        }
                    })
                })
                .collect();
            if !self.no_folds(&kept, &ring) {
                continue;
            }
            stats.checks += 1;
            if !within(&ring, original, eps, CHECK_BUDGET) {
                continue;
            }
            stats.checks += 1;
            if let Some(support) = self.recertify(&affected, &touched, &kept, &ring, eps, originals)
            {
                self.apply(a, b, p, &dying, &kept, &affected, support);
                return Some(a);
            }
        }
        None
    }

    /// No face of the ring turns over or collapses to a line.
    fn no_folds(&self, kept: &[u32], ring: &[[DVec3; 3]]) -> bool {
        kept.iter().zip(ring).all(|(&f, r)| {
            let [p0, p1, p2] = self.faces[f as usize].map(|v| self.positions[v as usize]);
            let before = (p1 - p0).cross(p2 - p0);
            let after = (r[1] - r[0]).cross(r[2] - r[0]);
            after.length_squared() > 0.0
                && before.normalize_or_zero().dot(after.normalize_or_zero()) > FOLD_COS
        })
    }

    /// Checks that each affected original triangle is within `eps` of the faces it may rely on
    /// after the collapse — its certifying faces the collapse does not touch, the new ring, and the
    /// faces just beyond the ring — and returns, for each, the faces its proof used, which it is
    /// certified by from now on. `None` if any fails.
    fn recertify(
        &self,
        affected: &[u32],
        touched: &[u32],
        kept: &[u32],
        ring: &[[DVec3; 3]],
        eps: f64,
        originals: &[[DVec3; 3]],
    ) -> Option<Vec<Vec<u32>>> {
        let mut out = Vec::with_capacity(affected.len());
        let (mut faces, mut geometry, mut witnesses) = (Vec::new(), Vec::new(), Vec::new());
        // The untouched faces around the ring: an original near the ring's rim may have part of
        // its proof there, though its old proof did not need them.
        let mut beyond: Vec<u32> = kept
            .iter()
            .flat_map(|&f| self.faces[f as usize])
            .flat_map(|v| self.live_around(v))
            .filter(|f| touched.binary_search(f).is_err())
            .collect();
        beyond.sort_unstable();
        beyond.dedup();
        let beyond: Vec<(u32, [DVec3; 3])> = beyond
            .into_iter()
            .map(|f| {
                (
                    f,
                    self.faces[f as usize].map(|v| self.positions[v as usize]),
                )
            })
            .collect();
        for &o in affected {
            // The faces near this triangle: one farther than eps from its box cannot hold any of
            // its nearest points within eps, so it is left out of the set.
            let (lo, hi) = bounds(&originals[o as usize]);
            let near = |r: &[DVec3; 3]| {
                let (rlo, rhi) = bounds(r);
                (rlo - hi).max(lo - rhi).max(DVec3::ZERO).length() <= eps
            };
            faces.clear();
            geometry.clear();
            for &f in &self.certified_by[o as usize] {
                if !self.alive[f as usize] || touched.contains(&f) {
                    continue;
                }
                let g = self.faces[f as usize].map(|v| self.positions[v as usize]);
                if near(&g) {
                    faces.push(f);
                    geometry.push(g);
                }
            }
            for (&f, r) in kept.iter().zip(ring) {
                if near(r) {
                    faces.push(f);
                    geometry.push(*r);
                }
            }
            for (f, g) in &beyond {
                if near(g) && !faces.contains(f) {
                    faces.push(*f);
                    geometry.push(*g);
                }
            }
            witnesses.clear();
            if !within_by(
                &[originals[o as usize]],
                &Triangles(&geometry),
                eps,
                CHECK_BUDGET,
                &mut witnesses,
            ) {
                return None;
            }
            // From now on it relies on the faces the proof used, not all those near it: fewer
            // links, so fewer re-certifications when a face changes.
            let mut support: Vec<u32> = witnesses.iter().map(|&i| faces[i as usize]).collect();
            support.sort_unstable();
            support.dedup();
            out.push(support);
        }
        Some(out)
    }

    /// Applies `vunify(a, b)` at `p`: `b`'s faces now use `a`, the faces with both die, and the
    /// certifying sets become `support`.
    #[allow(clippy::too_many_arguments)]
    fn apply(
        &mut self,
        a: u32,
        b: u32,
        p: DVec3,
        dying: &[u32],
        kept: &[u32],
        affected: &[u32],
        support: Vec<Vec<u32>>,
    ) {
        for &f in dying {
            self.alive[f as usize] = false;
            self.live_faces -= 1;
            self.covers[f as usize].clear();
        }
        for &f in kept {
            for v in &mut self.faces[f as usize] {
                if *v == b {
                    *v = a;
                }
            }
            self.covers[f as usize].clear();
        }
        let moved = std::mem::take(&mut self.around[b as usize]);
        self.around[a as usize].extend(moved);
        self.around[a as usize].retain(|&f| self.alive[f as usize]);
        self.around[a as usize].sort_unstable();
        self.around[a as usize].dedup();
        self.positions[a as usize] = p;
        let qb = self.quadric[b as usize];
        self.quadric[a as usize] += qb;
        self.version[a as usize] += 1;
        self.version[b as usize] += 1;
        // Certifying sets. The faces an affected original now relies on are ring faces, whose
        // lists were cleared above; untouched faces it relied on before (whose lists still name
        // it: lists are only cleared when their face changes); and untouched faces just beyond
        // the ring that its new proof found, whose lists may not name it yet — without that, a
        // later change to such a face would not re-certify it, and its proof would go stale.
        for (&o, faces) in affected.iter().zip(support) {
            for &f in &faces {
                let list = &mut self.covers[f as usize];
                if !list.contains(&o) {
                    list.push(o);
                }
            }
            self.certified_by[o as usize] = faces;
        }
    }

    /// The bookkeeping's invariant: every original's certifying faces are alive and name it in
    /// their `covers` lists. Returns the first original for which it fails.
    #[cfg(test)]
    fn stale_original(&self) -> Option<u32> {
        (0..self.certified_by.len() as u32).find(|&o| {
            self.certified_by[o as usize]
                .iter()
                .any(|&f| !self.alive[f as usize] || !self.covers[f as usize].contains(&o))
        })
    }

    fn into_mesh(self, input: &Mesh) -> Mesh {
        crate::simplify::live_mesh(&self.positions, &self.faces, &self.alive, input)
    }
}

fn bounds(t: &[DVec3; 3]) -> (DVec3, DVec3) {
    (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use proptest::prelude::*;

    /// A grid of `n × n` vertices over the unit square, heights from `h`, two triangles a cell.
    fn height_field(n: usize, h: &[f32]) -> Mesh {
        let positions = (0..n * n)
            .map(|i| {
                let (x, y) = (i % n, i / n);
                Vec3::new(
                    x as f32 / (n - 1) as f32,
                    y as f32 / (n - 1) as f32,
                    h[i % h.len()],
                )
            })
            .collect();
        let mut triangles = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let v = (y * n + x) as u32;
                let n = n as u32;
                triangles.push([v, v + 1, v + n + 1]);
                triangles.push([v, v + n + 1, v + n]);
            }
        }
        Mesh {
            positions,
            triangles,
            ..Default::default()
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        /// After every accepted collapse, every original triangle's certifying faces are alive and
        /// name it, so a change to any of them re-certifies it (the proof can never go stale).
        #[test]
        fn certifying_faces_name_their_originals(
            n in 5usize..11,
            heights in proptest::collection::vec(-0.08f32..0.08, 1..40),
            epsilon in 0.005f64..0.08,
        ) {
            let mesh = height_field(n, &heights);
            let options = BoundedOptions { epsilon, target_triangles: 0 };
            let mut stale = None;
            let mut collapses = 0;
            simplify_watched(&mesh, &options, &mut |_| {}, &mut |w| {
                collapses += 1;
                if stale.is_none() {
                    stale = w.stale_original().map(|o| (collapses, o));
                }
            })
            .unwrap();
            prop_assert!(stale.is_none(), "after collapse {:?} (collapse, original)", stale);
        }
    }
}

//! The paper's **local offset patches** (Zou, Shen and Peng, §2.2–2.3): for a triangle tried for
//! collapse, its ring `TT_i` (every face around its three corners) is offset along `+n` and `−n` at
//! each ring vertex by that vertex's own `ε_j`, making an outer and an inner patch. `ε_j` is the
//! largest value in `[0, ε0]` found by bisection at which neither patch meets the original mesh or
//! itself. The collapse is accepted when no deformed triangle meets either patch: they stay between.
//!
//! ```text
//!   outer patch  ·───·───·───·───·      each ring vertex j moved by ±ε_j n_j
//!                ╲ deformed ring ╱       (n_j: area-weighted normal of the current mesh)
//!   ring         ●───●───v───●───●      deformed triangles must meet neither patch
//!   inner patch  ·───·───·───·───·
//! ```
//!
//! The ring is the *current* mesh's, so what one collapse promises is relative to the surface it
//! starts from: a per-step bound. The patches must not cross the original mesh, which keeps a ring
//! that has drifted from tightening its own patches, but the steps can still add up; that is what
//! `vunify measure --certified` shows in BENCHMARKS.md.

use super::Counter;
use super::work::{Plan, Work};
use crate::measure::Bvh;
use crate::simplify::intersect::triangles_intersect;
use glam::DVec3;

/// Bisection steps on `[0, ε0]` for a vertex whose patch meets something at `ε0` (the paper counts
/// about two tries on average; most vertices take the full `ε0` at the first).
const BISECTIONS: usize = 4;

/// The ring of a planned collapse in local numbering, with each vertex's offset direction.
struct Ring {
    base: Vec<DVec3>,
    normals: Vec<DVec3>,
    triangles: Vec<[usize; 3]>,
}

/// Whether the collapse in `plan` keeps its deformed triangles between the local offset patches.
pub(super) fn admits(work: &Work, plan: &Plan, eps0: f64, original: &Bvh, tests: &Counter) -> bool {
    let mut vertices: Vec<u32> = plan
        .ring
        .iter()
        .flat_map(|&f| work.faces[f as usize])
        .collect();
    vertices.sort_unstable();
    vertices.dedup();
    let local = |v: u32| vertices.binary_search(&v).unwrap_or(0);
    let ring = Ring {
        base: vertices
            .iter()
            .map(|&v| work.positions[v as usize])
            .collect(),
        normals: vertices.iter().map(|&v| work.normal(v)).collect(),
        triangles: plan
            .ring
            .iter()
            .map(|&f| work.faces[f as usize].map(local))
            .collect(),
    };
    let Some(offsets) = ring.offsets(eps0, original, tests) else {
        return false;
    };
    [1.0, -1.0].into_iter().all(|side| {
        let patch = ring.layer(&offsets, side);
        plan.deformed.iter().all(|d| {
            patch.iter().all(|p| {
                tests.add(1);
                !triangles_intersect(d, p)
            })
        })
    })
}

impl Ring {
    /// One patch: the ring's triangles with each vertex moved `side · ε_j` along its normal.
    fn layer(&self, offsets: &[f64], side: f64) -> Vec<[DVec3; 3]> {
        self.triangles
            .iter()
            .map(|t| t.map(|j| self.base[j] + self.normals[j] * (side * offsets[j])))
            .collect()
    }

    /// Each ring vertex's `ε_j` by bisection, or `None` when some patch triangle still meets the
    /// original or its own patch with the offsets found (then the collapse is refused).
    fn offsets(&self, eps0: f64, original: &Bvh, tests: &Counter) -> Option<Vec<f64>> {
        let n = self.base.len();
        let mut current = vec![eps0; n];
        let mut bad = self.offending(&current, original, tests);
        if !bad.contains(&true) {
            return Some(current);
        }
        // [lo, hi]: lo is an offset at which the vertex's triangles passed, hi one at which they met.
        let (mut lo, mut hi) = (vec![0.0; n], vec![eps0; n]);
        let mut searching = bad.clone();
        for _ in 0..BISECTIONS {
            for j in (0..n).filter(|&j| searching[j]) {
                current[j] = 0.5 * (lo[j] + hi[j]);
            }
            bad = self.offending(&current, original, tests);
            for j in 0..n {
                match (bad[j], searching[j]) {
                    (true, true) => hi[j] = current[j],
                    (true, false) => (searching[j], hi[j]) = (true, current[j]),
                    (false, true) => lo[j] = current[j],
                    (false, false) => {}
                }
            }
        }
        for j in (0..n).filter(|&j| searching[j]) {
            current[j] = lo[j];
        }
        let bad = self.offending(&current, original, tests);
        (!bad.contains(&true)).then_some(current)
    }

    /// The ring vertices of every patch triangle that meets the original mesh, or a triangle of its
    /// own patch that shares no vertex with it.
    fn offending(&self, offsets: &[f64], original: &Bvh, tests: &Counter) -> Vec<bool> {
        let mut bad = vec![false; self.base.len()];
        let mut mark = |t: [usize; 3]| t.into_iter().for_each(|j| bad[j] = true);
        for side in [1.0, -1.0] {
            let patch = self.layer(offsets, side);
            for (i, p) in patch.iter().enumerate() {
                if meets(p, original, tests) {
                    mark(self.triangles[i]);
                }
                for (k, q) in patch.iter().enumerate().skip(i + 1) {
                    let (ti, tk) = (self.triangles[i], self.triangles[k]);
                    if tk.iter().any(|v| ti.contains(v)) {
                        continue;
                    }
                    tests.add(1);
                    if triangles_intersect(p, q) {
                        mark(ti);
                        mark(tk);
                    }
                }
            }
        }
        bad
    }
}

/// Whether triangle `t` meets any triangle of `mesh`.
pub(super) fn meets(t: &[DVec3; 3], mesh: &Bvh, tests: &Counter) -> bool {
    let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
    mesh.any_overlapping(lo, hi, |i| {
        tests.add(1);
        triangles_intersect(t, &mesh.triangle64(i))
    })
}

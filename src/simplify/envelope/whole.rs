//! Whole-model envelopes, built once before simplification: Cohen et al.'s two (*Simplification
//! envelopes*, SIGGRAPH 96) and the single inner one of Zou, Shen and Peng's earlier method
//! (Shen, Zou et al., Acta Electronica Sinica 30(12A), 2002).
//!
//! Every vertex `p_i` of the original moves to `p_i ± ε_i n_i` (area-weighted normal); the
//! original's triangles over the moved vertices make the outer and inner envelope. `ε_i` starts at
//! `ε0` and is halved, round after round, at every vertex of an envelope triangle that meets the
//! original mesh or a triangle of its own envelope sharing no vertex with it. A vertex still offending
//! after the last round keeps `ε_i = 0`: its envelope touches the model there, and since touching
//! counts as meeting, no deformed triangle may reach that vertex — the conservative end.
//!
//! Each collapse's deformed triangles are then tested against the envelopes through a BVH over each
//! (the method, with a modern data structure): none may meet an envelope.

use super::Counter;
use super::patch::meets;
use crate::measure::Bvh;
use crate::mesh::Mesh;
use crate::simplify::intersect::triangles_intersect;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Halvings of an offending vertex's offset before it is set to 0 (`ε0 / 2¹⁰` is under a
/// thousandth of it).
const ROUNDS: usize = 10;

pub(super) struct Envelope {
    layers: Vec<Bvh>,
    /// Vertices whose offset ended at 0.
    pub pinned: usize,
}

impl Envelope {
    /// Builds the envelopes on the given sides (`+1.0` outer, `-1.0` inner) of `mesh`.
    pub fn build(
        mesh: &Mesh,
        original: &Bvh,
        eps0: f64,
        sides: &[f64],
        tests: &Counter,
    ) -> Envelope {
        let normals = vertex_normals(mesh);
        let mut offsets = vec![eps0; mesh.positions.len()];
        let mut layers = Vec::new();
        for round in 0..=ROUNDS {
            layers = sides
                .iter()
                .map(|&side| layer(mesh, &normals, &offsets, side))
                .collect();
            let bad = offending(mesh, original, &layers, tests);
            if !bad.contains(&true) {
                break;
            }
            for (e, _) in offsets.iter_mut().zip(&bad).filter(|(_, b)| **b) {
                *e = if round + 1 >= ROUNDS { 0.0 } else { *e * 0.5 };
            }
        }
        Envelope {
            layers,
            pinned: offsets.iter().filter(|&&e| e == 0.0).count(),
        }
    }

    /// Whether none of `triangles` meets an envelope.
    pub fn admits(&self, triangles: &[[DVec3; 3]], tests: &Counter) -> bool {
        triangles
            .iter()
            .all(|t| self.layers.iter().all(|layer| !meets(t, layer, tests)))
    }
}

/// Area-weighted vertex normals, turned to point out of each connected part: a part whose signed
/// volume is negative faces inward (the horse), and there "inner" would otherwise mean outside — which
/// matters to the single envelope, the one side it guards.
fn vertex_normals(mesh: &Mesh) -> Vec<DVec3> {
    let n = mesh.positions.len();
    let mut normal = vec![DVec3::ZERO; n];
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            parent[v as usize] = parent[parent[v as usize] as usize];
            v = parent[v as usize];
        }
        v
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize].as_dvec3());
        let area_normal = (b - a).cross(c - a);
        for v in t {
            normal[*v as usize] += area_normal;
        }
        let r = root(&mut parent, t[0]);
        for &v in &t[1..] {
            let s = root(&mut parent, v);
            parent[s as usize] = r;
        }
    }
    let mut volume = vec![0.0f64; n];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize].as_dvec3());
        volume[root(&mut parent, t[0]) as usize] += a.dot(b.cross(c));
    }
    (0..n as u32)
        .map(|v| {
            let outward = volume[root(&mut parent, v) as usize] >= 0.0;
            normal[v as usize].normalize_or_zero() * if outward { 1.0 } else { -1.0 }
        })
        .collect()
}

/// One envelope as a BVH (its vertices rounded to `f32`: the envelope is whatever the BVH holds,
/// and every test uses exactly that).
fn layer(mesh: &Mesh, normals: &[DVec3], offsets: &[f64], side: f64) -> Bvh {
    let moved: Vec<Vec3> = mesh
        .positions
        .iter()
        .zip(normals)
        .zip(offsets)
        .map(|((p, n), e)| (p.as_dvec3() + *n * (side * e)).as_vec3())
        .collect();
    Bvh::new(&moved, &mesh.triangles)
}

/// The vertices of every envelope triangle that meets the original or its own envelope.
fn offending(mesh: &Mesh, original: &Bvh, layers: &[Bvh], tests: &Counter) -> Vec<bool> {
    let mut bad = vec![false; mesh.positions.len()];
    for layer in layers {
        let hits: Vec<usize> = (0..layer.len())
            .into_par_iter()
            .filter(|&i| {
                let t = layer.triangle64(i);
                let corners = mesh.triangles[layer.input_index(i)];
                if meets(&t, original, tests) {
                    return true;
                }
                let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                layer.any_overlapping(lo, hi, |k| {
                    let other = mesh.triangles[layer.input_index(k)];
                    !other.iter().any(|v| corners.contains(v)) && {
                        tests.add(1);
                        triangles_intersect(&t, &layer.triangle64(k))
                    }
                })
            })
            .map(|i| layer.input_index(i))
            .collect();
        for f in hits {
            for v in mesh.triangles[f] {
                bad[v as usize] = true;
            }
        }
    }
    bad
}

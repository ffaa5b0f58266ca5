//! The input's vertices as leaves, and their close non-edge pairs.

use super::NONE;
use super::node::cone_of;
use crate::mesh::Mesh;
use crate::simplify::metric::PairEnd;
use crate::simplify::pairs::close_pairs_near;
use crate::simplify::quadric::Quadric;
use crate::vtree::Node;
use glam::Vec3;
use rayon::prelude::*;

/// The leaves: each input vertex's node, with a sphere over its 1-ring (so that it covers the
/// triangles around the leaf) and a cone of those faces; and its mass, a third of their area.
/// Each face's normal is computed where a corner needs it (three times a face), not kept for all
/// faces at once: at a hundred million triangles that array was 1.6 GB at a build's peak.
/// `faces_of(v)`: the triangles around vertex `v`, with their corners, in index order.
pub(super) fn leaves<F, I>(mesh: &Mesh, faces_of: F) -> (Vec<Node>, Vec<f32>)
where
    F: Fn(u32) -> I + Sync,
    I: Iterator<Item = (u32, [u32; 3])> + Clone,
{
    let n = mesh.positions.len();
    // A face's unit normal (zero when degenerate) and a third of its area.
    let face = |t: [u32; 3]| {
        let [a, b, d] = t.map(|w| mesh.positions[w as usize]);
        let cross = (b - a).cross(d - a);
        let len = cross.length();
        (if len > 0.0 { cross / len } else { Vec3::ZERO }, len / 6.0)
    };
    let mut nodes: Vec<Node> = Vec::with_capacity(2 * n - 1);
    let mut mass: Vec<f32> = Vec::with_capacity(n);
    (0..n as u32)
        .into_par_iter()
        .map(|v| {
            let p = mesh.positions[v as usize];
            let (mut radius, mut area, mut nsum) = (0.0f32, 0.0f32, Vec3::ZERO);
            for (_, c) in faces_of(v) {
                let (unit, third) = face(c);
                area += third;
                nsum += unit * third;
                for w in c {
                    radius = radius.max(p.distance(mesh.positions[w as usize]));
                }
            }
            let cone = cone_of(
                faces_of(v)
                    .map(|(_, c)| face(c).0)
                    .filter(|n| *n != Vec3::ZERO),
            );
            let normal = mesh
                .normals
                .as_ref()
                .map_or(nsum.normalize_or_zero(), |ns| {
                    ns[v as usize].normalize_or_zero()
                });
            let color = mesh
                .colors
                .as_ref()
                .map_or(Vec3::ONE, |cs| super::input_color(cs[v as usize]));
            let node = Node {
                position: p.to_array(),
                error: 0.0,
                color: color.to_array(),
                parent: NONE,
                normal: normal.to_array(),
                children: [NONE, NONE],
                sphere: [p.x, p.y, p.z, radius],
                cone: [cone.axis.x, cone.axis.y, cone.axis.z, cone.cos_angle],
            };
            (node, area)
        })
        .unzip_into_vecs(&mut nodes, &mut mass);
    (nodes, mass)
}

/// Each vertex's pair end: its quadric (about the origin in `quadrics`) about its position, and
/// its Table 1 weight.
pub(super) fn pair_ends(quadrics: &[Quadric], weights: &[f32], positions: &[Vec3]) -> Vec<PairEnd> {
    quadrics
        .par_iter()
        .zip(weights)
        .zip(positions)
        .map(|((q, &w), &p)| PairEnd::new(q, p, w))
        .collect()
}

/// Each vertex's triangles in index order, in one array grouped by vertex (a counting sort): what
/// the leaves need of the mesh's adjacency, without a whole working mesh.
pub(super) struct FaceLists {
    start: Vec<u32>,
    faces: Vec<u32>,
}

impl FaceLists {
    pub(super) fn new(n: usize, triangles: &[[u32; 3]]) -> FaceLists {
        let mut start = vec![0u32; n + 1];
        for t in triangles {
            for &v in t {
                start[v as usize + 1] += 1;
            }
        }
        for v in 0..n {
            start[v + 1] += start[v];
        }
        let mut fill = start.clone();
        let mut faces = vec![0u32; 3 * triangles.len()];
        for (f, t) in triangles.iter().enumerate() {
            for &v in t {
                faces[fill[v as usize] as usize] = f as u32;
                fill[v as usize] += 1;
            }
        }
        FaceLists { start, faces }
    }

    pub(super) fn of(&self, v: u32) -> &[u32] {
        &self.faces[self.start[v as usize] as usize..self.start[v as usize + 1] as usize]
    }
}

/// Close non-edge pairs: vertices closer than `distance` and outside each other's 2-ring, at most
/// `per_vertex` per vertex (`edges`: the mesh's edges).
/// The close non-edge pairs `options` asks for (`--pair-distance`, a share of `diagonal`, and
/// `--max-pairs`), none when either is 0.
pub(super) fn close_pairs_for(
    positions: &[Vec3],
    edges: &[(u32, u32)],
    options: &super::BuildOptions,
    diagonal: f32,
) -> Vec<(u32, u32)> {
    if options.pair_distance > 0.0 && options.max_pairs_per_vertex > 0 {
        close_non_edge_pairs(
            positions,
            edges,
            options.pair_distance * diagonal,
            options.max_pairs_per_vertex,
        )
    } else {
        Vec::new()
    }
}

/// How far, in mean edge lengths, a vertex's close pairs are searched for first (the whole radius
/// only where that finds too few): a 2-ring reaches about two edges out.
const NEAR_EDGES: f32 = 4.0;

pub(super) fn close_non_edge_pairs(
    positions: &[Vec3],
    edges: &[(u32, u32)],
    distance: f32,
    per_vertex: usize,
) -> Vec<(u32, u32)> {
    let adjacency = Adjacency::new(positions.len(), edges);
    let points: Vec<(u32, Vec3)> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| (i as u32, *p))
        .collect();
    // A vertex's nearest points outside its 2-ring are a few edges away: searched there first.
    let mean_edge = edges
        .par_iter()
        .map(|&(a, b)| positions[a as usize].distance(positions[b as usize]) as f64)
        .sum::<f64>()
        / edges.len().max(1) as f64;
    let near = NEAR_EDGES * mean_edge as f32;
    close_pairs_near(&points, distance, near, per_vertex, |i, j| {
        !adjacency.within_two_rings(i, j)
    })
}
/// Compressed vertex adjacency, for the 2-ring test of close pairs.
pub(super) struct Adjacency {
    pub(super) offsets: Vec<u32>,
    pub(super) neighbors: Vec<u32>,
}

impl Adjacency {
    pub(super) fn new(n: usize, edges: &[(u32, u32)]) -> Adjacency {
        let mut offsets = vec![0u32; n + 1];
        for &(a, b) in edges {
            offsets[a as usize + 1] += 1;
            offsets[b as usize + 1] += 1;
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut neighbors = vec![0u32; offsets[n] as usize];
        for &(a, b) in edges {
            neighbors[fill[a as usize] as usize] = b;
            fill[a as usize] += 1;
            neighbors[fill[b as usize] as usize] = a;
            fill[b as usize] += 1;
        }
        for i in 0..n {
            neighbors[offsets[i] as usize..offsets[i + 1] as usize].sort_unstable();
        }
        Adjacency { offsets, neighbors }
    }

    pub(super) fn of(&self, v: u32) -> &[u32] {
        &self.neighbors[self.offsets[v as usize] as usize..self.offsets[v as usize + 1] as usize]
    }

    pub(super) fn within_two_rings(&self, a: u32, b: u32) -> bool {
        let ring = self.of(a);
        ring.binary_search(&b).is_ok() || ring.iter().any(|&k| self.of(k).binary_search(&b).is_ok())
    }
}

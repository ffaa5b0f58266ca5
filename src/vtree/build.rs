//! The offline builder (seed 001 §2.3): greedy `vunify` of the cheapest candidate pair until one vertex
//! is left, recording each merge as a tree node.
//!
//! 1. classify edges, build quadrics (with constraint planes on boundaries and creases);
//! 2. queue every edge and every close non-edge pair (outside each other's 2-ring);
//! 3. pop the cheapest valid pair; if its merge would flip a triangle, re-queue it once at a penalty;
//! 4. merge, record the node and the triangles that vanish, re-price the merged vertex's pairs;
//! 5. when the queue runs dry with more than one vertex left (separate parts, after each collapsed to a
//!    point), pair the survivors within a doubled radius and go on: the result is one tree, one root.

use super::{NONE, Node, PartInfo, VertexTree};
use crate::mesh::Mesh;
use crate::simplify::bounds::{NormalCone, Sphere};
use crate::simplify::collapse::{Collapser, Neighbor};
use crate::simplify::features;
use crate::simplify::metric::{HybridWeights, Pricing, merged_weight};
use crate::simplify::pairs::close_pairs;
use crate::simplify::{Metric, quadric::Quadric};
use glam::Vec3;
use rayon::prelude::*;
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::time::Instant;

/// Builder settings; `Default` gives the documented defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildOptions {
    /// How merges are priced and placed. Default: `Qem`.
    pub metric: Metric,
    /// Non-edge pairs closer than this fraction of the bounding-box diagonal are candidates.
    /// Default 0.001: bridges the seams and hairline gaps between the parts of scanned and CAD scenes;
    /// wider radii flood dense scans with pairs (0.005 gives the dragon 625k pairs and doubles the build
    /// time) while separate parts are joined anyway once each has collapsed. 0 disables them.
    pub pair_distance: f32,
    /// At most this many nearest non-edge partners per vertex. Default 2: close pairs matter where
    /// two sheets meet, and there each vertex needs only its nearest few across the gap.
    pub max_pairs_per_vertex: usize,
    /// Seed 001's θ in degrees: an edge whose dihedral angle is below it is sharp. Default 120°.
    pub sharp_angle_deg: f32,
    /// Seed 001's w1 and w2, used by `Metric::Hybrid`.
    pub hybrid: HybridWeights,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            metric: Metric::Qem,
            pair_distance: 0.001,
            max_pairs_per_vertex: 2,
            sharp_angle_deg: 120.0,
            hybrid: HybridWeights::default(),
        }
    }
}

/// What happened during a build, for the summary.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct BuildStats {
    pub leaves: u32,
    pub nodes: u32,
    pub depth: u32,
    pub input_triangles: u32,
    pub parts: u32,
    pub feature_edges: u32,
    pub proximity_pairs: u32,
    /// Merges put back in the queue because they would have flipped a triangle.
    pub flip_deferrals: u32,
    /// Times the queue ran dry with several roots and the pair radius was doubled.
    pub widenings: u32,
    /// Queue entries pushed and popped (most pops are stale entries, skipped).
    pub queue_pushes: u64,
    pub queue_pops: u64,
    pub seconds: f64,
}

#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("the mesh has no triangles")]
    Empty,
    #[error("the mesh has {0} vertices; at most 2^30 are supported")]
    TooLarge(usize),
    #[error("invalid mesh: {0}")]
    Invalid(String),
}

// Flags in the high bits of `Entry::b`.
const NO_EDGE: u32 = 1 << 31;
const PENALIZED: u32 = 1 << 30;
const SLOT: u32 = PENALIZED - 1;

/// A merge that would flip a triangle costs this many times more, plus a quarter of its squared length
/// (a fold moves the surface by about that much), when it comes round again.
const FLIP_PENALTY: f64 = 10.0;

/// How many merges between progress callbacks.
const PROGRESS_EVERY: usize = 4096;

/// A queued pair. Valid while both slots are live and neither changed after `created` (a merge count).
#[derive(Clone, Copy, Debug)]
struct Entry {
    /// `f32::to_bits` of a non-negative cost: for those, integer order is numeric order, and integer
    /// compares keep the heap's sift loops cheap (they dominate the build's profile).
    cost: u32,
    a: u32,
    b: u32,
    created: u32,
}

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    /// Reversed: `BinaryHeap` is a max-heap and the cheapest pair must come first. Ties break on the
    /// slots so that builds are deterministic.
    fn cmp(&self, o: &Self) -> Ordering {
        o.cost
            .cmp(&self.cost)
            .then(o.a.cmp(&self.a))
            .then(o.b.cmp(&self.b))
    }
}

/// The queue key of a cost (see [`Entry::cost`]); NaN, which a finite mesh never produces, sorts last.
fn key(cost: f64) -> u32 {
    let c = cost as f32;
    if c >= 0.0 {
        c.to_bits()
    } else if c.is_nan() {
        u32::MAX
    } else {
        0
    }
}

/// Cheap cone around a set of unit normals: axis their mean, angle their largest deviation from it.
fn cone_of(normals: impl Iterator<Item = Vec3> + Clone) -> NormalCone {
    let sum: Vec3 = normals.clone().sum();
    let axis = sum.normalize_or_zero();
    if axis == Vec3::ZERO {
        return if normals.clone().next().is_some() {
            NormalCone::FULL
        } else {
            NormalCone::EMPTY
        };
    }
    let min_dot = normals.map(|n| n.dot(axis)).fold(1.0f32, f32::min);
    if min_dot <= -0.999 {
        return NormalCone::FULL;
    }
    // Pad by about 0.1° so rounding never leaves a member outside.
    NormalCone {
        axis,
        cos_angle: (min_dot.clamp(-1.0, 1.0).acos() + 2e-3).cos(),
    }
}

fn unit_normal(p: &[Vec3], c: [u32; 3]) -> Vec3 {
    let [a, b, d] = c.map(|v| p[v as usize]);
    (b - a).cross(d - a).normalize_or_zero()
}

/// Builds the vertex tree of `mesh`. `progress(done, total)` is called every few thousand merges.
pub fn build(
    mesh: &Mesh,
    options: &BuildOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(VertexTree, BuildStats), BuildError> {
    let start = Instant::now();
    mesh.check().map_err(BuildError::Invalid)?;
    if mesh.triangles.is_empty() {
        return Err(BuildError::Empty);
    }
    let n = mesh.positions.len();
    if n >= SLOT as usize {
        return Err(BuildError::TooLarge(n));
    }
    let diagonal = mesh.diagonal().max(f32::MIN_POSITIVE);

    // 1. Features and quadrics.
    let feats = features::classify(&mesh.positions, &mesh.triangles, options.sharp_angle_deg);
    let mut quadrics = feats.quadrics;
    let mut weights = feats.vertex_weight;
    let mut collapser = Collapser::new(mesh.positions.clone(), &mesh.triangles);

    // Leaves: sphere over the 1-ring (so it covers the triangles around the leaf), cone of those faces.
    let leaf_data: Vec<(Sphere, NormalCone, f32, Vec3)> = (0..n as u32)
        .into_par_iter()
        .map(|v| {
            let p = mesh.positions[v as usize];
            let mut radius = 0.0f32;
            let mut area = 0.0f32;
            let mut nsum = Vec3::ZERO;
            for (_, c) in collapser.faces_of(v) {
                let [a, b, d] = c.map(|w| mesh.positions[w as usize]);
                let cross = (b - a).cross(d - a);
                area += cross.length() / 6.0; // a third of the triangle's area
                nsum += cross;
                for w in c {
                    radius = radius.max(p.distance(mesh.positions[w as usize]));
                }
            }
            let cone = cone_of(
                collapser
                    .faces_of(v)
                    .map(|(_, c)| unit_normal(&mesh.positions, c))
                    .filter(|n| *n != Vec3::ZERO),
            );
            (
                Sphere { center: p, radius },
                cone,
                area,
                nsum.normalize_or_zero(),
            )
        })
        .collect();
    let mut nodes: Vec<Node> = Vec::with_capacity(2 * n - 1);
    let mut mass: Vec<f32> = Vec::with_capacity(n);
    for (v, (sphere, cone, area, face_normal)) in leaf_data.into_iter().enumerate() {
        let normal = mesh
            .normals
            .as_ref()
            .map_or(face_normal, |ns| ns[v].normalize_or_zero());
        let color = mesh.colors.as_ref().map_or(Vec3::ONE, |cs| cs[v]);
        nodes.push(Node {
            position: mesh.positions[v].to_array(),
            error: 0.0,
            color: color.to_array(),
            parent: NONE,
            normal: normal.to_array(),
            children: [NONE, NONE],
            sphere: [
                sphere.center.x,
                sphere.center.y,
                sphere.center.z,
                sphere.radius,
            ],
            cone: [cone.axis.x, cone.axis.y, cone.axis.z, cone.cos_angle],
        });
        mass.push(area);
    }
    let mut node_of: Vec<u32> = (0..n as u32).collect();

    let pricing = Pricing {
        metric: options.metric,
        hybrid: options.hybrid,
        mean_edge_length: feats.mean_edge_length,
        vertex_weight: &[],
    };
    let price = |c: &Collapser, q: &[Quadric], w: &[f32], a: u32, b: u32, edge: bool| {
        let pricing = Pricing {
            vertex_weight: w,
            ..pricing
        };
        pricing.price(
            c.positions[a as usize],
            &q[a as usize],
            a,
            c.positions[b as usize],
            &q[b as usize],
            b,
            edge,
        )
    };

    // 2. The initial queue: all edges, then close pairs outside each other's 2-ring.
    let mut stats = BuildStats {
        leaves: n as u32,
        input_triangles: mesh.triangles.len() as u32,
        parts: mesh.parts.len() as u32,
        feature_edges: feats.is_feature.iter().filter(|&&f| f).count() as u32,
        ..Default::default()
    };
    let mut entries: Vec<Entry> = feats
        .edges
        .par_iter()
        .map(|&(a, b)| Entry {
            cost: key(price(&collapser, &quadrics, &weights, a, b, true).cost),
            a,
            b,
            created: 0,
        })
        .collect();
    if options.pair_distance > 0.0 && options.max_pairs_per_vertex > 0 {
        let adjacency = Adjacency::new(n, &feats.edges);
        let points: Vec<(u32, Vec3)> = mesh
            .positions
            .iter()
            .enumerate()
            .map(|(i, p)| (i as u32, *p))
            .collect();
        let pairs = close_pairs(
            &points,
            options.pair_distance * diagonal,
            options.max_pairs_per_vertex,
            |i, j| !adjacency.within_two_rings(i, j),
        );
        stats.proximity_pairs = pairs.len() as u32;
        for &(a, b) in &pairs {
            collapser.add_proximity_pair(a, b);
        }
        entries.par_extend(pairs.par_iter().map(|&(a, b)| Entry {
            cost: key(price(&collapser, &quadrics, &weights, a, b, false).cost),
            a,
            b: b | NO_EDGE,
            created: 0,
        }));
    }
    drop(feats.edges);
    let mut heap = BinaryHeap::from(entries);

    // 3-5. Merge until one vertex is left.
    let mut changed_at = vec![0u32; n];
    let mut merges: u32 = 0;
    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(mesh.triangles.len());
    let mut vanish_offsets: Vec<u32> = Vec::with_capacity(n);
    vanish_offsets.push(0);
    let mut removed = Vec::new();
    let mut neighbors: Vec<Neighbor> = Vec::new();
    let mut radius = options.pair_distance.max(1e-3) * diagonal;
    let total = n - 1;
    loop {
        while let Some(e) = heap.pop() {
            stats.queue_pops += 1;
            let (mut a, mut b) = (e.a, e.b & SLOT);
            if !collapser.is_live(a)
                || !collapser.is_live(b)
                || changed_at[a as usize] > e.created
                || changed_at[b as usize] > e.created
            {
                continue; // stale
            }
            let edge = e.b & NO_EDGE == 0;
            let cand = price(&collapser, &quadrics, &weights, a, b, edge);
            if e.b & PENALIZED == 0 && collapser.flips(a, b, cand.position) {
                let gap2 = collapser.positions[a as usize]
                    .distance_squared(collapser.positions[b as usize])
                    as f64;
                let cost = key(FLIP_PENALTY * cand.cost + 0.25 * gap2);
                heap.push(Entry {
                    cost,
                    a,
                    b: e.b | PENALIZED,
                    created: merges,
                });
                stats.flip_deferrals += 1;
                continue;
            }
            // Keep the slot with more triangles: fewer to rewrite.
            if collapser.faces_of(b).count() > collapser.faces_of(a).count() {
                std::mem::swap(&mut a, &mut b);
            }
            removed.clear();
            collapser.unify(a, b, cand.position, &mut removed);
            let (ai, bi) = (a as usize, b as usize);
            let u = nodes.len() as u32;
            let (s, t) = (node_of[ai] as usize, node_of[bi] as usize);
            nodes[s].parent = u;
            nodes[t].parent = u;
            let (ns, nt) = (nodes[s], nodes[t]);
            let q = quadrics[bi];
            quadrics[ai] += q;
            weights[ai] = merged_weight(weights[ai], weights[bi]);
            let (ms, mt) = (mass[ai], mass[bi]);
            mass[ai] = ms + mt;
            let (fs, ft) = if ms + mt > 0.0 {
                (ms / (ms + mt), mt / (ms + mt))
            } else {
                (0.5, 0.5)
            };
            let blend =
                |x: [f32; 3], y: [f32; 3]| Vec3::from_array(x) * fs + Vec3::from_array(y) * ft;
            let sphere = Sphere {
                center: Vec3::from_slice(&ns.sphere),
                radius: ns.sphere[3],
            }
            .union(Sphere {
                center: Vec3::from_slice(&nt.sphere),
                radius: nt.sphere[3],
            })
            .union_point(cand.position);
            let around = cone_of(
                collapser
                    .faces_of(a)
                    .map(|(_, c)| unit_normal(&collapser.positions, c))
                    .filter(|n| *n != Vec3::ZERO),
            );
            let cone = NormalCone {
                axis: Vec3::from_slice(&ns.cone),
                cos_angle: ns.cone[3],
            }
            .union(NormalCone {
                axis: Vec3::from_slice(&nt.cone),
                cos_angle: nt.cone[3],
            })
            .union(around);
            nodes.push(Node {
                position: cand.position.to_array(),
                error: (cand.error as f32).max(ns.error).max(nt.error),
                color: blend(ns.color, nt.color).to_array(),
                parent: NONE,
                normal: blend(ns.normal, nt.normal).normalize_or_zero().to_array(),
                children: [s as u32, t as u32],
                sphere: [
                    sphere.center.x,
                    sphere.center.y,
                    sphere.center.z,
                    sphere.radius,
                ],
                cone: [cone.axis.x, cone.axis.y, cone.axis.z, cone.cos_angle],
            });
            node_of[ai] = u;
            triangles.extend(removed.iter().map(|&(f, _)| mesh.triangles[f as usize]));
            vanish_offsets.push(triangles.len() as u32);
            merges += 1;
            changed_at[ai] = merges;

            collapser.neighbors(a, &mut neighbors);
            for nb in &neighbors {
                let cost = key(price(&collapser, &quadrics, &weights, a, nb.slot, nb.edge).cost);
                let flags = if nb.edge { 0 } else { NO_EDGE };
                heap.push(Entry {
                    cost,
                    a,
                    b: nb.slot | flags,
                    created: merges,
                });
            }
            stats.queue_pushes += neighbors.len() as u64;
            if merges as usize % PROGRESS_EVERY == 0 {
                progress(merges as usize, total);
            }
        }
        if collapser.live_count() <= 1 {
            break;
        }
        // The queue ran dry with several isolated vertices left: bridge them.
        stats.widenings += 1;
        let live: Vec<(u32, Vec3)> = collapser
            .live_slots()
            .map(|s| (s, collapser.positions[s as usize]))
            .collect();
        let per_vertex = options.max_pairs_per_vertex.max(1);
        let pairs = loop {
            let pairs = close_pairs(&live, radius, per_vertex, |_, _| true);
            if !pairs.is_empty() {
                break pairs;
            }
            radius *= 2.0;
        };
        for &(a, b) in &pairs {
            collapser.add_proximity_pair(a, b);
            let cost = key(price(&collapser, &quadrics, &weights, a, b, false).cost);
            heap.push(Entry {
                cost,
                a,
                b: b | NO_EDGE,
                created: merges,
            });
        }
    }
    progress(total, total);

    let tree = VertexTree {
        leaf_count: n as u32,
        nodes,
        triangles,
        vanish_offsets,
        metric: options.metric,
        has_colors: mesh.colors.is_some(),
        has_normals: mesh.normals.is_some(),
        parts: mesh
            .parts
            .iter()
            .map(|p| PartInfo {
                name: p.name.clone(),
                triangles: p.triangles.end - p.triangles.start,
            })
            .collect(),
    };
    stats.nodes = tree.nodes.len() as u32;
    stats.depth = tree.depth();
    stats.seconds = start.elapsed().as_secs_f64();
    Ok((tree, stats))
}

/// Compressed vertex adjacency, for the 2-ring test of close pairs.
struct Adjacency {
    offsets: Vec<u32>,
    neighbors: Vec<u32>,
}

impl Adjacency {
    fn new(n: usize, edges: &[(u32, u32)]) -> Adjacency {
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

    fn of(&self, v: u32) -> &[u32] {
        &self.neighbors[self.offsets[v as usize] as usize..self.offsets[v as usize + 1] as usize]
    }

    fn within_two_rings(&self, a: u32, b: u32) -> bool {
        let ring = self.of(a);
        ring.binary_search(&b).is_ok() || ring.iter().any(|&k| self.of(k).binary_search(&b).is_ok())
    }
}

//! The offline builder (Tao et al. §2.3): merge the cheapest candidate pair, again and again, until one
//! vertex is left, recording each merge as a tree node.
//!
//! 1. classify edges, build quadrics (with constraint planes on boundaries and creases);
//! 2. candidates: every edge, and every close non-edge pair outside each other's 2-ring;
//! 3. merge in order of cost, skipping merges that would flip a triangle while there are others;
//! 4. record the node: position, attributes, bounds, error, and the triangles that vanish;
//! 5. when no candidate is left but several vertices are (separate parts, each collapsed to a point),
//!    pair the survivors within a doubling radius and go on: the result is one tree with one root.
//!
//! Step 3 has two schedules. [`Schedule::Greedy`] is the paper's: one priority queue, always the single
//! cheapest pair. [`Schedule::Passes`] (the default) is meshoptimizer's: each pass prices every
//! candidate at once, sorts them, and merges the cheapest ones that share no vertex, up to a bounded
//! share of the mesh and of the cost range. Priced candidates are never stale within a pass, so the
//! order is greedy up to that bound, and the work is sorting and streaming arrays instead of chasing a
//! heap through cache misses: several times faster at the same quality (see BENCHMARKS.md).
//!
//! The steps, one file each: [`leaves`] (the input's vertices as leaves, their close pairs),
//! [`pricing`] (candidates priced in parallel), [`passes`] and [`greedy`] (the two schedules),
//! [`finisher`] (a pass's nodes completed on a second thread), [`node`] (a node's attributes, bounds
//! and error), [`queue`] (the candidates as the schedules hold them).

pub mod cells;
mod finisher;
mod greedy;
mod leaves;
mod node;
pub mod partition;
pub use partition::{
    BudgetTooSmall, CELLS_FLOOR_BYTES_PER_TRIANGLE, DEFAULT_CELL_TRIANGLES,
    WHOLE_BUILD_BYTES_PER_TRIANGLE, cells_build_bytes, cells_within, default_cells,
    whole_build_bytes,
};
mod passes;
mod pricing;
mod queue;
mod wedges;

use super::{NONE, Node, PartInfo, VertexTree};
use crate::mesh::Mesh;
use crate::simplify::Metric;
use crate::simplify::attribute_quadric::{AttributeQuadric, CHANNELS, LocalAttributeQuadric};
use crate::simplify::collapse::Collapser;
use crate::simplify::features;
use crate::simplify::metric::{Candidate, HybridWeights, PairEnd, Pricing};
use crate::simplify::pairs::close_pairs;
use glam::Vec3;
use node::{Merged, Pending, SAMPLES, Samples, fan_of, finish_node};
use queue::{Entry, PENALIZED, SLOT, penalized_key};
use rayon::prelude::*;
use std::time::Instant;

/// How merges are ordered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Schedule {
    /// Passes of non-overlapping cheapest merges (meshoptimizer's scheme).
    #[default]
    Passes,
    /// Strictly the cheapest pair each time, from one priority queue (the paper's algorithm).
    Greedy,
}

/// Builder settings; `Default` gives the documented defaults.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BuildOptions {
    /// How merges are priced and placed. Default: `Qem`.
    pub metric: Metric,
    /// Default: `Passes`.
    pub schedule: Schedule,
    /// Non-edge pairs closer than this fraction of the bounding-box diagonal are candidates.
    /// Default 0.001: bridges the seams and hairline gaps between the parts of scanned and CAD scenes;
    /// wider radii flood dense scans with pairs (0.005 gives the dragon 625k pairs and doubles the build
    /// time) while separate parts are joined anyway once each has collapsed. 0 disables them.
    pub pair_distance: f32,
    /// At most this many nearest non-edge partners per vertex. Default 2: close pairs matter where
    /// two sheets meet, and there each vertex needs only its nearest few across the gap.
    pub max_pairs_per_vertex: usize,
    /// Tao et al.'s θ in degrees: an edge whose dihedral angle is below it is sharp. Default 120°.
    pub sharp_angle_deg: f32,
    /// Tao et al.'s w1 and w2, used by `Metric::Hybrid`.
    pub hybrid: HybridWeights,
    /// How much vertex colour counts, for meshes that have it (lit meshes, scans with colour): a
    /// colour difference of one full channel costs like a deviation of this many bounding-box
    /// diagonals, both in the merge order and in each node's error, so the runtime's screen-space
    /// test keeps colour edges (shadows) as it keeps shape. On a textured mesh the merge order
    /// also weighs how far a merge slides the texture over the surface. Default 0.02 (see
    /// docs/VERTEX_TREE.md); 0 builds from shape alone.
    pub color_weight: f32,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            metric: Metric::Qem,
            schedule: Schedule::Passes,
            pair_distance: 0.001,
            max_pairs_per_vertex: 2,
            sharp_angle_deg: 120.0,
            hybrid: HybridWeights::default(),
            color_weight: 0.02,
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
    /// A partitioned build's cells and levels (see [`partition`]); 0 for a whole build.
    pub cells: u32,
    pub levels: u32,
    pub feature_edges: u32,
    pub proximity_pairs: u32,
    /// Merges postponed because they would have flipped a triangle.
    pub flip_deferrals: u32,
    /// Times no candidate was left with several roots, and the pair radius grew.
    pub widenings: u32,
    /// Passes (`Schedule::Passes`) or queue pops (`Schedule::Greedy`).
    pub rounds: u64,
    /// Candidate pairs priced.
    pub pricings: u64,
    pub seconds: f64,
    pub phases: Phases,
}

/// Wall-clock seconds of each part of a build (the parallel parts use every thread).
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Phases {
    /// Edge classification, Table 1 weights and quadrics.
    pub features: f64,
    /// Close non-edge pairs.
    pub close_pairs: f64,
    /// Leaf nodes and the working mesh.
    pub leaves: f64,
    /// Every candidate priced before the first pass; each pass's pairs chosen and priced.
    pub pricing: f64,
    /// The merges, their nodes finished alongside (greedy schedule: everything after the first
    /// pricing).
    pub merging: f64,
    /// Stale pairs dropped and the pairs around each pass's merges priced anew.
    pub repricing: f64,
}

#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("the mesh has no triangles")]
    Empty,
    #[error("the mesh has {0} vertices; at most 2^30 are supported")]
    TooLarge(usize),
    #[error("the mesh has {0} triangles; at most 2^31 are supported")]
    TooManyTriangles(usize),
    #[error("invalid mesh: {0}")]
    Invalid(#[from] crate::mesh::MeshProblem),
    #[error("the model's coordinates span more than a float holds (its diagonal is infinite)")]
    TooLargeCoordinates,
    /// A temporary file of a partitioned build (its levels' nodes, see [`build_partitioned`]).
    #[error("{}: {problem}", path.display())]
    Spill {
        path: std::path::PathBuf,
        problem: String,
    },
    /// A cell file of a build run in steps ([`cells`]).
    #[error("{}: {problem}", path.display())]
    Cell {
        path: std::path::PathBuf,
        problem: String,
    },
}

/// How many merges between progress callbacks.
const PROGRESS_EVERY: usize = 4096;

/// The state of a build: the working mesh, per-slot merge data, and the tree so far.
struct Builder<'m> {
    mesh: &'m Mesh,
    /// The input's positions, which the error samples name: `mesh`'s own, except in a partitioned
    /// build, whose levels' meshes are cells of live slots (see [`partition`]).
    leaf_positions: &'m [Vec3],
    /// Slots that must not merge (a cell's border in a partitioned build); `None` in a whole build.
    locked: Option<passes::SlotSet>,
    /// Whether a pass's nodes may be finished on a second thread (see [`finisher`]); off where
    /// the caller keeps every core busy already (the cells of a partitioned build).
    finisher: bool,
    /// The build stops when this many slots are live (1: the root), or earlier when only pairs
    /// with a locked end are left.
    target_live: usize,
    collapser: Collapser,
    /// Each slot's quadric (about its position) and Table 1 weight, as pricing reads them.
    ends: Vec<PairEnd>,
    /// Each slot's attribute quadric, about its position: empty for a mesh without colours (or with
    /// colour weighed at 0).
    colors: Vec<LocalAttributeQuadric>,
    /// Surface area each slot stands for: the weight of attribute averages.
    mass: Vec<f32>,
    /// The tree node each live slot currently is.
    node_of: Vec<u32>,
    nodes: Vec<Node>,
    /// The input triangles that vanish at each merge, by index, in node order. The corners are read
    /// after the merges ([`build`]): read here, each would be a cache miss on the sequential path.
    vanished: Vec<u32>,
    vanish_offsets: Vec<u32>,
    metric: Metric,
    hybrid: HybridWeights,
    mean_edge_length: f32,
    /// [`Pricing::color_scale`]: 0 for a mesh without colours.
    color_scale: f32,
    stats: BuildStats,
    removed: Vec<(u32, crate::simplify::collapse::Vanish)>,
    /// Error samples of each live slot (input vertex ids, `NONE`-padded).
    samples: Vec<Samples>,
    /// A mesh with texture coordinates or materials is built on welded positions, its vertices
    /// carried as wedges (see [`wedges`]); `colors` then holds each slot's principal wedge's.
    wedges: Option<wedges::WedgeState>,
    /// With wedges, each slot's principal wedge's texture, and each texture's scale (see
    /// [`texture_scales`]), as pricing reads them; empty otherwise.
    charts: Vec<u32>,
    scales: Vec<f32>,
}

impl Builder<'_> {
    fn pricing(&self) -> Pricing {
        Pricing {
            metric: self.metric,
            hybrid: self.hybrid,
            mean_edge_length: self.mean_edge_length,
            color_scale: self.color_scale,
        }
    }

    fn price(&self, a: u32, b: u32, edge: bool) -> Candidate {
        let (a, b) = (a as usize, b as usize);
        if self.wedges.is_some() {
            let ends = |s: usize| (&self.ends[s], self.colors.get(s), self.charts[s]);
            return wedges::price(&self.pricing(), ends(a), ends(b), edge, &self.scales);
        }
        let colors = (!self.colors.is_empty()).then(|| [&self.colors[a], &self.colors[b]]);
        self.pricing()
            .price(&self.ends[a], &self.ends[b], edge, colors)
    }

    /// With wedges, node `u`'s (the merge `merged`, whose vanished triangles are in `removed`):
    /// its principal wedge's quadric and texture, and the merge's texture slide.
    fn merge_wedges(
        &mut self,
        merged: &Merged,
        u: u32,
    ) -> Option<(LocalAttributeQuadric, u32, f32)> {
        let (removed, colors) = (&self.removed, &self.colors);
        self.wedges.as_mut().map(|w| {
            w.merge(
                (merged.slot, merged.gone),
                u,
                merged.position,
                removed.iter().map(|&(f, _)| f),
                removed
                    .iter()
                    .any(|&(_, v)| v == crate::simplify::collapse::Vanish::Degenerate),
                colors,
            )
        })
    }

    fn merges(&self) -> u32 {
        self.nodes.len() as u32 - self.mesh.positions.len() as u32
    }

    /// `vunify(a, b)` at the priced position, recorded as a new node. Returns the surviving slot.
    fn merge(&mut self, a: u32, b: u32, cand: &Candidate) -> u32 {
        let pending = self.pending(a, b);
        let mut nodes = std::mem::take(&mut self.nodes);
        let u = nodes.len() as u32;
        let (mut node, mut merged) = self.merge_topology(a, b, cand, u, pending);
        let survivor = merged.slot;
        let (s, g) = (survivor as usize, merged.gone as usize);
        let principal = self.merge_wedges(&merged, u).map(|(q, chart, slide)| {
            merged.slide = slide;
            (q, chart)
        });
        let color = if let Some((q, chart)) = principal {
            self.charts[s] = chart;
            (!self.colors.is_empty()).then_some(q)
        } else {
            (!self.colors.is_empty()).then(|| {
                PairEnd::merged_color(
                    (&self.ends[s], &self.colors[s]),
                    (&self.ends[g], &self.colors[g]),
                    merged.position,
                )
            })
        };
        if let Some(c) = color {
            self.colors[s] = c;
        }
        self.ends[s] = PairEnd::merged(&self.ends[s], &self.ends[g], merged.position);
        let mut fan = Vec::new();
        fan_of(&self.collapser, survivor, &mut fan);
        self.samples[survivor as usize] = finish_node(
            &mut node,
            &nodes,
            &merged,
            &fan,
            self.leaf_positions,
            wedges::node_color(self.color_scale, color, principal),
        );
        for c in node.children {
            nodes[c as usize].parent = u;
        }
        nodes.push(node);
        self.nodes = nodes;
        survivor
    }

    /// Asks for what merging `a` and `b` will read, in stages a few merges ahead (see
    /// [`Collapser::prefetch_pair`]): the working mesh around them, and their quadrics, weights,
    /// masses, samples and current nodes (`done`). Only a hint.
    fn prefetch_merge(&self, a: u32, b: u32, stage: u32) {
        self.collapser.prefetch_pair(a, b, stage);
        if stage == 0 {
            for s in [a as usize, b as usize] {
                crate::prefetch(&self.node_of[s]);
                crate::prefetch(&self.samples[s]);
                crate::prefetch(&self.mass[s]);
            }
        }
        if let Some(w) = &self.wedges {
            w.prefetch_merge(a, b, stage);
        }
    }

    /// Both slots' error samples, before they merge.
    fn pending(&self, a: u32, b: u32) -> Pending {
        let mut out = [NONE; 2 * SAMPLES];
        out[..SAMPLES].copy_from_slice(&self.samples[a as usize]);
        out[SAMPLES..].copy_from_slice(&self.samples[b as usize]);
        out
    }

    /// The sequential half of a merge: the working mesh, the vanishing triangles. Returns the new
    /// node `u`, whose colour, normal, sphere, cone and error [`finish_node`] completes from the
    /// returned [`Merged`] (`pending`: both slots' samples); the caller links its children to it,
    /// stores it, and stores the survivor's new pricing data ([`PairEnd::merged`]).
    fn merge_topology(
        &mut self,
        a: u32,
        b: u32,
        cand: &Candidate,
        u: u32,
        pending: Pending,
    ) -> (Node, Merged) {
        // Keep the slot with more triangles: fewer to rewrite.
        let (a, b) = if self.collapser.face_count(b) > self.collapser.face_count(a) {
            (b, a)
        } else {
            (a, b)
        };
        let across_gap = !self.collapser.faces_of(a).any(|(_, f)| f.contains(&b));
        self.removed.clear();
        self.collapser.unify(a, b, cand.position, &mut self.removed);
        let (ai, bi) = (a as usize, b as usize);
        let (s, t) = (self.node_of[ai] as usize, self.node_of[bi] as usize);
        let (ms, mt) = (self.mass[ai], self.mass[bi]);
        self.mass[ai] = ms + mt;
        let blend = if ms + mt > 0.0 {
            [ms / (ms + mt), mt / (ms + mt)]
        } else {
            [0.5, 0.5]
        };
        let node = Node {
            position: cand.position.to_array(),
            error: cand.error as f32,
            color: [0.0; 3],
            parent: NONE,
            normal: [0.0; 3],
            children: [s as u32, t as u32],
            sphere: [0.0; 4],
            cone: [0.0; 4],
        };
        self.node_of[ai] = u;
        self.vanished.extend(self.removed.iter().map(|&(f, _)| f));
        self.vanish_offsets.push(self.vanished.len() as u32);
        let merged = Merged {
            blend,
            pending,
            slot: a,
            gone: b,
            position: cand.position,
            across_gap,
            principal: None,
            slide: 0.0,
        };
        (node, merged)
    }

    /// If merging `e`'s pair at `cand` would flip a triangle and it has not been deferred before,
    /// defers it: back in the list at a penalty. Returns whether it did.
    pub(super) fn defer_if_flips(&mut self, e: &mut Entry, cand: &Candidate) -> bool {
        let (a, b) = (e.a, e.b & SLOT);
        if e.b & PENALIZED != 0 || !self.collapser.flips(a, b, cand.position) {
            return false;
        }
        let c = &self.collapser;
        let gap2 = c.positions[a as usize].distance_squared(c.positions[b as usize]) as f64;
        e.cost = penalized_key(cand.cost, gap2);
        e.b |= PENALIZED;
        self.stats.flip_deferrals += 1;
        true
    }

    /// No candidate is left but several isolated vertices are: pair each with its nearest others within
    /// a radius that doubles until some pair is found. Returns the new pairs.
    fn widen(&mut self, radius: &mut f32, per_vertex: usize) -> Vec<(u32, u32)> {
        self.stats.widenings += 1;
        let c = &self.collapser;
        let live: Vec<(u32, Vec3)> = c
            .live_slots()
            .map(|s| (s, c.positions[s as usize]))
            .collect();
        let pairs = loop {
            let pairs = close_pairs(&live, *radius, per_vertex.max(1), |_, _| true);
            if !pairs.is_empty() {
                break pairs;
            }
            *radius *= 2.0;
        };
        for &(a, b) in &pairs {
            self.collapser.add_proximity_pair(a, b);
        }
        pairs
    }
}

/// Builds the vertex tree of `mesh`. `progress(done, total)` is called every few thousand merges.
pub fn build(
    mesh: &Mesh,
    options: &BuildOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(VertexTree, BuildStats), BuildError> {
    build_scaled(mesh, progress, &mut |unit, progress| {
        build_unit(unit, options, progress)
    })
}

/// [`build`] in cells of at most `cell_triangles` triangles, built in parallel with their borders
/// locked and joined level by level (see [`partition`]): one vertex tree all the same. A mesh with
/// vertex colours, texture coordinates or materials, or one that fits in one cell, is built whole. The
/// cells build with the passes schedule whatever `options.schedule` says. The nodes each level
/// makes wait on disk, in a temporary folder inside `spill` (the output's folder, say), until the
/// tree is numbered.
pub fn build_partitioned(
    mesh: &Mesh,
    options: &BuildOptions,
    cell_triangles: usize,
    spill: &std::path::Path,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(VertexTree, BuildStats), BuildError> {
    build_scaled(mesh, progress, &mut |unit, progress| {
        if builds_whole(unit, cell_triangles) {
            build_unit(unit, options, progress)
        } else {
            partition::build(unit, options, cell_triangles, spill, progress)
        }
    })
}

/// Whether [`build_partitioned`] builds `unit` whole: it fits in one cell, or carries colours,
/// texture coordinates or materials, which the cells do not carry yet.
pub(super) fn builds_whole(unit: &Mesh, cell_triangles: usize) -> bool {
    unit.triangles.len() <= cell_triangles
        || unit.colors.is_some()
        || unit.uvs.is_some()
        || unit.material_of.is_some()
}

/// Runs `build_at_unit` on `mesh`, checked, and scaled to near unit size when it is far from it.
#[allow(clippy::type_complexity)]
fn build_scaled(
    mesh: &Mesh,
    progress: &mut dyn FnMut(usize, usize),
    build_at_unit: &mut dyn FnMut(
        &Mesh,
        &mut dyn FnMut(usize, usize),
    ) -> Result<(VertexTree, BuildStats), BuildError>,
) -> Result<(VertexTree, BuildStats), BuildError> {
    let (unit, factor) = at_unit_size(mesh)?;
    let (mut tree, stats) = build_at_unit(&unit, progress)?;
    if factor != 1.0 {
        tree.scale_lengths(1.0 / factor);
    }
    Ok((tree, stats))
}

/// `mesh`, checked, near unit size: scaled by a power of two when far from it, and the factor.
///
/// Quadrics hold fourth powers of lengths in `f32`: far from unit size they underflow (a model
/// 1e-10 across prices every merge at 0) or overflow (1e7 across writes infinite errors). Such a
/// model is built at unit size, scaled by a power of two (exact in floating point), and its tree
/// scaled back.
fn at_unit_size(mesh: &Mesh) -> Result<(std::borrow::Cow<'_, Mesh>, f32), BuildError> {
    mesh.check().map_err(BuildError::Invalid)?;
    let diagonal = mesh.diagonal();
    if !diagonal.is_finite() {
        return Err(BuildError::TooLargeCoordinates);
    }
    if diagonal > 0.0 && !(UNSCALED_DIAGONAL.0..=UNSCALED_DIAGONAL.1).contains(&diagonal) {
        let factor = (-diagonal.log2().round()).exp2();
        let unit = Mesh {
            positions: mesh.positions.iter().map(|&p| p * factor).collect(),
            ..mesh.clone()
        };
        return Ok((std::borrow::Cow::Owned(unit), factor));
    }
    Ok((std::borrow::Cow::Borrowed(mesh), 1.0))
}

/// Each part of `mesh` as the tree records it: its name and triangle count.
fn part_infos(mesh: &Mesh) -> Vec<PartInfo> {
    mesh.parts
        .iter()
        .map(|p| PartInfo {
            name: p.name.clone(),
            triangles: p.triangles.end - p.triangles.start,
        })
        .collect()
}

/// Models whose diagonal lies in this range are built as they are: the quadrics' fourth powers stay
/// well inside `f32` (they broke between 1e6 and 1e7 across, and below 1e-9). The range holds every
/// model of the benchmarks (0.25 to 733 units across), whose trees stay the same bit for bit.
const UNSCALED_DIAGONAL: (f32, f32) = (1.0 / 4096.0, 4096.0);

/// [`build`] of a mesh near unit size: one with texture coordinates or materials on its welded
/// positions, its vertices carried as wedges.
fn build_unit(
    mesh: &Mesh,
    options: &BuildOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(VertexTree, BuildStats), BuildError> {
    if mesh.triangles.is_empty() {
        return Err(BuildError::Empty);
    }
    if mesh.uvs.is_none() && mesh.material_of.is_none() {
        return build_geometry(mesh, None, options, progress);
    }
    let mut welded = wedges::weld(mesh);
    let geometry = std::mem::take(&mut welded.geometry);
    crate::memory::trace_phase("welding");
    build_geometry(&geometry, Some((mesh, welded)), options, progress)
}

/// [`build_unit`] on `mesh`, whose vertices are `source`'s welded when it is given.
fn build_geometry(
    mesh: &Mesh,
    source: Option<(&Mesh, wedges::Welded)>,
    options: &BuildOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(VertexTree, BuildStats), BuildError> {
    let start = Instant::now();
    if mesh.triangles.is_empty() {
        return Err(BuildError::Empty);
    }
    let n = mesh.positions.len();
    if n >= SLOT as usize {
        return Err(BuildError::TooLarge(n));
    }
    if mesh.triangles.len() >= features::MAX_TRIANGLES {
        return Err(BuildError::TooManyTriangles(mesh.triangles.len()));
    }
    let diagonal = mesh.diagonal().max(f32::MIN_POSITIVE);

    // 1. Features and quadrics.
    let clock = Instant::now();
    let feats = match &source {
        Some((_, welded)) => features::classify_with_seams(
            &mesh.positions,
            &mesh.triangles,
            options.sharp_angle_deg,
            |f0, f1, u, v| wedges::is_seam(welded, &mesh.triangles, [f0, f1], [u, v]),
        ),
        None => features::classify(&mesh.positions, &mesh.triangles, options.sharp_angle_deg),
    };
    let features_secs = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    // 2. Close non-edge pairs (edges come from the working mesh itself). Found before the working mesh
    // and the nodes exist: the grid is the largest temporary of the build, and this keeps it off the peak.
    let mut stats = BuildStats {
        leaves: n as u32,
        input_triangles: mesh.triangles.len() as u32,
        parts: mesh.parts.len() as u32,
        feature_edges: feats.is_feature.iter().filter(|&&f| f).count() as u32,
        ..Default::default()
    };
    let close = leaves::close_pairs_for(&mesh.positions, &feats.edges, options, diagonal);
    stats.proximity_pairs = close.len() as u32;
    stats.phases.features = features_secs;
    stats.phases.close_pairs = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let features::Features {
        edges,
        quadrics,
        vertex_weight,
        mean_edge_length,
        ..
    } = feats;

    let mut collapser = Collapser::new(mesh.positions.clone(), &mesh.triangles);
    let (nodes, mass) = leaves::leaves(mesh, |v| collapser.faces_of(v));

    for &(a, b) in &close {
        collapser.add_proximity_pair(a, b);
    }

    let ends = leaves::pair_ends(&quadrics, &vertex_weight, &mesh.positions);
    let color_scale = match mesh.colors {
        Some(_) => options.color_weight.max(0.0) * diagonal,
        None => 0.0,
    };
    let input = source.as_ref().map(|(m, _)| *m);
    let (colors, wedges, charts, scales) = appearance_state(mesh, source, color_scale);
    drop((quadrics, vertex_weight));
    crate::memory::trace_phase("the leaves");

    // 3-5. Merge until one vertex is left.
    let mut vanish_offsets = Vec::with_capacity(n);
    vanish_offsets.push(0);
    let mut builder = Builder {
        mesh,
        leaf_positions: &mesh.positions,
        locked: None,
        finisher: true,
        target_live: 1,
        collapser,
        ends,
        colors,
        mass,
        node_of: (0..n as u32).collect(),
        nodes,
        vanished: Vec::with_capacity(mesh.triangles.len()),
        vanish_offsets,
        metric: options.metric,
        hybrid: options.hybrid,
        mean_edge_length,
        color_scale,
        stats,
        removed: Vec::new(),
        samples: (0..n as u32)
            .map(|v| {
                let mut s = [NONE; SAMPLES];
                s[0] = v;
                s
            })
            .collect(),
        wedges,
        charts,
        scales,
    };
    builder.stats.phases.leaves = clock.elapsed().as_secs_f64();
    // Every pair of the mesh, priced once: its edges and its close pairs are exactly the partners of
    // each slot, listed already.
    let clock = Instant::now();
    let mut initial = builder.price_pairs(&edges, true);
    drop(edges);
    initial.extend(builder.price_pairs(&close, false));
    drop(close);
    builder.stats.phases.pricing += clock.elapsed().as_secs_f64();
    crate::memory::trace_phase("pricing every pair");
    let mut radius = options.pair_distance.max(1e-3) * diagonal;
    match options.schedule {
        Schedule::Passes => {
            builder.run_passes(initial, &mut radius, options.max_pairs_per_vertex, progress)
        }
        Schedule::Greedy => {
            builder.run_greedy(initial, &mut radius, options.max_pairs_per_vertex, progress)
        }
    }
    progress(n - 1, n - 1);
    crate::memory::trace_phase("merging");

    let (tree, mut stats) = builder.into_tree(options, input);
    crate::memory::trace_phase("the tree");
    stats.seconds = start.elapsed().as_secs_f64();
    Ok((tree, stats))
}

impl Builder<'_> {
    /// The finished tree: the vanished triangles' corners read now, in node order (see
    /// [`Builder::vanished`]), and the input's parts.
    fn into_tree(self, options: &BuildOptions, input: Option<&Mesh>) -> (VertexTree, BuildStats) {
        let Builder {
            mesh,
            mut stats,
            nodes,
            vanished,
            vanish_offsets,
            wedges,
            ..
        } = self;
        let triangles = vanished
            .par_iter()
            .map(|&f| mesh.triangles[f as usize])
            .collect();
        let wedges = wedges.map(|w| {
            let firsts = w.firsts().to_vec();
            (w.finish(&vanished), firsts)
        });
        drop(vanished);
        let mut tree = geometry_tree(mesh, options, nodes, triangles, vanish_offsets);
        if let (Some((wedges, firsts)), Some(input)) = (wedges, input) {
            (tree.appearance, tree.materials) = wedges::node_appearance(input, &wedges, &firsts);
            tree.wedges = Some(wedges);
        }
        stats.nodes = tree.nodes.len() as u32;
        stats.depth = tree.depth();
        (tree, stats)
    }
}

/// The tree of `mesh` built with `options` from its nodes, triangles and their offsets, without
/// appearance (what [`Builder::into_tree`] adds).
pub(super) fn geometry_tree(
    mesh: &Mesh,
    options: &BuildOptions,
    nodes: Vec<Node>,
    triangles: Vec<[u32; 3]>,
    vanish_offsets: Vec<u32>,
) -> VertexTree {
    let mut tree = VertexTree {
        leaf_count: mesh.positions.len() as u32,
        nodes,
        triangles,
        vanish_offsets,
        metric: options.metric,
        has_colors: mesh.colors.is_some(),
        has_normals: mesh.normals.is_some(),
        one_sided: mesh.one_sided,
        appearance: None,
        materials: None,
        wedges: None,
        position_error: 0.0,
        inward: None,
        parts: part_infos(mesh),
    };
    // Decided once, on the positions as built, and recorded in the file.
    tree.inward = Some(tree.winds_inward());
    tree
}

/// Two wedges of one texture whose best coordinates at a merged place lie further apart than this
/// are on different charts (or a chart's far sides): pricing does not expect the merge to join
/// them (see [`wedges::price`]).
pub(super) const CHART_UV_DISTANCE: f32 = 0.05;

/// What pricing weighs of appearance: each slot's attribute quadric (empty when appearance is
/// not weighed), and with wedges (`source`: the input and its welding) their state, each slot's
/// principal texture and each texture's scale.
#[allow(clippy::type_complexity)]
fn appearance_state(
    mesh: &Mesh,
    source: Option<(&Mesh, wedges::Welded)>,
    color_scale: f32,
) -> (
    Vec<LocalAttributeQuadric>,
    Option<wedges::WedgeState>,
    Vec<u32>,
    Vec<f32>,
) {
    let quadrics_of = |m: &Mesh, scales: &[f32]| match &m.colors {
        Some(colors) if color_scale > 0.0 => attribute_quadrics(m, colors, color_scale, scales),
        _ => Vec::new(),
    };
    let Some((input, welded)) = source else {
        return (
            quadrics_of(mesh, &texture_scales(mesh)),
            None,
            Vec::new(),
            Vec::new(),
        );
    };
    let scales = texture_scales(input);
    let (state, colors) = wedges::WedgeState::new(
        input,
        welded,
        quadrics_of(input, &scales),
        scales.clone(),
        color_scale,
    );
    let charts = state.charts();
    (colors, Some(state), charts, scales)
}

/// On a textured vertex the colour (the texture's mean around it) counts this share of
/// `--color-weight`: the texture coordinates' channels already price what the texture shows, and
/// the colour at full weight priced it twice, crudely (the textured bunny's static level at 10 %
/// measured 33.6 dB at full weight, 35.3 at a fortieth; its scene 45.9 and 50.3).
const TEXTURED_COLOR_SHARE: f32 = 1.0 / 32.0;

/// The length a colour difference of one counts as on a vertex (or wedge) that is `textured` or
/// not, for a mesh whose colour scale is `color_scale`.
pub(super) fn color_scale_of(color_scale: f32, textured: bool) -> f32 {
    if textured {
        color_scale * TEXTURED_COLOR_SHARE
    } else {
        color_scale
    }
}

/// An input colour as the builder reads it: colours are meant to lie in [0, 1], and one beyond (a
/// float PLY may hold any finite value) is read as its nearest in range, in the leaves and the colour
/// quadrics alike.
pub(super) fn input_color(c: Vec3) -> Vec3 {
    c.clamp(Vec3::ZERO, Vec3::ONE)
}

/// Each vertex's attribute quadric (see [`crate::simplify::attribute_quadric`]): its triangles'
/// summed, about the vertex. The channels in units of length: a colour times `color_scale`,
/// texture coordinates times `scales` (the [`texture_scales`]).
///
/// The vertices are cut into [`QUADRIC_BLOCKS`] blocks, each summed on its own core in `f64` from
/// every triangle with a corner in it (in index order, so each sum is the same bits whatever the
/// blocks), then rounded about its vertices: no whole-mesh array of 256-byte sums, and a triangle
/// is computed again only for each other block its corners reach.
fn attribute_quadrics(
    mesh: &Mesh,
    colors: &[Vec3],
    color_scale: f32,
    scales: &[f32],
) -> Vec<LocalAttributeQuadric> {
    let channels = |v: u32| -> [f64; CHANNELS] {
        let textured = mesh
            .texture_of
            .as_ref()
            .is_some_and(|t| t[v as usize] != crate::mesh::NO_TEXTURE);
        let c = input_color(colors[v as usize]) * color_scale_of(color_scale, textured);
        let (uv, s) = match (&mesh.uvs, &mesh.texture_of) {
            (Some(uvs), Some(of)) => (
                uvs[v as usize],
                scales.get(of[v as usize] as usize).copied().unwrap_or(0.0),
            ),
            _ => (glam::Vec2::ZERO, 0.0),
        };
        [c.x, c.y, c.z, uv.x * s, uv.y * s].map(f64::from)
    };
    let n = mesh.positions.len();
    let mut out = vec![LocalAttributeQuadric::default(); n];
    let block = n.div_ceil(QUADRIC_BLOCKS).max(1);
    out.par_chunks_mut(block).enumerate().for_each(|(b, out)| {
        let first = (b * block) as u32;
        let mut sums = vec![AttributeQuadric::default(); out.len()];
        for t in &mesh.triangles {
            if !t.iter().any(|&v| v.wrapping_sub(first) < out.len() as u32) {
                continue;
            }
            let q = AttributeQuadric::from_triangle(
                t.map(|v| mesh.positions[v as usize]),
                t.map(channels),
            );
            for &v in t {
                if let Some(sum) = sums.get_mut(v.wrapping_sub(first) as usize) {
                    *sum += q;
                }
            }
        }
        for (k, (o, q)) in out.iter_mut().zip(&sums).enumerate() {
            let p = mesh.positions[first as usize + k];
            *o = LocalAttributeQuadric::new(&q.shifted(p.as_dvec3()));
        }
    });
    out
}

/// How many blocks [`attribute_quadrics`] sums the vertices in: enough for every core to have
/// several, few enough that scanning the triangles once a block costs little beside the sums.
const QUADRIC_BLOCKS: usize = 16;

/// Per texture, the surface's length per unit of texture space: the square root of the area of
/// the triangles that use it over their area in texture space (0 for a texture no triangle
/// spans). A texture coordinate times it is where on the surface its texel lies, give or take the
/// chart's layout, so a residual in these units is how far the texture slides.
fn texture_scales(mesh: &Mesh) -> Vec<f32> {
    let (Some(uvs), Some(of)) = (&mesh.uvs, &mesh.texture_of) else {
        return Vec::new();
    };
    let mut areas = vec![(0f64, 0f64); mesh.textures.len()];
    for t in &mesh.triangles {
        let Some(a) = areas.get_mut(of[t[0] as usize] as usize) else {
            continue;
        };
        let [p, q, r] = t.map(|v| mesh.positions[v as usize]);
        let [u, v, w] = t.map(|v| uvs[v as usize]);
        a.0 += 0.5 * (q - p).cross(r - p).length() as f64;
        a.1 += 0.5 * (v - u).perp_dot(w - u).abs() as f64;
    }
    areas
        .iter()
        .map(|&(world, texture)| {
            if texture > 0.0 {
                (world / texture).sqrt() as f32
            } else {
                0.0
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The blocked sums are the plain ones, bit for bit: every vertex's triangles in index order,
    /// whichever block its triangles' other corners fall in. A 9 × 9 grid of vertices whose
    /// triangles join vertices far apart in index order (the rows are shuffled), so most reach
    /// across blocks, with colours and texture coordinates that no linear map fits.
    #[test]
    fn blocked_attribute_sums_are_the_plain_sums() {
        const N: u32 = 9;
        let row = |y: u32| (y * 5) % N; // a permutation of the rows
        let id = |x: u32, y: u32| row(y) * N + x;
        let mut positions = vec![Vec3::ZERO; (N * N) as usize];
        let mut colors = positions.clone();
        let mut uvs = vec![glam::Vec2::ZERO; positions.len()];
        for y in 0..N {
            for x in 0..N {
                let (fx, fy) = (x as f32, y as f32);
                let v = id(x, y) as usize;
                positions[v] = Vec3::new(fx, fy, (fx * 0.7).sin() * (fy * 0.4).cos());
                colors[v] = Vec3::new(
                    (fx * fy * 0.1).fract(),
                    fy / N as f32,
                    (fx * 1.3).sin().abs(),
                );
                uvs[v] = glam::Vec2::new((fx * fx * 0.01).fract(), fy * 0.1);
            }
        }
        let mut triangles = Vec::new();
        for y in 0..N - 1 {
            for x in 0..N - 1 {
                triangles.push([id(x, y), id(x + 1, y), id(x + 1, y + 1)]);
                triangles.push([id(x, y), id(x + 1, y + 1), id(x, y + 1)]);
            }
        }
        let mut mesh = Mesh::from_triangles(positions, triangles);
        mesh.colors = Some(colors.clone());
        mesh.uvs = Some(uvs);
        mesh.texture_of = Some(vec![0; mesh.positions.len()]);
        mesh.textures = vec![std::sync::Arc::new(Vec::new())];
        let scales = texture_scales(&mesh);
        assert!(scales[0] > 0.0);
        let blocked = attribute_quadrics(&mesh, &colors, 0.3, &scales);
        let mut sums = vec![AttributeQuadric::default(); mesh.positions.len()];
        for t in &mesh.triangles {
            let channel = |v: u32| {
                let (c, uv) = (
                    colors[v as usize] * 0.3 / 32.0,
                    mesh.uvs.as_ref().unwrap()[v as usize] * scales[0],
                );
                [c.x, c.y, c.z, uv.x, uv.y].map(f64::from)
            };
            let q = AttributeQuadric::from_triangle(
                t.map(|v| mesh.positions[v as usize]),
                t.map(channel),
            );
            for &v in t {
                sums[v as usize] += q;
            }
        }
        assert!(mesh.positions.len() > QUADRIC_BLOCKS);
        for (v, (got, sum)) in blocked.iter().zip(&sums).enumerate() {
            let want = LocalAttributeQuadric::new(&sum.shifted(mesh.positions[v].as_dvec3()));
            assert_eq!(*got, want, "vertex {v}");
        }
    }
}

//! The offline builder (seed 001 §2.3): merge the cheapest candidate pair, again and again, until one
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

use super::{NONE, Node, PartInfo, VertexTree};
use crate::mesh::Mesh;
use crate::simplify::Metric;
use crate::simplify::bounds::{NormalCone, Sphere};
use crate::simplify::collapse::{Collapser, Neighbor, gather_neighbors};
use crate::simplify::features;
use crate::simplify::geometry::{LANES, nearest_squared};
use crate::simplify::metric::{Candidate, HybridWeights, PairEnd, Pricing};
use crate::simplify::pairs::close_pairs;
use glam::Vec3;
use rayon::prelude::*;
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::collections::VecDeque;
use std::sync::{Condvar, Mutex};
use std::time::Instant;

/// How merges are ordered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum Schedule {
    /// Passes of non-overlapping cheapest merges (meshoptimizer's scheme).
    #[default]
    Passes,
    /// Strictly the cheapest pair each time, from one priority queue (the paper's algorithm).
    Greedy,
}

/// Builder settings; `Default` gives the documented defaults.
#[derive(Clone, Debug, PartialEq)]
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
    /// Seed 001's θ in degrees: an edge whose dihedral angle is below it is sharp. Default 120°.
    pub sharp_angle_deg: f32,
    /// Seed 001's w1 and w2, used by `Metric::Hybrid`.
    pub hybrid: HybridWeights,
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
    #[error("invalid mesh: {0}")]
    Invalid(String),
}

// Flags in the high bits of a queued pair's `b`.
const NO_EDGE: u32 = 1 << 31;
const PENALIZED: u32 = 1 << 30;
const SLOT: u32 = PENALIZED - 1;

/// Greedy schedule: a merge that would flip a triangle costs this many times more, plus a quarter of its
/// squared length (a fold moves the surface by about that much), when it comes round again.
const FLIP_PENALTY: f64 = 10.0;

/// Passes schedule: each pass aims to merge this share of the live vertices. Smaller is closer to
/// greedy order and slower (more passes); a sixth matches the greedy schedule's quality on every model
/// of the benchmark within a few per cent.
const PASS_SHARE: f64 = 1.0 / 6.0;
/// A pass stops at this multiple of the cost of its goal-th candidate (meshoptimizer's `kPassErrorBound`):
/// locked vertices make it skip many candidates, so it must reach somewhat past the goal's cost.
const PASS_COST_BOUND: f32 = 1.5;

/// A pass looks only at its cheapest `PASS_WINDOW × goal` candidates: locking skips about one in
/// three or four of them, and the cost bound stops most passes well before the window ends.
const PASS_WINDOW: usize = 4;

/// The sequential merge loop prefetches the slots of the merge this many ahead, the triangles
/// around them half as many ahead, those triangles' corners a quarter as many ahead, and the lists
/// the merge unlinks from an eighth as many ahead (see [`Builder::prefetch_merge`]).
const PREFETCH_AHEAD: usize = 16;

/// Slots priced one after another by one thread, prefetching ahead within the run.
const PRICE_RUN: usize = 256;

/// Slots priced per parallel batch (see [`Builder::price_around`]).
const PRICE_CHUNK: usize = 1 << 14;

/// How many merges between progress callbacks.
const PROGRESS_EVERY: usize = 4096;

/// A priced pair. `cost` is `f32::to_bits` of a non-negative cost: for those, integer order is
/// numeric order, and integer compares keep sorting and the heap cheap.
#[derive(Clone, Copy, Debug)]
struct Entry {
    cost: u32,
    a: u32,
    b: u32,
}

/// A pair in the greedy schedule's queue, ordered as its entry: valid while neither slot changed
/// after merge number `created`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Queued {
    entry: Entry,
    created: u32,
}

impl PartialOrd for Queued {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Queued {
    fn cmp(&self, o: &Self) -> Ordering {
        self.entry.cmp(&o.entry)
    }
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

/// A triangle around a merged vertex, as [`finish_node`] reads it.
struct FanTriangle {
    corners: [Vec3; 3],
    /// The slots at the corners.
    slots: [u32; 3],
}

fn sphere_of(n: &Node) -> Sphere {
    Sphere {
        center: Vec3::from_slice(&n.sphere),
        radius: n.sphere[3],
    }
}

fn cone_of_node(n: &Node) -> NormalCone {
    NormalCone {
        axis: Vec3::from_slice(&n.cone),
        cos_angle: n.cone[3],
    }
}

/// A merge whose node [`finish_node`] has still to complete.
#[derive(Clone, Copy)]
struct Merged {
    /// The children's shares of the attribute blend.
    blend: [f32; 2],
    /// Both slots' error samples, from before the merge.
    pending: Pending,
    /// The surviving slot, and the slot merged into it.
    slot: u32,
    gone: u32,
    position: Vec3,
}

/// The triangles around a live slot, read once: corners and their slots, for the cone, every
/// distance in [`finish_node`] and the survivor's partners. Appended to `out`.
fn fan_of(collapser: &Collapser, slot: u32, out: &mut Vec<FanTriangle>) {
    let c = collapser;
    out.extend(c.faces_of(slot).map(|(_, f)| {
        let [a, b, d] = f.map(|v| c.positions[v as usize]);
        FanTriangle {
            corners: [a, b, d],
            slots: f,
        }
    }));
}

/// Merges handed to [`finish_node`] in one go, with the triangles and other partners around each
/// survivor as they were right after its merge.
#[derive(Default)]
struct FinishBatch {
    nodes: Vec<(Node, Merged)>,
    /// The fans of `nodes`, one after another; `fan_ends[i]` closes the i-th.
    fans: Vec<FanTriangle>,
    fan_ends: Vec<u32>,
    /// The survivors' partners by loose edges and proximity pairs, likewise.
    extras: Vec<Neighbor>,
    extra_ends: Vec<u32>,
}

/// Merges per [`FinishBatch`] handed to the finishing thread (fewer when their fans reach
/// [`FINISH_FANS`] triangles). Passes with fewer than four batches' worth finish on the merging
/// thread, [`FINISH_HERE`] merges at a time, while their fans are still in cache.
const FINISH_BATCH: usize = 256;
const FINISH_FANS: usize = 2048;
const FINISH_HERE: usize = 32;

/// What finishing a pass's nodes reads: none of it changes while the pass merges.
struct PassView<'a> {
    /// The nodes of earlier passes.
    done: &'a [Node],
    leaves: &'a [Vec3],
    /// Every slot's pricing data as the pass began (the survivors' new data go to [`Places::ends`]).
    ends: &'a [PairEnd],
    /// The ends of the pairs chosen in the pass.
    picked: &'a SlotSet,
    pricing: Pricing,
}

/// Where a batch's results go: its nodes, their kept samples, and whether all their pairs were
/// priced.
struct Places<'a> {
    nodes: &'a mut [Node],
    kept: &'a mut [Samples],
    /// The survivors' pricing data ([`PairEnd::merged`]).
    ends: &'a mut [PairEnd],
    /// Every pair of the survivor priced: none waits for the pass to end.
    priced: &'a mut [bool],
}

/// The part of a pass's outputs not yet handed to a batch.
impl<'a> Places<'a> {
    /// The next `n` places.
    fn take(&mut self, n: usize) -> Places<'a> {
        let (nodes, rest) = std::mem::take(&mut self.nodes).split_at_mut(n);
        self.nodes = rest;
        let (kept, rest) = std::mem::take(&mut self.kept).split_at_mut(n);
        self.kept = rest;
        let (ends, rest) = std::mem::take(&mut self.ends).split_at_mut(n);
        self.ends = rest;
        let (priced, rest) = std::mem::take(&mut self.priced).split_at_mut(n);
        self.priced = rest;
        Places {
            nodes,
            kept,
            ends,
            priced,
        }
    }
}

/// A batch and where its results go.
type Job<'a> = (FinishBatch, Places<'a>);

/// Batches waiting to be finished, shared by the merging thread and the finisher. The finisher
/// takes them oldest first; the merging thread takes the oldest back when more than
/// [`BACKLOG`] wait, and every one left once its merges are done, so that neither thread idles
/// while the other has work.
#[derive(Default)]
struct Backlog<'a> {
    /// The jobs, and whether more will come.
    queue: Mutex<(VecDeque<Job<'a>>, bool)>,
    ready: Condvar,
}

const BACKLOG: usize = 2;

impl<'a> Backlog<'a> {
    fn lock(&self) -> std::sync::MutexGuard<'_, (VecDeque<Job<'a>>, bool)> {
        // A panicking thread holds no job: what it left is consistent.
        self.queue
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Queues `job`; returns the oldest job when too many wait.
    fn push(&self, job: Job<'a>) -> Option<Job<'a>> {
        let mut q = self.lock();
        q.0.push_back(job);
        let back = (q.0.len() > BACKLOG).then(|| q.0.pop_front()).flatten();
        drop(q);
        self.ready.notify_one();
        back
    }

    /// The oldest job, if any.
    fn take(&self) -> Option<Job<'a>> {
        self.lock().0.pop_front()
    }

    /// The oldest job, waiting for one; `None` once closed and empty.
    fn wait(&self) -> Option<Job<'a>> {
        let mut q = self.lock();
        loop {
            if let Some(job) = q.0.pop_front() {
                return Some(job);
            }
            if q.1 {
                return None;
            }
            q = self
                .ready
                .wait(q)
                .unwrap_or_else(|poisoned| poisoned.into_inner());
        }
    }

    /// No more jobs will come.
    fn close(&self) {
        self.lock().1 = true;
        self.ready.notify_all();
    }
}

impl FinishBatch {
    fn push(&mut self, c: &Collapser, node: Node, merged: Merged) {
        fan_of(c, merged.slot, &mut self.fans);
        self.fan_ends.push(self.fans.len() as u32);
        self.extras.extend(c.extra_neighbors(merged.slot));
        self.extra_ends.push(self.extras.len() as u32);
        self.nodes.push((node, merged));
    }

    /// Completes the nodes into `out`, and prices each survivor's pairs with partners in no pair
    /// of the pass into `entries` (see `run_passes`, step 5), marking in `out.priced` the survivors
    /// with no others. Returns the emptied batch for reuse.
    fn finish(mut self, view: &PassView, out: Places, entries: &mut Vec<Entry>) -> FinishBatch {
        let mut around = Vec::new();
        let (mut fan_start, mut extra_start) = (0, 0);
        for (i, &(mut node, merged)) in self.nodes.iter().enumerate() {
            // Children, samples and partners are scattered: start loading the next ones'.
            if let Some((next, m)) = self.nodes.get(i + PREFETCH_AHEAD) {
                for c in next.children {
                    crate::prefetch(&view.done[c as usize]);
                }
                for q in m.pending.into_iter().filter(|&q| q != NONE) {
                    crate::prefetch(&view.leaves[q as usize]);
                }
                crate::prefetch(&view.ends[m.slot as usize]);
                crate::prefetch(&view.ends[m.gone as usize]);
            }
            if let Some(&end) = self.fan_ends.get(i + PREFETCH_AHEAD / 2) {
                let start = self.fan_ends[i + PREFETCH_AHEAD / 2 - 1];
                for t in &self.fans[start as usize..end as usize] {
                    for v in t.slots {
                        crate::prefetch(&view.ends[v as usize]);
                    }
                }
            }
            let (fan_end, extra_end) = (self.fan_ends[i], self.extra_ends[i]);
            let fan = &self.fans[fan_start as usize..fan_end as usize];
            out.kept[i] = finish_node(&mut node, view.done, &merged, fan, view.leaves);
            out.nodes[i] = node;
            let end = PairEnd::merged(
                &view.ends[merged.slot as usize],
                &view.ends[merged.gone as usize],
                merged.position,
            );
            out.ends[i] = end;

            gather_neighbors(
                merged.slot,
                fan.iter().map(|t| t.slots),
                self.extras[extra_start as usize..extra_end as usize]
                    .iter()
                    .copied(),
                &mut around,
            );
            let mut all = true;
            for n in &around {
                if view.picked.contains(n.slot) {
                    all = false;
                    continue;
                }
                let cand = view
                    .pricing
                    .price(&end, &view.ends[n.slot as usize], n.edge);
                entries.push(Entry {
                    cost: key(cand.cost),
                    a: merged.slot,
                    b: n.slot | if n.edge { 0 } else { NO_EDGE },
                });
            }
            out.priced[i] = all;
            (fan_start, extra_start) = (fan_end, extra_end);
        }
        self.nodes.clear();
        self.fans.clear();
        self.fan_ends.clear();
        self.extras.clear();
        self.extra_ends.clear();
        self
    }
}

/// Colour, normal, bounding sphere, normal cone and error of a new node, from its (finished)
/// children and `fan`, the triangles around its slot right after the merge ([`fan_of`]).
fn finish_node(
    node: &mut Node,
    done: &[Node],
    merged: &Merged,
    fan: &[FanTriangle],
    leaves: &[Vec3],
) -> Samples {
    let Merged {
        blend, ref pending, ..
    } = *merged;
    let (ns, nt) = (
        &done[node.children[0] as usize],
        &done[node.children[1] as usize],
    );
    // Never below a child's: the runtime's error test relies on errors growing towards the root.
    node.error = node.error.max(ns.error).max(nt.error);
    let mix =
        |x: [f32; 3], y: [f32; 3]| Vec3::from_array(x) * blend[0] + Vec3::from_array(y) * blend[1];
    node.color = mix(ns.color, nt.color).to_array();
    node.normal = mix(ns.normal, nt.normal).normalize_or_zero().to_array();
    let sphere = sphere_of(ns)
        .union(sphere_of(nt))
        .union_point(node.position());
    node.sphere = [
        sphere.center.x,
        sphere.center.y,
        sphere.center.z,
        sphere.radius,
    ];
    let mut cone = cone_of_node(ns).union(cone_of_node(nt));
    for t in fan {
        let [a, b, d] = t.corners;
        cone = cone.union_normal((b - a).cross(d - a).normalize_or_zero());
    }
    node.cone = [cone.axis.x, cone.axis.y, cone.axis.z, cone.cos_angle];
    // How far the merged surface strays from the input: Hoppe 1997's residuals, measured from a few
    // input vertices per node, the farthest so far, to the triangles now around the merged vertex
    // (the children's samples compete for the places). The RMS plane distance alone underestimates
    // the Hausdorff distance 2–5× (BENCHMARKS.md).
    // Lanes: the pending samples, then the two children's vertices (the rest repeat the node's).
    let here = node.position();
    const _: () = assert!(2 * SAMPLES + 2 <= LANES);
    let points: [Vec3; LANES] = std::array::from_fn(|i| match i.checked_sub(pending.len()) {
        None if pending[i] != NONE => leaves[pending[i] as usize],
        Some(0) => ns.position(),
        Some(1) => nt.position(),
        _ => here,
    });
    let distance: [f32; LANES] = if fan.is_empty() {
        points.map(|p| p.distance(here))
    } else {
        let mut best = [f32::INFINITY; LANES];
        nearest_squared(
            &points.map(|p| p.x),
            &points.map(|p| p.y),
            &points.map(|p| p.z),
            fan.iter().map(|t| t.corners),
            &mut best,
        );
        best.map(f32::sqrt)
    };
    let mut scored = [(f32::NEG_INFINITY, NONE); 2 * SAMPLES];
    for (i, (score, &q)) in scored.iter_mut().zip(pending).enumerate() {
        if q != NONE {
            *score = (distance[i], q);
        }
    }
    scored.sort_unstable_by(|x, y| y.0.total_cmp(&x.0));
    node.error = node.error.max(scored[0].0);
    // Each child's own vertex, on top of the child's error: its surface was that close to the
    // input, and its vertex's distance to the new fan is where a merge usually strays most. Summed
    // along a chain this grows like a geometric series, a small factor over the true deviation.
    for (k, child) in [ns, nt].into_iter().enumerate() {
        node.error = node.error.max(child.error + distance[pending.len() + k]);
    }
    let mut kept = [NONE; SAMPLES];
    for (k, &(_, q)) in kept.iter_mut().zip(&scored) {
        // NONE-padded entries sort last and stay NONE.
        *k = q;
    }
    kept
}

/// Input vertices each live slot keeps for measuring its deviation: the ones farthest from the surface
/// so far. Four: six gave the same Hausdorff-to-error ratios on cow, fandisk, cessna and bunny and
/// cost the dragon's build 0.2 s more; none at all (the children's vertices only) let the ratio reach
/// 2.7–5.5 on cow and cessna.
const SAMPLES: usize = 4;
type Samples = [u32; SAMPLES];
/// The samples of both merging slots, waiting for [`finish_node`] to keep the worst.
type Pending = [u32; 2 * SAMPLES];

/// The state of a build: the working mesh, per-slot merge data, and the tree so far.
struct Builder<'m> {
    mesh: &'m Mesh,
    collapser: Collapser,
    /// Each slot's quadric (about its position) and Table 1 weight, as pricing reads them.
    ends: Vec<PairEnd>,
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
    stats: BuildStats,
    removed: Vec<(u32, crate::simplify::collapse::Vanish)>,
    /// Error samples of each live slot (input vertex ids, `NONE`-padded).
    samples: Vec<Samples>,
}

impl Builder<'_> {
    fn pricing(&self) -> Pricing {
        Pricing {
            metric: self.metric,
            hybrid: self.hybrid,
            mean_edge_length: self.mean_edge_length,
        }
    }

    fn price(&self, a: u32, b: u32, edge: bool) -> Candidate {
        self.pricing()
            .price(&self.ends[a as usize], &self.ends[b as usize], edge)
    }

    fn merges(&self) -> u32 {
        self.nodes.len() as u32 - self.mesh.positions.len() as u32
    }

    /// `vunify(a, b)` at the priced position, recorded as a new node. Returns the surviving slot.
    fn merge(&mut self, a: u32, b: u32, cand: &Candidate) -> u32 {
        let pending = self.pending(a, b);
        let mut nodes = std::mem::take(&mut self.nodes);
        let u = nodes.len() as u32;
        let (mut node, merged) = self.merge_topology(a, b, cand, u, pending);
        let survivor = merged.slot;
        self.ends[survivor as usize] = PairEnd::merged(
            &self.ends[survivor as usize],
            &self.ends[merged.gone as usize],
            merged.position,
        );
        let mut fan = Vec::new();
        fan_of(&self.collapser, survivor, &mut fan);
        self.samples[survivor as usize] =
            finish_node(&mut node, &nodes, &merged, &fan, &self.mesh.positions);
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
        };
        (node, merged)
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

    /// `pairs` (`(a, b)` with `a < b`, sorted by `a`), priced in parallel.
    fn price_pairs(&mut self, pairs: &[(u32, u32)], edge: bool) -> Vec<Entry> {
        self.stats.pricings += pairs.len() as u64;
        let this = &*self;
        pairs
            .par_chunks(PRICE_RUN)
            .flat_map_iter(|run| {
                run.iter().enumerate().map(move |(i, &(a, b))| {
                    // Sorted by `a`, so the `b` are the scattered ends: load a few ahead.
                    if let Some(&(_, ahead)) = run.get(i + PREFETCH_AHEAD) {
                        crate::prefetch(&this.ends[ahead as usize]);
                    }
                    Entry {
                        cost: key(this.price(a, b, edge).cost),
                        a,
                        b: b | if edge { 0 } else { NO_EDGE },
                    }
                })
            })
            .collect()
    }

    /// The pairs between each of `slots` and its neighbours for which `keep(slot, neighbour)` holds,
    /// priced in parallel. In chunks, so that rayon's per-thread vectors and their concatenation never
    /// hold the whole list twice (the first call prices every pair of the mesh).
    fn price_around(
        &mut self,
        slots: &[u32],
        keep: impl Fn(u32, u32) -> bool + Sync,
    ) -> Vec<Entry> {
        let mut out = Vec::new();
        for chunk in slots.chunks(PRICE_CHUNK) {
            let part = self.price_chunk(chunk, &keep);
            out.extend_from_slice(&part);
        }
        self.stats.pricings += out.len() as u64;
        out
    }

    fn price_chunk(&self, slots: &[u32], keep: &(impl Fn(u32, u32) -> bool + Sync)) -> Vec<Entry> {
        slots
            .par_chunks(PRICE_RUN)
            .fold_with(
                (Vec::new(), Vec::new(), Vec::new()),
                |(mut out, mut here, mut next): (Vec<Entry>, Vec<Neighbor>, Vec<Neighbor>), run| {
                    if let Some(&first) = run.first() {
                        self.collapser.neighbors(first, &mut next);
                    }
                    for (i, &a) in run.iter().enumerate() {
                        // Scattered slots: load the next ones' triangles while this one is priced.
                        for stage in 0..3 {
                            if let Some(&ahead) = run.get(i + (PREFETCH_AHEAD >> stage)) {
                                self.collapser.prefetch(ahead, stage as u32);
                            }
                        }
                        // The neighbours of the next slot are known a slot ahead: load what pricing
                        // them reads (quadric, weight, position) while this slot's pairs are priced.
                        std::mem::swap(&mut here, &mut next);
                        if let Some(&ahead) = run.get(i + 1) {
                            self.collapser.neighbors(ahead, &mut next);
                            for nb in &next {
                                crate::prefetch(&self.ends[nb.slot as usize]);
                            }
                        }
                        for nb in here.iter().filter(|nb| keep(a, nb.slot)) {
                            let cost = key(self.price(a, nb.slot, nb.edge).cost);
                            out.push(Entry {
                                cost,
                                a,
                                b: nb.slot | if nb.edge { 0 } else { NO_EDGE },
                            });
                        }
                    }
                    (out, here, next)
                },
            )
            .map(|(out, _, _)| out)
            .reduce(Vec::new, |mut x, mut y| {
                x.append(&mut y);
                x
            })
    }

    fn run_passes(
        &mut self,
        mut cands: Vec<Entry>,
        radius: &mut f32,
        per_vertex: usize,
        progress: &mut dyn FnMut(usize, usize),
    ) {
        let total = self.mesh.positions.len() - 1;
        let n = self.mesh.positions.len();
        // Of the pass under way: `picked`, the ends of its chosen pairs (so no other pair may use
        // them); `changed`, the slots that merged (or died), whose pairs' prices are stale.
        let mut picked = SlotSet::new(n);
        let mut changed = SlotSet::new(n);
        let mut last_report = 0;
        // Candidates persist across passes; only the pairs around a pass's merges are re-priced.
        let mut chosen: Vec<usize> = Vec::new();
        let mut survivors: Vec<u32> = Vec::new();
        let mut new_ends: Vec<PairEnd> = Vec::new();
        while self.collapser.live_count() > 1 {
            if cands.is_empty() {
                let pairs = self.widen(radius, per_vertex);
                cands.extend(pairs.into_iter().map(|(a, b)| Entry {
                    cost: key(self.price(a, b, false).cost),
                    a,
                    b: b | NO_EDGE,
                }));
                continue;
            }
            self.stats.rounds += 1;
            picked.clear();
            changed.clear();
            let clock = Instant::now();
            let goal = ((self.collapser.live_count() as f64 * PASS_SHARE).ceil() as usize).max(1);
            // Only the cheapest few goals' worth can be reached in a pass: partition, then sort just
            // those; and of those the first half first, as most passes stop in it.
            let window = (goal * PASS_WINDOW).min(cands.len());
            let head = (goal * PASS_WINDOW / 2).min(window);
            // A total order: where each entry stands in the list does not matter.
            let order = |e: &Entry| (((e.cost as u64) << 32) | e.a as u64, e.b);
            if window < cands.len() {
                cands.select_nth_unstable_by_key(window, order);
            }
            if head < window {
                cands[..window].select_nth_unstable_by_key(head, order);
            }
            cands[..head].par_sort_unstable_by_key(order);
            // Within the sorted head when it matters (`goal < window`).
            let bound = cands
                .get(goal)
                .map_or(f32::INFINITY, |e| f32::from_bits(e.cost) * PASS_COST_BOUND);

            // 1. Choose vertex-disjoint pairs, cheapest first.
            chosen.clear();
            for index in 0..window {
                if index == head {
                    cands[head..window].par_sort_unstable_by_key(order);
                }
                let e = &cands[index];
                if chosen.len() >= goal
                    || (chosen.len() > goal / 6 && f32::from_bits(e.cost) > bound)
                {
                    break;
                }
                let (a, b) = (e.a, e.b & SLOT);
                if picked.contains(a) || picked.contains(b) {
                    continue;
                }
                picked.insert(a);
                picked.insert(b);
                chosen.push(index);
            }
            // 2. Price them in parallel (their quadrics and positions do not change within the pass).
            let this = &*self;
            let priced: Vec<Candidate> = chosen
                .par_chunks(PRICE_RUN)
                .flat_map_iter(|run| {
                    run.iter().enumerate().map(|(i, &index)| {
                        // Scattered pairs: load the ones a few ahead while this one is priced.
                        if let Some(&ahead) = run.get(i + PREFETCH_AHEAD / 2) {
                            let e = cands[ahead];
                            for s in [e.a as usize, (e.b & SLOT) as usize] {
                                crate::prefetch(&this.ends[s]);
                            }
                        }
                        let e = cands[index];
                        this.price(e.a, e.b & SLOT, e.b & NO_EDGE == 0)
                    })
                })
                .collect();
            self.stats.phases.pricing += clock.elapsed().as_secs_f64();
            let clock = Instant::now();
            // 3. Merge, in cost order. The flip test must see the positions so far (earlier merges of
            // this pass may have moved a neighbour), so it runs here, as in meshoptimizer. A merge that
            // would flip a triangle goes back to the list at a penalty, as in the greedy schedule; left
            // in place at its low cost, it would crowd the front of every later pass.
            //
            // 4, alongside. The new nodes' colour, normal, sphere, cone and error, on a second thread
            // as the merges hand them over: each depends only on finished nodes (its children, from
            // earlier passes) and on the triangles around its slot right after its merge, which the
            // merge copies out while they are in cache. The merges are sequential and memory-bound, so
            // this work would otherwise wait for them; when the finisher falls behind, the merging
            // thread finishes a batch itself.
            //
            // 5, alongside. A survivor's pairs with partners in no pair of the pass: such a pair's
            // price can no longer change in the pass (the survivor has merged, the partner will not,
            // and whether a triangle joins them changes only when one of them merges), so it is
            // priced with the node. The pairs with partners in the pass wait for it to end.
            let mut nodes = std::mem::take(&mut self.nodes);
            let first_new = nodes.len();
            // Room for every chosen merge; what flip tests defer is cut off below.
            nodes.resize(first_new + chosen.len(), bytemuck::Zeroable::zeroed());
            let mut kept = vec![[NONE; SAMPLES]; chosen.len()];
            let mut priced_early = vec![false; chosen.len()];
            let (done, new) = nodes.split_at_mut(first_new);
            // Read-only while the pass merges; each merge's new data waits in `new_ends`.
            new_ends.resize(chosen.len(), PairEnd::default());
            let ends = std::mem::take(&mut self.ends);
            let view = PassView {
                done,
                leaves: &self.mesh.positions,
                ends: &ends,
                picked: &picked,
                pricing: self.pricing(),
            };
            let view = &view;
            survivors.clear();
            let backlog = &Backlog::default();
            let mut early = std::thread::scope(|scope| {
                let threaded = chosen.len() >= 4 * FINISH_BATCH;
                let batch_len = if threaded { FINISH_BATCH } else { FINISH_HERE };
                let finisher = threaded.then(|| {
                    scope.spawn(move || {
                        let mut entries = Vec::new();
                        while let Some((batch, places)) = backlog.wait() {
                            batch.finish(view, places, &mut entries);
                        }
                        entries
                    })
                });
                // The places of the pass's outputs not handed out yet.
                let mut out = Places {
                    nodes: new,
                    kept: &mut kept,
                    ends: &mut new_ends,
                    priced: &mut priced_early,
                };
                let mut entries = Vec::new();
                let mut batch = FinishBatch::default();
                for (i, (&index, &cand)) in chosen.iter().zip(&priced).enumerate() {
                    // The merges are scattered over the mesh: start loading the next ones' data.
                    for stage in 0..4 {
                        if let Some(&next) = chosen.get(i + (PREFETCH_AHEAD >> stage)) {
                            let e = cands[next];
                            self.prefetch_merge(e.a, e.b & SLOT, stage);
                        }
                    }
                    let e = &mut cands[index];
                    let (a, b) = (e.a, e.b & SLOT);
                    if e.b & PENALIZED == 0 && self.collapser.flips(a, b, cand.position) {
                        let c = &self.collapser;
                        let gap2 = c.positions[a as usize].distance_squared(c.positions[b as usize])
                            as f64;
                        e.cost = key(FLIP_PENALTY * cand.cost + 0.25 * gap2);
                        e.b |= PENALIZED;
                        self.stats.flip_deferrals += 1;
                        continue;
                    }
                    let pending = self.pending(a, b);
                    let u = (first_new + survivors.len()) as u32;
                    let (node, merged) = self.merge_topology(a, b, &cand, u, pending);
                    changed.insert(a);
                    changed.insert(b);
                    survivors.push(merged.slot);
                    batch.push(&self.collapser, node, merged);
                    if batch.nodes.len() == batch_len || batch.fans.len() >= FINISH_FANS {
                        let places = out.take(batch.nodes.len());
                        let job = (std::mem::take(&mut batch), places);
                        let back = match &finisher {
                            Some(_) => backlog.push(job),
                            None => Some(job),
                        };
                        if let Some((full, places)) = back {
                            batch = full.finish(view, places, &mut entries);
                        }
                    }
                }
                let places = out.take(batch.nodes.len());
                batch.finish(view, places, &mut entries);
                // What the finisher has not started yet, finished here alongside it.
                backlog.close();
                while let Some((batch, places)) = backlog.take() {
                    batch.finish(view, places, &mut entries);
                }
                if let Some(finisher) = finisher {
                    entries.extend(
                        finisher
                            .join()
                            .unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
                    );
                }
                entries
            });
            self.ends = ends;
            nodes.truncate(first_new + survivors.len());
            self.nodes = nodes;
            for (k, (&slot, kept)) in survivors.iter().zip(kept).enumerate() {
                let u = (first_new + k) as u32;
                for c in self.nodes[u as usize].children {
                    self.nodes[c as usize].parent = u;
                }
                self.samples[slot as usize] = kept;
                self.ends[slot as usize] = new_ends[k];
            }

            self.stats.phases.merging += clock.elapsed().as_secs_f64();
            let clock = Instant::now();
            // 5. Drop the stale pairs, price the other survivors' pairs anew (each pair once).
            par_retain(&mut cands, |e| {
                !changed.contains(e.a) && !changed.contains(e.b & SLOT)
            });
            self.stats.pricings += early.len() as u64;
            cands.append(&mut early);
            let mut k = 0;
            survivors.retain(|_| {
                k += 1;
                !priced_early[k - 1]
            });
            // The pairs with partners in a pair of the pass; of two survivors, the smaller slot's.
            let fresh = self.price_around(&survivors, |s, other| {
                picked.contains(other) && !(changed.contains(other) && other < s)
            });
            cands.extend(fresh);
            self.stats.phases.repricing += clock.elapsed().as_secs_f64();
            let done = self.merges() as usize;
            if done - last_report >= PROGRESS_EVERY {
                progress(done, total);
                last_report = done;
            }
        }
    }

    fn run_greedy(
        &mut self,
        initial: Vec<Entry>,
        radius: &mut f32,
        per_vertex: usize,
        progress: &mut dyn FnMut(usize, usize),
    ) {
        let total = self.mesh.positions.len() - 1;
        let clock = Instant::now();
        let mut heap: BinaryHeap<Queued> = initial
            .into_iter()
            .map(|entry| Queued { entry, created: 0 })
            .collect();
        self.stats.phases.pricing += clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        let mut changed_at = vec![0u32; self.mesh.positions.len()];
        let mut neighbors: Vec<Neighbor> = Vec::new();
        loop {
            while let Some(Queued { entry: e, created }) = heap.pop() {
                self.stats.rounds += 1;
                let (a, b) = (e.a, e.b & SLOT);
                let c = &self.collapser;
                if !c.is_live(a)
                    || !c.is_live(b)
                    || changed_at[a as usize] > created
                    || changed_at[b as usize] > created
                {
                    continue; // stale
                }
                let cand = self.price(a, b, e.b & NO_EDGE == 0);
                if e.b & PENALIZED == 0 && c.flips(a, b, cand.position) {
                    let gap2 =
                        c.positions[a as usize].distance_squared(c.positions[b as usize]) as f64;
                    let cost = key(FLIP_PENALTY * cand.cost + 0.25 * gap2);
                    heap.push(Queued {
                        entry: Entry {
                            cost,
                            a,
                            b: e.b | PENALIZED,
                        },
                        created: self.merges(),
                    });
                    self.stats.flip_deferrals += 1;
                    continue;
                }
                let s = self.merge(a, b, &cand);
                let now = self.merges();
                changed_at[s as usize] = now;
                self.collapser.neighbors(s, &mut neighbors);
                self.stats.pricings += neighbors.len() as u64;
                for nb in &neighbors {
                    let cost = key(self.price(s, nb.slot, nb.edge).cost);
                    heap.push(Queued {
                        entry: Entry {
                            cost,
                            a: s,
                            b: nb.slot | if nb.edge { 0 } else { NO_EDGE },
                        },
                        created: now,
                    });
                }
                if (now as usize).is_multiple_of(PROGRESS_EVERY) {
                    progress(now as usize, total);
                }
            }
            if self.collapser.live_count() <= 1 {
                self.stats.phases.merging = clock.elapsed().as_secs_f64();
                break;
            }
            let now = self.merges();
            for (a, b) in self.widen(radius, per_vertex) {
                let cost = key(self.price(a, b, false).cost);
                heap.push(Queued {
                    entry: Entry {
                        cost,
                        a,
                        b: b | NO_EDGE,
                    },
                    created: now,
                });
            }
        }
    }
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
    let clock = Instant::now();
    let feats = features::classify(&mesh.positions, &mesh.triangles, options.sharp_angle_deg);
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
    let close = if options.pair_distance > 0.0 && options.max_pairs_per_vertex > 0 {
        let adjacency = Adjacency::new(n, &feats.edges);
        let points: Vec<(u32, Vec3)> = mesh
            .positions
            .iter()
            .enumerate()
            .map(|(i, p)| (i as u32, *p))
            .collect();
        close_pairs(
            &points,
            options.pair_distance * diagonal,
            options.max_pairs_per_vertex,
            |i, j| !adjacency.within_two_rings(i, j),
        )
    } else {
        Vec::new()
    };
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

    // Leaves: sphere over the 1-ring (so it covers the triangles around the leaf), cone of those faces,
    // a third of their area as the leaf's mass. Each face's normal is computed once, not once a corner.
    let faces: Vec<(Vec3, f32)> = mesh
        .triangles
        .par_iter()
        .map(|t| {
            let [a, b, d] = t.map(|w| mesh.positions[w as usize]);
            let cross = (b - a).cross(d - a);
            let len = cross.length();
            (if len > 0.0 { cross / len } else { Vec3::ZERO }, len / 6.0)
        })
        .collect();
    let mut nodes: Vec<Node> = Vec::with_capacity(2 * n - 1);
    let mut mass: Vec<f32> = Vec::with_capacity(n);
    (0..n as u32)
        .into_par_iter()
        .map(|v| {
            let p = mesh.positions[v as usize];
            let (mut radius, mut area, mut nsum) = (0.0f32, 0.0f32, Vec3::ZERO);
            for (f, c) in collapser.faces_of(v) {
                let (unit, third) = faces[f as usize];
                area += third;
                nsum += unit * third;
                for w in c {
                    radius = radius.max(p.distance(mesh.positions[w as usize]));
                }
            }
            let cone = cone_of(
                collapser
                    .faces_of(v)
                    .map(|(f, _)| faces[f as usize].0)
                    .filter(|n| *n != Vec3::ZERO),
            );
            let normal = mesh
                .normals
                .as_ref()
                .map_or(nsum.normalize_or_zero(), |ns| {
                    ns[v as usize].normalize_or_zero()
                });
            let color = mesh.colors.as_ref().map_or(Vec3::ONE, |cs| cs[v as usize]);
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
    drop(faces);

    for &(a, b) in &close {
        collapser.add_proximity_pair(a, b);
    }

    let ends: Vec<PairEnd> = quadrics
        .par_iter()
        .zip(&vertex_weight)
        .zip(&mesh.positions)
        .map(|((q, &w), &p)| PairEnd::new(q, p, w))
        .collect();
    drop((quadrics, vertex_weight));

    // 3-5. Merge until one vertex is left.
    let mut builder = Builder {
        mesh,
        collapser,
        ends,
        mass,
        node_of: (0..n as u32).collect(),
        nodes,
        vanished: Vec::with_capacity(mesh.triangles.len()),
        vanish_offsets: {
            let mut v = Vec::with_capacity(n);
            v.push(0);
            v
        },
        metric: options.metric,
        hybrid: options.hybrid,
        mean_edge_length,
        stats,
        removed: Vec::new(),
        samples: (0..n as u32)
            .map(|v| {
                let mut s = [NONE; SAMPLES];
                s[0] = v;
                s
            })
            .collect(),
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

    let Builder {
        mut stats,
        nodes,
        vanished,
        vanish_offsets,
        ..
    } = builder;
    let triangles = vanished
        .par_iter()
        .map(|&f| mesh.triangles[f as usize])
        .collect();
    drop(vanished);
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

/// A set of slots, one bit each: the pass's marks stay in cache where a word per slot would not.
struct SlotSet(Vec<u64>);

impl SlotSet {
    fn new(n: usize) -> SlotSet {
        SlotSet(vec![0; n.div_ceil(64)])
    }
    fn insert(&mut self, s: u32) {
        self.0[s as usize / 64] |= 1 << (s % 64);
    }
    fn contains(&self, s: u32) -> bool {
        self.0[s as usize / 64] & (1 << (s % 64)) != 0
    }
    fn clear(&mut self) {
        self.0.fill(0);
    }
}

/// `Vec::retain` on every thread: each chunk keeps its entries in place, then the chunks close up.
/// The order is a sequential `retain`'s.
fn par_retain<T: Copy + Send + Sync>(v: &mut Vec<T>, keep: impl Fn(&T) -> bool + Sync) {
    let chunk = v
        .len()
        .div_ceil(rayon::current_num_threads())
        .max(PRICE_CHUNK);
    let kept: Vec<usize> = v
        .par_chunks_mut(chunk)
        .map(|part| {
            let mut n = 0;
            for i in 0..part.len() {
                if keep(&part[i]) {
                    part[n] = part[i];
                    n += 1;
                }
            }
            n
        })
        .collect();
    let mut end = 0;
    for (k, &n) in kept.iter().enumerate() {
        v.copy_within(k * chunk..k * chunk + n, end);
        end += n;
    }
    v.truncate(end);
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

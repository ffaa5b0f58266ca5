//! The partitioned build: the input split into cells, each cell built on its own (in parallel)
//! with its border locked, and the cells' remains joined level by level up a kd-tree until one
//! root is left. The result is an ordinary vertex tree.
//!
//! This is the level-by-level scheme of Cignoni et al., *Batched multi triangulation* (IEEE
//! Visualization 2005) and Ponchio's Nexus, carried to a binary vertex tree:
//!
//! 1. The triangles are split at the median of their centroids along the longest axis, again and
//!    again, until every cell holds at most `cell_triangles`: a kd-tree whose leaves are the cells.
//! 2. Each leaf cell is built like a whole mesh, except that a vertex with a triangle in another
//!    cell is *locked* (no merge moves it), and the cell stops when half of its free vertices are
//!    left. What is left (its live vertices, with their quadrics, error samples and current nodes,
//!    and its live triangles) is the cell's *remains*.
//! 3. A kd-tree node joins its two children's remains (they share only locked border vertices),
//!    unlocks the border between them (the vertices all of whose triangles are now inside), and
//!    builds on, again to half. The root builds to one vertex, joining separate parts as the whole
//!    build does.
//!
//! The two halves of every kd-tree node build at once (`rayon::join`), so the build uses every
//! core. Each vertex's quadric, Table 1 weight and leaf node are the whole mesh's (computed before
//! the split), so a border vertex prices the same as in a whole build once it is unlocked.
//!
//! The nodes are numbered at the end: level by level (a kd-tree node's after all of its
//! descendants'), and within a level the cells' nodes interleaved by error, each cell's in the order
//! it made them. Every triangle's merges lie in the cells on the path from its leaf cell to the
//! root, whose order this keeps, so each triangle vanishes at the same node as in the cells' own
//! order; and [`crate::vtree::extract::cut_at_triangles`] (build order) takes the levels' cheapest
//! merges first, as a whole build's passes do.

mod budget;
mod kd;
mod number;
mod spill;

pub use budget::{
    BudgetTooSmall, CELLS_FLOOR_BYTES_PER_TRIANGLE, DEFAULT_CELL_TRIANGLES,
    WHOLE_BUILD_BYTES_PER_TRIANGLE, cells_build_bytes, cells_within, default_cells,
    whole_build_bytes,
};

use super::node::{SAMPLES, Samples};
use super::passes::SlotSet;
use super::{BuildError, BuildOptions, BuildStats, Builder, NONE, VertexTree, leaves};
use crate::mesh::Mesh;
use crate::simplify::collapse::Collapser;
use crate::simplify::features;
use crate::simplify::metric::PairEnd;
use crate::vtree::Node;
use glam::Vec3;
use kd::{Split, cell_ranges};
use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;
use spill::{Spill, Spilled};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// A node as the cells name it before the tree is numbered: a leaf (an input vertex), or the
/// `k`-th node made in cell `cell`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Ref(pub(super) u64);

impl Ref {
    const LEAF: u64 = u32::MAX as u64;

    fn leaf(v: u32) -> Ref {
        Ref((Ref::LEAF << 32) | u64::from(v))
    }

    fn made(cell: u32, k: u32) -> Ref {
        Ref((u64::from(cell) << 32) | u64::from(k))
    }

    pub(super) fn as_leaf(self) -> Option<u32> {
        (self.0 >> 32 == Ref::LEAF).then_some(self.0 as u32)
    }

    pub(super) fn cell_and_index(self) -> (u32, u32) {
        ((self.0 >> 32) as u32, self.0 as u32)
    }
}

/// A live vertex between levels: what the builder knows of it.
#[derive(Clone, Copy)]
pub(super) struct Live {
    pub(super) node: Ref,
    /// Its node's data (its position among them), as a parent's node reads it.
    pub(super) current: Node,
    pub(super) end: PairEnd,
    pub(super) mass: f32,
    pub(super) samples: Samples,
}

/// What a cell hands its parent.
#[derive(Default)]
pub(super) struct Remains {
    pub(super) slots: Vec<Live>,
    /// Live triangles: the input triangle, and its corners as indices into `slots`.
    pub(super) triangles: Vec<(u32, [u32; 3])>,
    /// Partners by loose edges (left by vanished triangles) and close pairs, as indices into `slots`.
    pub(super) pairs: Vec<(u32, u32)>,
}

/// The nodes one cell made, in the order it made them.
pub(super) struct Made {
    pub(super) cell: u32,
    pub(super) height: u32,
    pub(super) nodes: Vec<Node>,
    pub(super) children: Vec<[Ref; 2]>,
    /// Input triangles vanishing at each node: `vanished[offsets[k]..offsets[k + 1]]`.
    pub(super) vanished: Vec<u32>,
    pub(super) offsets: Vec<u32>,
}

/// What every level reads: the whole mesh's per-vertex data, computed once.
pub(super) struct Shared<'m> {
    mesh: &'m Mesh,
    options: &'m BuildOptions,
    split: Split,
    /// Each vertex's lowest and highest cell (of the triangles around it).
    cell_range: Vec<(u32, u32)>,
    leaf_nodes: Vec<Node>,
    mass: Vec<f32>,
    ends: Vec<PairEnd>,
    /// Close non-edge pairs, by the kd-tree node that holds both ends' triangles.
    close: Vec<Vec<(u32, u32)>>,
    params: Params,
    merges: AtomicUsize,
    /// What the preparation did (features, pairs, leaves), for the summary.
    prefix: BuildStats,
}

/// The settings a level builds with, the same for every level of a build.
#[derive(Clone)]
pub(super) struct Params {
    pub(super) options: BuildOptions,
    pub(super) mean_edge_length: f32,
    /// The radius the root widens from to join separate parts.
    pub(super) radius: f32,
}

/// One level's work (a kd-tree node's): everything it needs, nothing shared, so that a cell can
/// be built in another process from this alone (see [`super::cells`]).
pub(super) struct LevelInput {
    pub(super) at: u32,
    pub(super) height: u32,
    /// Stop when this many slots are live.
    pub(super) target: u32,
    pub(super) root: bool,
    /// Its slots, triangles and non-edge partners (close pairs and loose edges, between free
    /// slots; edges are dropped from them when the level runs).
    pub(super) remains: Remains,
    pub(super) locked: Vec<bool>,
}

/// What a level hands on: its remains, the nodes it made, what its build did.
pub(super) struct LevelOutput {
    pub(super) remains: Remains,
    pub(super) made: Made,
    pub(super) stats: BuildStats,
}

/// Where the leaf cells' outputs come from: built here, or read from another process's file.
pub(super) type LeafCells<'a> = dyn Fn(&Shared, u32) -> Result<LevelOutput, BuildError> + Sync + 'a;

/// [`super::build`] of a mesh near unit size in cells of at most `cell_triangles` triangles.
pub(super) fn build(
    mesh: &Mesh,
    options: &BuildOptions,
    cell_triangles: usize,
    spill: &Path,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(VertexTree, BuildStats), BuildError> {
    let start = Instant::now();
    let shared = Shared::new(mesh, options, cell_triangles)?;
    shared.finish(
        &|shared, at| Ok(shared.build_cell(at)),
        spill,
        start,
        progress,
    )
}

impl<'m> Shared<'m> {
    /// The whole mesh's per-vertex data and the kd-tree of its cells.
    pub(super) fn new(
        mesh: &'m Mesh,
        options: &'m BuildOptions,
        cell_triangles: usize,
    ) -> Result<Shared<'m>, BuildError> {
        if mesh.triangles.is_empty() {
            return Err(BuildError::Empty);
        }
        let n = mesh.positions.len();
        if n >= super::queue::SLOT as usize {
            return Err(BuildError::TooLarge(n));
        }
        if mesh.triangles.len() >= features::MAX_TRIANGLES {
            return Err(BuildError::TooManyTriangles(mesh.triangles.len()));
        }
        let diagonal = mesh.diagonal().max(f32::MIN_POSITIVE);
        let mut prefix = BuildStats::default();
        let clock = Instant::now();
        let features::Features {
            edges,
            is_feature,
            vertex_weight,
            quadrics,
            mean_edge_length,
        } = features::classify(&mesh.positions, &mesh.triangles, options.sharp_angle_deg);
        // Each array goes as soon as what it makes is made: at a hundred million triangles the
        // quadrics alone are 4 GB.
        let ends = leaves::pair_ends(&quadrics, &vertex_weight, &mesh.positions);
        drop((quadrics, vertex_weight));
        prefix.feature_edges = is_feature.iter().filter(|&&f| f).count() as u32;
        drop(is_feature);
        crate::memory::trace_phase("features");
        prefix.phases.features = clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        let close = leaves::close_pairs_for(&mesh.positions, &edges, options, diagonal);
        drop(edges);
        crate::memory::trace_phase("close pairs");
        prefix.phases.close_pairs = clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        let lists = leaves::FaceLists::new(n, &mesh.triangles);
        let (leaf_nodes, mass) = leaves::leaves(mesh, |v| {
            let t = &mesh.triangles;
            lists.of(v).iter().map(move |&f| (f, t[f as usize]))
        });
        drop(lists);
        let split = Split::new(mesh, cell_triangles);
        let cell_range = cell_ranges(mesh, &split);
        let holder: Vec<u32> = close
            .par_iter()
            .map(|&(a, b)| {
                let (ra, rb) = (cell_range[a as usize], cell_range[b as usize]);
                split.holding(ra.0.min(rb.0)..ra.1.max(rb.1) + 1)
            })
            .collect();
        let mut by_node = vec![Vec::new(); split.nodes.len()];
        for (&pair, &k) in close.iter().zip(&holder) {
            by_node[k as usize].push(pair);
        }
        prefix.proximity_pairs = close.len() as u32;
        prefix.phases.leaves = clock.elapsed().as_secs_f64();
        crate::memory::trace_phase("leaves");
        Ok(Shared {
            mesh,
            options,
            split,
            cell_range,
            leaf_nodes,
            mass,
            ends,
            close: by_node,
            params: Params {
                options: options.clone(),
                mean_edge_length,
                radius: options.pair_distance.max(1e-3) * diagonal,
            },
            merges: AtomicUsize::new(0),
            prefix,
        })
    }

    /// The leaf cells' kd-tree nodes, in cell order.
    pub(super) fn cells(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.split.nodes.len() as u32)
            .filter(|&k| self.split.nodes[k as usize].children.is_none())
    }

    /// The cell number of leaf kd-tree node `at`.
    pub(super) fn cell_index(&self, at: u32) -> u32 {
        self.split.nodes[at as usize].cells.start
    }

    pub(super) fn params(&self) -> &Params {
        &self.params
    }

    /// Counts `merges` made elsewhere (a cell built by another process) in the progress.
    pub(super) fn count_merges(&self, merges: usize) {
        self.merges.fetch_add(merges, Ordering::Relaxed);
    }

    /// Every level, the leaf cells' from `leaf`, the halves of each kd-tree node at once, and the
    /// nodes numbered into one tree; progress from this thread meanwhile.
    /// The levels' nodes wait in a temporary folder in `spill` until they are numbered.
    pub(super) fn finish(
        self,
        leaf: &LeafCells,
        spill: &Path,
        start: Instant,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<(VertexTree, BuildStats), BuildError> {
        let n = self.mesh.positions.len();
        let spill = Spill::new(spill)?;
        let (remains, made, cell_stats) = std::thread::scope(|scope| {
            let work = scope.spawn(|| self.solve(self.split.root, leaf, &spill));
            while !work.is_finished() {
                progress(self.merges.load(Ordering::Relaxed), n - 1);
                std::thread::sleep(std::time::Duration::from_millis(50));
            }
            work.join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        })?;
        debug_assert_eq!(remains.slots.len(), 1);
        progress(n - 1, n - 1);
        let mut stats = cell_stats;
        stats.leaves = n as u32;
        stats.input_triangles = self.mesh.triangles.len() as u32;
        stats.parts = self.mesh.parts.len() as u32;
        stats.cells = self.cells().count() as u32;
        stats.levels = self.split.nodes[self.split.root as usize].height + 1;
        stats.feature_edges = self.prefix.feature_edges;
        stats.proximity_pairs = self.prefix.proximity_pairs;
        stats.phases.features = self.prefix.phases.features;
        stats.phases.close_pairs = self.prefix.phases.close_pairs;
        stats.phases.leaves = self.prefix.phases.leaves;
        // What only the levels read goes before the tree is numbered, whose nodes are a
        // partitioned build's peak: the leaves become the tree's first nodes, not a copy.
        let Shared {
            mesh,
            options,
            leaf_nodes,
            ends,
            mass,
            cell_range,
            close,
            split,
            ..
        } = self;
        drop((ends, mass, cell_range, close, split));
        crate::memory::trace_phase("levels");
        let tree = number::number(mesh, options, leaf_nodes, made)?;
        drop(spill);
        crate::memory::trace_phase("numbering");
        stats.nodes = tree.nodes.len() as u32;
        stats.depth = tree.depth();
        stats.seconds = start.elapsed().as_secs_f64();
        Ok((tree, stats))
    }

    /// Builds kd-tree node `at`: its cells, then its own level. Returns its remains, the nodes made
    /// under it, and what the builds did.
    fn solve(
        &self,
        at: u32,
        leaf: &LeafCells,
        spill: &Spill,
    ) -> Result<(Remains, Vec<Spilled>, BuildStats), BuildError> {
        let kd = &self.split.nodes[at as usize];
        let Some([l, r]) = kd.children else {
            let out = leaf(self, at)?;
            return Ok((out.remains, vec![spill.write(out.made)?], out.stats));
        };
        let (left, right) =
            rayon::join(|| self.solve(l, leaf, spill), || self.solve(r, leaf, spill));
        let ((left, mut made, mut stats), (right, more, other)) = (left?, right?);
        made.extend(more);
        add_stats(&mut stats, &other);
        let mut input = join(left, right);
        if at == self.split.root {
            // Vertices of no triangle are in no cell: the root joins them in.
            input.slots.extend(
                (0..self.mesh.positions.len() as u32)
                    .filter(|&v| self.cell_range[v as usize].0 == u32::MAX)
                    .map(|v| self.leaf_live(v)),
            );
        }
        let out = run_level(
            self.prepare(at, input),
            &self.params,
            &self.mesh.positions,
            &self.merges,
        );
        made.push(spill.write(out.made)?);
        add_stats(&mut stats, &out.stats);
        Ok((out.remains, made, stats))
    }

    /// Leaf cell `at` built here.
    fn build_cell(&self, at: u32) -> LevelOutput {
        run_cell(self.cell_input(at), &self.params, &self.merges)
    }

    /// Leaf cell `at`'s level: its triangles over its vertices, each a leaf.
    pub(super) fn cell_input(&self, at: u32) -> LevelInput {
        let kd = &self.split.nodes[at as usize];
        let triangles = &self.split.order[kd.triangles.clone()];
        let mut vertices: Vec<u32> = triangles
            .iter()
            .flat_map(|&t| self.mesh.triangles[t as usize])
            .collect();
        vertices.par_sort_unstable();
        vertices.dedup();
        let index = |v: u32| vertices.binary_search(&v).unwrap_or(0) as u32;
        let remains = Remains {
            triangles: triangles
                .iter()
                .map(|&t| (t, self.mesh.triangles[t as usize].map(index)))
                .collect(),
            slots: vertices.iter().map(|&v| self.leaf_live(v)).collect(),
            pairs: Vec::new(),
        };
        self.prepare(at, remains)
    }

    /// Input vertex `v` as a live vertex that has not merged yet.
    fn leaf_live(&self, v: u32) -> Live {
        let mut samples = [NONE; SAMPLES];
        samples[0] = v;
        Live {
            node: Ref::leaf(v),
            current: self.leaf_nodes[v as usize],
            end: self.ends[v as usize],
            mass: self.mass[v as usize],
            samples,
        }
    }

    /// Kd-tree node `at`'s level on `input`: its border (vertices with triangles outside it)
    /// locked, to half of its free vertices, or to one vertex at the root; the close pairs it
    /// holds added to the partners.
    fn prepare(&self, at: u32, mut input: Remains) -> LevelInput {
        let kd = &self.split.nodes[at as usize];
        let root = at == self.split.root;
        let locked: Vec<bool> = input
            .slots
            .iter()
            .map(|s| {
                !root
                    && s.node.as_leaf().is_some_and(|v| {
                        let (lo, hi) = self.cell_range[v as usize];
                        lo < kd.cells.start || hi >= kd.cells.end
                    })
            })
            .collect();
        let n = input.slots.len();
        let free = locked.iter().filter(|&&l| !l).count();
        let close = &self.close[at as usize];
        if !close.is_empty() {
            let leaf_slot: HashMap<u32, u32> = input
                .slots
                .iter()
                .enumerate()
                .filter_map(|(i, s)| s.node.as_leaf().map(|v| (v, i as u32)))
                .collect();
            input.pairs.extend(
                close
                    .iter()
                    .filter_map(|&(a, b)| Some((*leaf_slot.get(&a)?, *leaf_slot.get(&b)?))),
            );
        }
        let mut pairs: Vec<(u32, u32)> = input
            .pairs
            .iter()
            .map(|&(a, b)| (a.min(b), a.max(b)))
            .filter(|&(a, b)| a != b && !locked[a as usize] && !locked[b as usize])
            .collect();
        pairs.sort_unstable();
        pairs.dedup();
        input.pairs = pairs;
        LevelInput {
            at,
            height: kd.height,
            target: if root { 1 } else { (n - free / 2) as u32 },
            root,
            remains: input,
            locked,
        }
    }
}

/// Builds one level: its free slots merged, cheapest first, until `input.target` are live (or
/// only pairs with a locked end are left). `leaf_positions` are the positions the slots' error
/// samples name.
fn run_level(
    input: LevelInput,
    params: &Params,
    leaf_positions: &[Vec3],
    merges: &AtomicUsize,
) -> LevelOutput {
    let LevelInput {
        at,
        height,
        target,
        root,
        remains: input,
        locked,
    } = input;
    let n = input.slots.len();
    let corners: Vec<[u32; 3]> = input.triangles.iter().map(|t| t.1).collect();
    let edges = free_edges(n, &corners, &locked);
    let mut others = input.pairs.clone();
    others.retain(|p| edges.binary_search(p).is_err());

    let positions: Vec<Vec3> = input.slots.iter().map(|s| s.current.position()).collect();
    let mesh = Mesh::from_triangles(positions.clone(), corners);
    let mut collapser = Collapser::new(positions, &mesh.triangles);
    for &(a, b) in &others {
        collapser.add_proximity_pair(a, b);
    }
    let mut set = SlotSet::new(n);
    for (i, _) in locked.iter().enumerate().filter(|(_, l)| **l) {
        set.insert(i as u32);
    }
    let slots = &input.slots;
    let mut nodes = Vec::with_capacity(2 * n);
    nodes.extend(slots.iter().map(|s| s.current));
    let options = &params.options;
    let mut builder = Builder {
        mesh: &mesh,
        leaf_positions,
        locked: (!root).then_some(set),
        finisher: false,
        target_live: target as usize,
        collapser,
        ends: slots.iter().map(|s| s.end).collect(),
        colors: Vec::new(),
        mass: slots.iter().map(|s| s.mass).collect(),
        node_of: (0..n as u32).collect(),
        nodes,
        vanished: Vec::new(),
        vanish_offsets: vec![0],
        metric: options.metric,
        hybrid: options.hybrid,
        mean_edge_length: params.mean_edge_length,
        color_scale: 0.0,
        stats: BuildStats::default(),
        removed: Vec::new(),
        samples: slots.iter().map(|s| s.samples).collect(),
        wedges: None,
        charts: Vec::new(),
        scales: Vec::new(),
    };
    let mut initial = builder.price_pairs(&edges, true);
    drop(edges);
    initial.extend(builder.price_pairs(&others, false));
    let mut radius = params.radius;
    builder.run_passes(
        initial,
        &mut radius,
        options.max_pairs_per_vertex,
        &mut |_, _| {},
    );
    merges.fetch_add(builder.nodes.len() - n, Ordering::Relaxed);
    let stats = builder.stats.clone();
    let (remains, made) = after_level(at, height, &input, builder);
    LevelOutput {
        remains,
        made,
        stats,
    }
}

/// [`run_level`] on a leaf cell, whose slots are all leaves: its error samples are renamed to
/// slots for the build, so that it reads no positions but its own, and back after.
pub(super) fn run_cell(
    mut input: LevelInput,
    params: &Params,
    merges: &AtomicUsize,
) -> LevelOutput {
    let leaf_of: Vec<u32> = input
        .remains
        .slots
        .iter()
        .map(|s| s.node.as_leaf().unwrap_or(NONE))
        .collect();
    let positions: Vec<Vec3> = input
        .remains
        .slots
        .iter()
        .map(|s| s.current.position())
        .collect();
    for (i, s) in input.remains.slots.iter_mut().enumerate() {
        s.samples = [NONE; SAMPLES];
        s.samples[0] = i as u32;
    }
    let mut out = run_level(input, params, &positions, merges);
    for s in &mut out.remains.slots {
        for q in s.samples.iter_mut().filter(|q| **q != NONE) {
            *q = leaf_of[*q as usize];
        }
    }
    out
}

/// The edges of `corners` (over `n` slots) between free slots, each once, sorted: grouped by
/// their lower end in one counting pass, so a level costs time linear in its triangles.
fn free_edges(n: usize, corners: &[[u32; 3]], locked: &[bool]) -> Vec<(u32, u32)> {
    let each = || {
        corners
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .filter(|&(a, b)| !locked[a as usize] && !locked[b as usize])
    };
    let mut start = vec![0u32; n + 1];
    for (a, _) in each() {
        start[a as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut higher = vec![0u32; start[n] as usize];
    for (a, b) in each() {
        higher[fill[a as usize] as usize] = b;
        fill[a as usize] += 1;
    }
    let mut edges = Vec::with_capacity(higher.len() / 2 + 1);
    for a in 0..n {
        let list = &mut higher[start[a] as usize..start[a + 1] as usize];
        list.sort_unstable();
        let mut last = None;
        for &b in list.iter() {
            if last != Some(b) {
                edges.push((a as u32, b));
                last = Some(b);
            }
        }
    }
    edges
}

/// What a level leaves: its live slots (renumbered densely), live triangles and partners as the
/// parent's remains, and the nodes it made, named as [`Ref`]s.
fn after_level(at: u32, height: u32, input: &Remains, builder: Builder<'_>) -> (Remains, Made) {
    let Builder {
        nodes,
        node_of,
        collapser,
        ends,
        mass,
        samples,
        vanished,
        vanish_offsets,
        ..
    } = builder;
    let slots = &input.slots;
    let n = slots.len();
    let mut nodes = nodes;
    let made_nodes = nodes.split_off(n);
    let name = |u: u32| {
        if (u as usize) < n {
            slots[u as usize].node
        } else {
            Ref::made(at, u - n as u32)
        }
    };
    let live: Vec<u32> = collapser.live_slots().collect();
    let mut index = vec![NONE; n];
    for (i, &s) in live.iter().enumerate() {
        index[s as usize] = i as u32;
    }
    let mut pairs = Vec::new();
    for &s in &live {
        for partner in collapser.extra_neighbors(s) {
            let p = index[partner.slot as usize];
            if p != NONE && index[s as usize] < p {
                pairs.push((index[s as usize], p));
            }
        }
    }
    let remains = Remains {
        slots: live
            .iter()
            .map(|&s| {
                let (u, si) = (node_of[s as usize], s as usize);
                Live {
                    node: name(u),
                    current: if (u as usize) < n {
                        slots[u as usize].current
                    } else {
                        made_nodes[u as usize - n]
                    },
                    end: ends[si],
                    mass: mass[si],
                    samples: samples[si],
                }
            })
            .collect(),
        triangles: collapser
            .live_faces()
            .map(|(f, c)| (input.triangles[f as usize].0, c.map(|s| index[s as usize])))
            .collect(),
        pairs,
    };
    let made = Made {
        cell: at,
        height,
        children: made_nodes.iter().map(|m| m.children.map(name)).collect(),
        nodes: made_nodes,
        vanished: vanished
            .iter()
            .map(|&f| input.triangles[f as usize].0)
            .collect(),
        offsets: vanish_offsets,
    };
    (remains, made)
}

/// Two sibling cells' remains as one: their slots (the border vertices they share once), their
/// triangles and partners.
fn join(left: Remains, right: Remains) -> Remains {
    let Remains {
        mut slots,
        mut triangles,
        mut pairs,
    } = left;
    let shared: HashMap<u32, u32> = slots
        .iter()
        .enumerate()
        .filter_map(|(i, s)| s.node.as_leaf().map(|v| (v, i as u32)))
        .collect();
    let map: Vec<u32> = right
        .slots
        .iter()
        .map(|s| match s.node.as_leaf().and_then(|v| shared.get(&v)) {
            Some(&i) => i,
            None => {
                slots.push(*s);
                slots.len() as u32 - 1
            }
        })
        .collect();
    triangles.extend(
        right
            .triangles
            .into_iter()
            .map(|(f, c)| (f, c.map(|s| map[s as usize]))),
    );
    pairs.extend(
        right
            .pairs
            .into_iter()
            .map(|(a, b)| (map[a as usize], map[b as usize])),
    );
    Remains {
        slots,
        triangles,
        pairs,
    }
}

fn add_stats(to: &mut BuildStats, from: &BuildStats) {
    to.flip_deferrals += from.flip_deferrals;
    to.widenings += from.widenings;
    to.rounds += from.rounds;
    to.pricings += from.pricings;
    to.phases.pricing += from.phases.pricing;
    to.phases.merging += from.phases.merging;
    to.phases.repricing += from.phases.repricing;
}

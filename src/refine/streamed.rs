//! A tree flown without reading all of it (issue 40 §1; docs/RUNTIME.md, "A streamed tree"): the
//! runtime refines over the pages read so far, asks for the pages the view wants, and takes
//! them in when they have arrived, so that a frame never waits for the disk.
//!
//! # The part that is read
//! The pages a [`PageCache`] holds are a connected top of the tree (a page is only asked for by
//! a front node in the page above it). The runtime's hierarchy is built over that top: its
//! leaves are the tree's leaves that have been read and *stand-ins*, nodes whose children are
//! not read yet, which draw as one vertex and cannot split. A triangle's corners are leaves of
//! the whole tree; in the part each becomes the part's leaf whose leaves hold it (a version 5
//! file numbers leaves depth-first and gives every node its range, so that is a search in one
//! sorted array), and the cut's triangles come out as the whole tree's would for the same cut:
//! a triangle whose two corners fall under one stand-in is one that the cut does not draw.
//!
//! # Taking pages in
//! Pages arrive on the cache's reader thread. When some have arrived, the next part is built on
//! another thread, from every resident page and the front as it is then (each front node's
//! leaves, which name it in any part that holds it, or its nearest ancestor there). The frames go
//! on over the old part meanwhile; once the new one is ready it replaces the old, and the front
//! goes on from the cut it was built at, which the next frames adapt as they always do. Building
//! the part costs time in proportion to what is resident, not to the model.
//!
//! # Asking for pages
//! Each frame every stand-in on the front is weighed by the same tests as a node of the
//! hierarchy: one in view whose projected error is above τ asks for the pages of its children,
//! its projected error the priority (as Nexus orders its requests), so that what the user looks
//! at sharpens first. Its shading term is bounded from its normal cone, not measured, so a
//! stand-in may ask for a page its measured term would not need; never the other way round.
//! Pages in which the front stands, and the pages above them, are pinned; the cache lets the
//! least recently used of the others go when it is over its budget.

use super::adapt::{FrameStats, Refiner, Settings};
use super::cache::{CacheStats, PageCache, PageSource};
use super::criteria::{Camera, View};
use super::front::Front;
use super::hierarchy::{Bounds, Hierarchy, Whole, stand_in_bounds, turn_bound};
use crate::vtree::{DecodedPage, FormatError, NONE, Node, PagedFile, VertexTree};
use glam::Vec3;
use rustc_hash::FxHashMap;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, TryRecvError, channel};

/// Why a tree cannot be streamed.
#[derive(Debug, thiserror::Error)]
pub enum StreamError {
    #[error(transparent)]
    Format(#[from] FormatError),
    #[error(
        "{0}: format version 4 keeps the input's order of leaves; rebuild it with `vunify build` to stream it"
    )]
    OldVersion(String),
    #[error(
        "{0}: textures, materials and per-corner appearance are not streamed yet; view it without --cache"
    )]
    Appearance(String),
    #[error("{0}: its root's page is not readable: {1}")]
    Root(String, String),
}

/// The part of the tree read so far, as the runtime reads it.
pub struct Part {
    pub h: Arc<Hierarchy>,
    /// Per leaf of `h` and one more, the first leaf of the whole tree under it (the last entry
    /// is the whole tree's leaf count): a node's leaves in the whole tree are
    /// `leaf_first[lo]..leaf_first[hi]` for its range `lo..hi` in the part.
    leaf_first: Vec<u32>,
    /// Per node of `h`, the page it was read from.
    page: Vec<u32>,
    /// The leaves of `h` that stand for subtrees not read yet.
    stand_ins: Vec<StandIn>,
    /// The pages it was built from, in increasing order, and each one's nodes:
    /// `page_nodes[page_start[k]..page_start[k + 1]]` are those of `pages[k]`.
    pages: Vec<u32>,
    page_start: Vec<u32>,
    page_nodes: Vec<u32>,
}

/// A leaf of the part that is an internal node of the tree.
#[derive(Clone, Copy, Debug)]
struct StandIn {
    leaf: u32,
    bounds: Bounds,
    center: Vec3,
    /// The pages it needs to split ([`NONE`] for none).
    wants: [u32; 2],
}

impl Part {
    /// The leaves of the whole tree under node `u` of the part.
    pub fn whole_range(&self, u: u32) -> [u32; 2] {
        let (lo, hi, _) = self.h.leaf_range(u);
        [self.leaf_first[lo as usize], self.leaf_first[hi as usize]]
    }

    /// How many leaves of the part stand for subtrees not read yet.
    pub fn stand_ins(&self) -> usize {
        self.stand_ins.len()
    }

    /// Whether leaf `u` of the part stands for a subtree not read yet.
    pub fn is_stand_in(&self, u: u32) -> bool {
        self.stand_ins.binary_search_by_key(&u, |s| s.leaf).is_ok()
    }

    /// Whether the part was built with page `p`.
    pub fn has_page(&self, p: u32) -> bool {
        self.pages.binary_search(&p).is_ok()
    }

    /// Whether the front stands in page `p` or below it: some node of the page is active or
    /// split. Such a page must stay: a part built without it would lose the front below.
    pub fn in_use(&self, p: u32, front: &Front) -> bool {
        let Ok(k) = self.pages.binary_search(&p) else {
            return false;
        };
        let nodes = &self.page_nodes[self.page_start[k] as usize..self.page_start[k + 1] as usize];
        nodes.iter().any(|&u| front.state(u) != super::front::BELOW)
    }

    /// The page node `u` of the part was read from.
    pub fn page_of(&self, u: u32) -> u32 {
        self.page[u as usize]
    }

    /// The deepest node of the part whose leaves in the whole tree hold `range`.
    fn holding(&self, range: [u32; 2]) -> u32 {
        let h = &self.h;
        let mut u = h.root();
        while !h.is_leaf(u) {
            let inside = h.children(u).into_iter().find(|&c| {
                let [a, b] = self.whole_range(c);
                a <= range[0] && range[1] <= b
            });
            match inside {
                Some(c) => u = c,
                None => break,
            }
        }
        u
    }

    /// The cut of this part nearest to a cut given by its nodes' leaves in the whole tree: each
    /// node, or its deepest ancestor here when the node is not.
    pub fn cut_at(&self, ranges: &[[u32; 2]]) -> Vec<u32> {
        let mut held: Vec<(u32, u32, u32)> = ranges
            .iter()
            .map(|&r| {
                let u = self.holding(r);
                let [a, b] = self.whole_range(u);
                (a, b, u)
            })
            .collect();
        // Ancestors before their descendants: then a node is on the cut unless one kept holds it.
        held.sort_unstable_by(|x, y| x.0.cmp(&y.0).then(y.1.cmp(&x.1)));
        let mut cut = Vec::with_capacity(held.len());
        let mut end = 0;
        for (a, b, u) in held {
            if a >= end {
                cut.push(u);
                end = b;
            }
        }
        cut
    }
}

/// What every part of one file shares.
#[derive(Clone)]
struct Meta {
    leaf_count: u32,
    node_count: u32,
    page_of_root: Arc<FxHashMap<u32, u32>>,
    tree: VertexTree,
    inward: Option<bool>,
    diagonal: f32,
    /// The root's bounding sphere.
    sphere: (Vec3, f32),
}

/// A node of a part in the making: which of the pages it is in, and where in that page.
type At = (usize, usize);

/// The nodes of the part the pages hold, found from the root down in pre-order, first child
/// first (so the part's leaves come out in the whole tree's order).
struct Walk {
    leaves: Vec<At>,
    internal: Vec<At>,
    /// Per leaf, whether it stands for a subtree not read, and then the pages it wants.
    stand_in: Vec<Option<[u32; 2]>>,
    /// Per leaf, how far normals turn below it (0 for a leaf of the whole tree).
    turn: Vec<f32>,
    /// Nodes below the part that the cache keeps (see [`Trim::keeps`]).
    cached: Vec<At>,
}

/// How far normals turn below node `i` of `page`: as the page records it (version 6), else
/// bounded from the node's normal cone.
fn turn_at(page: &DecodedPage, i: usize) -> f32 {
    page.turns
        .get(i)
        .copied()
        .unwrap_or_else(|| turn_bound(&page.nodes[i]))
}

/// What a part needs of the resident pages: the nodes on and above the front it starts from, and
/// below those only the ones the view may split soon; the rest of a resident page stays out of
/// it until the view wants it (see [`Trim::expands`]). Without it a part is every resident node.
#[derive(Clone)]
struct Trim {
    view: View,
    tests: super::Tests,
    /// τ over [`TRIM_MARGIN`]: a node whose projected error is below it stays a stand-in.
    tau: f32,
    /// The front's nodes' leaves in the whole tree, in order.
    cut: Vec<[u32; 2]>,
    inward: bool,
}

/// How much finer than τ a part reaches below the front: the camera may come this many times
/// closer before the front needs a new part to refine further.
const TRIM_MARGIN: f32 = 4.0;

/// How much finer again the cache keeps the nodes of the pages it has read: the camera may come
/// this many times closer still before a page is read again.
const KEEP_MARGIN: f32 = 2.0;

impl Trim {
    /// Whether the cache keeps the children of `node`, below the part.
    fn keeps(&self, node: &Node, turn: f32) -> bool {
        let bounds = stand_in_bounds(node, turn, self.inward);
        let n = self.tests.view_of(&bounds, node.position());
        self.tests.projected(&self.view, &n) > self.tau / KEEP_MARGIN
    }

    /// Whether the part takes in the children of `node`, whose leaves are `leaves`.
    fn expands(&self, node: &Node, turn: f32, leaves: [u32; 2]) -> bool {
        // Above the front: the front node holding its first leaf is smaller than it.
        let k = self.cut.partition_point(|c| c[1] <= leaves[0]);
        if self
            .cut
            .get(k)
            .is_some_and(|c| c[1] < leaves[1] || c[0] > leaves[0])
        {
            return true;
        }
        let bounds = stand_in_bounds(node, turn, self.inward);
        let n = self.tests.view_of(&bounds, node.position());
        self.tests.projected(&self.view, &n) > self.tau
    }
}

fn walk(meta: &Meta, pages: &[(u32, Arc<DecodedPage>)], trim: Option<&Trim>) -> Option<Walk> {
    let slot_of: FxHashMap<u32, usize> = pages
        .iter()
        .enumerate()
        .map(|(s, (p, _))| (*p, s))
        .collect();
    // A node by its id: in the page of `near`, or heading a page of its own.
    let find = |id: u32, near: usize| -> Option<At> {
        if let Ok(i) = pages[near].1.ids.binary_search(&id) {
            return Some((near, i));
        }
        let &s = slot_of.get(meta.page_of_root.get(&id)?)?;
        let i = pages[s].1.ids.binary_search(&id).ok()?;
        Some((s, i))
    };
    let root = meta.node_count - 1;
    let root_slot = *slot_of.get(meta.page_of_root.get(&root)?)?;
    let mut out = Walk {
        leaves: Vec::new(),
        internal: Vec::new(),
        stand_in: Vec::new(),
        turn: Vec::new(),
        cached: Vec::new(),
    };
    let mut stack = vec![find(root, root_slot)?];
    while let Some((s, i)) = stack.pop() {
        if pages[s].1.ids[i] < meta.leaf_count {
            out.leaves.push((s, i));
            out.stand_in.push(None);
            out.turn.push(0.0);
            continue;
        }
        let turn = turn_at(&pages[s].1, i);
        let (node, leaves) = (&pages[s].1.nodes[i], pages[s].1.leaves[i]);
        let children = node.children;
        let found = children.map(|c| find(c, s));
        let expands = trim.is_none_or(|t| t.expands(node, turn, leaves));
        if let ([Some(c0), Some(c1)], true) = (found, expands) {
            out.internal.push((s, i));
            stack.push(c1);
            stack.push(c0);
        } else {
            if let Some(t) = trim {
                // Left out for now, but what the camera nearing would want soon stays cached.
                let mut below: Vec<At> = found.into_iter().flatten().collect();
                while let Some((s, i)) = below.pop() {
                    out.cached.push((s, i));
                    let (node, page) = (&pages[s].1.nodes[i], &pages[s].1);
                    if page.ids[i] >= meta.leaf_count && t.keeps(node, turn_at(page, i)) {
                        below.extend(node.children.iter().filter_map(|&c| find(c, s)));
                    }
                }
            }
            out.leaves.push((s, i));
            // The pages its children are in (read, or to be read; its own page when only
            // some of that page's nodes are kept).
            let want = |k: usize| match found[k] {
                Some((c, _)) => pages[c].0,
                None => meta
                    .page_of_root
                    .get(&children[k])
                    .copied()
                    .unwrap_or(pages[s].0),
            };
            out.stand_in.push(Some([want(0), want(1)]));
            out.turn.push(turn);
        }
    }
    Some(out)
}

/// The part's tree (leaves in the walk's order, internal nodes in reverse pre-order: children
/// before their parent, the root last), each of its nodes' page, and each leaf's first leaf in
/// the whole tree (and the whole tree's leaf count after them).
fn assemble(
    meta: &Meta,
    pages: &[(u32, Arc<DecodedPage>)],
    walk: &Walk,
) -> (VertexTree, Vec<u32>, Vec<u32>) {
    let (n_leaves, n_internal) = (walk.leaves.len() as u32, walk.internal.len() as u32);
    let tree_id_of_internal = |k: usize| n_leaves + n_internal - 1 - k as u32;
    let id = |(s, i): At| pages[s].1.ids[i];
    let tree_id: FxHashMap<u32, u32> = walk
        .leaves
        .iter()
        .enumerate()
        .map(|(j, &x)| (id(x), j as u32))
        .chain(
            walk.internal
                .iter()
                .enumerate()
                .map(|(k, &x)| (id(x), tree_id_of_internal(k))),
        )
        .collect();
    let count = (n_leaves + n_internal) as usize;
    let mut nodes = vec![<Node as bytemuck::Zeroable>::zeroed(); count];
    let mut page_of_tree = vec![0u32; count];
    let places = (walk.leaves.iter().enumerate().map(|(j, &x)| (j, x))).chain(
        (walk.internal.iter().enumerate()).map(|(k, &x)| (tree_id_of_internal(k) as usize, x)),
    );
    for (t, (s, i)) in places {
        let mut node = pages[s].1.nodes[i];
        // Pages leave parents unset; the part's come from its children below.
        node.parent = NONE;
        node.children = match t < n_leaves as usize {
            true => [NONE, NONE],
            false => node.children.map(|c| tree_id[&c]),
        };
        nodes[t] = node;
        page_of_tree[t] = pages[s].0;
    }
    for t in n_leaves as usize..count {
        for c in nodes[t].children {
            nodes[c as usize].parent = t as u32;
        }
    }
    let mut leaf_first: Vec<u32> = (walk.leaves.iter())
        .map(|&(s, i)| pages[s].1.leaves[i][0])
        .collect();
    leaf_first.push(meta.leaf_count);
    let (triangles, vanish_offsets) = triangles_of(meta, pages, &walk.internal, &leaf_first);
    let tree = VertexTree {
        leaf_count: n_leaves,
        nodes,
        triangles,
        vanish_offsets,
        ..meta.tree.clone()
    };
    (tree, page_of_tree, leaf_first)
}

/// The part's triangles, grouped by the node whose merge removed them as the file groups them
/// (`internal` in pre-order; the part's tree numbers them in reverse), each corner the part's
/// leaf that holds it; a triangle two of whose corners one stand-in holds is left out.
fn triangles_of(
    meta: &Meta,
    pages: &[(u32, Arc<DecodedPage>)],
    internal: &[At],
    leaf_first: &[u32],
) -> (Vec<[u32; 3]>, Vec<u32>) {
    let corner = |leaf: u32| leaf_first.partition_point(|&f| f <= leaf) as u32 - 1;
    // Per page, where its internal nodes begin and where each one's triangles do.
    let first_internal: Vec<usize> = (pages.iter())
        .map(|(_, p)| p.ids.partition_point(|&id| id < meta.leaf_count))
        .collect();
    let starts: Vec<Vec<u32>> = (pages.iter())
        .map(|(_, p)| {
            std::iter::once(0)
                .chain(p.counts.iter().scan(0, |at, &c| {
                    *at += c;
                    Some(*at)
                }))
                .collect()
        })
        .collect();
    let mut triangles = Vec::new();
    let mut vanish_offsets = Vec::with_capacity(internal.len() + 1);
    vanish_offsets.push(0);
    for &(s, i) in internal.iter().rev() {
        let k = i - first_internal[s];
        let (a, b) = (starts[s][k] as usize, starts[s][k + 1] as usize);
        for t in &pages[s].1.triangles[a..b] {
            let c = t.map(corner);
            if c[0] != c[1] && c[1] != c[2] && c[0] != c[2] {
                triangles.push(c);
            }
        }
        vanish_offsets.push(triangles.len() as u32);
    }
    (triangles, vanish_offsets)
}

/// Each page's nodes, given each node's page: the pages in increasing order, where each one's
/// nodes begin in the list, and the list (a counting sort over the pages).
fn nodes_by_page(page: &[u32]) -> (Vec<u32>, Vec<u32>, Vec<u32>) {
    let mut pages: Vec<u32> = page.to_vec();
    pages.sort_unstable();
    pages.dedup();
    let slot: Vec<u32> = (page.iter())
        .map(|p| pages.binary_search(p).expect("a page of the part") as u32)
        .collect();
    let mut start = vec![0u32; pages.len() + 1];
    for &k in &slot {
        start[k as usize + 1] += 1;
    }
    for k in 0..pages.len() {
        start[k + 1] += start[k];
    }
    let mut next = start.clone();
    let mut nodes = vec![0u32; page.len()];
    for (u, &k) in slot.iter().enumerate() {
        nodes[next[k as usize] as usize] = u as u32;
        next[k as usize] += 1;
    }
    (pages, start, nodes)
}

/// Builds the part of the tree that `pages` hold (which must include the root's page), and
/// says whether it winds inward (as given, or guessed from the part).
/// A page as the part found it, and the nodes of it the part uses: what the cache may keep of it.
type Kept = (u32, Arc<DecodedPage>, Arc<DecodedPage>);

/// Per page the part uses only some nodes of, the page and those nodes.
fn kept_of(pages: &[(u32, Arc<DecodedPage>)], walk: &Walk) -> Vec<Kept> {
    let mut used: Vec<Vec<usize>> = vec![Vec::new(); pages.len()];
    for &(s, i) in walk.leaves.iter().chain(&walk.internal).chain(&walk.cached) {
        used[s].push(i);
    }
    (pages.iter().zip(used))
        .filter(|((_, page), used)| used.len() < page.ids.len())
        .map(|((p, page), mut used)| {
            used.sort_unstable();
            used.dedup();
            (*p, page.clone(), Arc::new(page.keep(&used)))
        })
        .collect()
}

fn build_part(
    meta: &Meta,
    pages: &[(u32, Arc<DecodedPage>)],
    trim: Option<&Trim>,
) -> Option<(Part, bool, Vec<Kept>)> {
    let walk = walk(meta, pages, trim)?;
    let kept = match trim {
        Some(_) => kept_of(pages, &walk),
        None => Vec::new(),
    };
    let (tree, page_of_tree, leaf_first) = assemble(meta, pages, &walk);
    let renumber = Hierarchy::renumbering(&tree);
    let inward = meta.inward.unwrap_or_else(|| tree.winds_inward());
    let mut stand_ins: Vec<StandIn> = (walk.stand_in.iter().enumerate())
        .filter_map(|(j, wants)| {
            let node = &tree.nodes[j];
            wants.map(|wants| StandIn {
                leaf: renumber[j],
                bounds: stand_in_bounds(node, walk.turn[j], inward),
                center: node.position(),
                wants,
            })
        })
        .collect();
    stand_ins.sort_unstable_by_key(|s| s.leaf);
    let mut page = vec![0u32; page_of_tree.len()];
    for (t, &p) in page_of_tree.iter().enumerate() {
        page[renumber[t] as usize] = p;
    }
    let whole = Whole {
        inward,
        diagonal: meta.diagonal,
        leaf_turn: walk.turn.clone(),
    };
    let mut h = Hierarchy::of_part(tree, &whole);
    h.stand_in_error = vec![0.0; h.leaf_count as usize];
    for s in &stand_ins {
        h.stand_in_error[s.leaf as usize] = s.bounds.error;
    }
    let h = Arc::new(h);
    let (used, page_start, page_nodes) = nodes_by_page(&page);
    Some((
        Part {
            h,
            leaf_first,
            page,
            stand_ins,
            pages: used,
            page_start,
            page_nodes,
        },
        inward,
        kept,
    ))
}

/// How many nodes the first part holds at least (when the tree has them): the pages nearest
/// the root, read before the first frame, so that it draws the model coarsely rather than a
/// root page's few nodes.
const FIRST_NODES: usize = 1 << 15;

/// The pages nearest the root (level by level, each level read on every core) until they hold
/// [`FIRST_NODES`]. One that cannot be read is left out here: the cache reports it when the view
/// asks for it.
fn first_pages(
    file: &PagedFile,
    page_of_root: &FxHashMap<u32, u32>,
    root_page: u32,
    root: DecodedPage,
) -> Vec<(u32, Arc<DecodedPage>)> {
    use rayon::prelude::*;
    let mut pages = vec![(root_page, Arc::new(root))];
    let mut level = vec![0usize];
    let mut nodes = pages[0].1.ids.len();
    while nodes < FIRST_NODES && !level.is_empty() {
        let below: Vec<u32> = (level.iter())
            .flat_map(|&k| {
                let page = &pages[k].1;
                (page.nodes.iter())
                    .flat_map(|n| n.children)
                    .filter(|c| *c != NONE && page.ids.binary_search(c).is_err())
                    .filter_map(|c| page_of_root.get(&c).copied())
                    .collect::<Vec<_>>()
            })
            .collect();
        let read: Vec<(u32, DecodedPage)> = (below.par_iter())
            .filter_map(|&p| Some((p, file.read_page(p as usize).ok()?)))
            .collect();
        level = (pages.len()..pages.len() + read.len()).collect();
        for (p, page) in read {
            nodes += page.ids.len();
            pages.push((p, Arc::new(page)));
        }
    }
    pages
}

/// A part being built on another thread, with the front it will start from.
type Building = Receiver<Option<(Part, Refiner, Vec<Kept>)>>;

/// A tree flown from its file: the part read so far, the runtime over it, and the cache that
/// reads the rest (see the module's text).
pub struct Streamed {
    meta: Meta,
    cache: PageCache,
    part: Part,
    refiner: Refiner,
    settings: Settings,
    building: Option<Building>,
    /// The cache's count of arrived pages when the part being built (or the current one) was
    /// begun: a part is built again once more have arrived.
    loaded_then: u64,
    /// Pages resident when the part being built began that the current part lacks, or that the
    /// front stood in: kept resident until it is taken in, so that the front can step into them
    /// (and start from where it was).
    arriving: Vec<u32>,
    /// The same for the part taken in last, until the front has had a frame to step into them
    /// and be pinned there.
    arrived: Vec<u32>,
    /// A part was taken in since the front was last pinned.
    taken: bool,
    /// The last frame's camera and τ: what the next part is trimmed for.
    seen: Option<(Camera, f32)>,
    /// A page the view wants is resident but not in the part: the next part should have it.
    stale: bool,
    failures: Vec<(u32, FormatError)>,
    /// Parts taken in since the tree opened (the first included).
    pub parts: u64,
}

/// What [`Streamed::update`] did besides adapting the front.
#[derive(Clone, Copy, Debug, Default)]
pub struct StreamFrame {
    pub stats: FrameStats,
    /// The part, and so the hierarchy, is new: a renderer uploads it again.
    pub new_part: bool,
    pub cache: CacheStats,
}

impl Streamed {
    /// Opens a paged file for streaming within `budget` bytes of pages (see
    /// [`Streamed::new`]).
    pub fn open(
        path: &std::path::Path,
        budget: u64,
        settings: Settings,
    ) -> Result<Streamed, StreamError> {
        let file = PagedFile::open(path)?;
        Streamed::new(Arc::new(file), budget, settings)
    }

    /// A runtime over `file`'s root page alone, read now (the first frame draws it); the
    /// rest is read as the view asks for it, within `budget` bytes of decoded pages (pinned
    /// pages may hold more). The runtime's hierarchy over the pages is about as large again.
    pub fn new(
        file: Arc<PagedFile>,
        budget: u64,
        settings: Settings,
    ) -> Result<Streamed, StreamError> {
        let source: Arc<dyn PageSource> = file.clone();
        Streamed::with_source(file, source, budget, settings)
    }

    /// [`Streamed::new`] with the pages after the root's read from `source` (in tests, a disk
    /// that is slow or delivers in any order).
    pub fn with_source(
        file: Arc<PagedFile>,
        source: Arc<dyn PageSource>,
        budget: u64,
        settings: Settings,
    ) -> Result<Streamed, StreamError> {
        let name = file.path().display().to_string();
        if !file.leaves_depth_first() {
            return Err(StreamError::OldVersion(name));
        }
        if file.appearance {
            return Err(StreamError::Appearance(name));
        }
        let page_of_root = Arc::new(file.page_of_root());
        let root_page = file.entries.len() as u32 - 1;
        let root = file
            .read_page(root_page as usize)
            .map_err(|e| StreamError::Root(name.clone(), e.to_string()))?;
        let mut meta = Meta {
            leaf_count: file.leaf_count,
            node_count: file.node_count,
            page_of_root,
            tree: VertexTree {
                leaf_count: 0,
                nodes: Vec::new(),
                triangles: Vec::new(),
                vanish_offsets: Vec::new(),
                metric: file.metric,
                has_colors: file.has_colors,
                has_normals: file.has_normals,
                one_sided: file.one_sided,
                parts: file.parts.clone(),
                appearance: None,
                materials: None,
                wedges: None,
                position_error: file.position_error,
                inward: file.inward,
            },
            inward: None,
            // The root's sphere holds every leaf: its diameter stands for the leaves' box's
            // diagonal, which only reading every page would give.
            diagonal: root.nodes.last().map_or(1.0, |n| 2.0 * n.sphere[3]),
            sphere: root.nodes.last().map_or((Vec3::ZERO, 1.0), |n| {
                (Vec3::from_slice(&n.sphere), n.sphere[3])
            }),
        };
        let pages = first_pages(&file, &meta.page_of_root, root_page, root);
        let (part, inward, _) = build_part(&meta, &pages, None).ok_or_else(|| {
            StreamError::Root(name, "the root's page does not hold the root".into())
        })?;
        meta.inward = Some(inward);
        let refiner = Refiner::new(&part.h, settings);
        let readers = std::thread::available_parallelism().map_or(1, |n| n.get());
        let mut cache = PageCache::with_readers(source, budget, readers);
        for (p, page) in pages {
            cache.adopt(p, page);
        }
        let mut streamed = Streamed {
            meta,
            cache,
            part,
            refiner,
            settings,
            building: None,
            loaded_then: 0,
            arriving: Vec::new(),
            arrived: Vec::new(),
            taken: false,
            seen: None,
            stale: false,
            failures: Vec::new(),
            parts: 1,
        };
        streamed.loaded_then = streamed.cache.stats().loaded + streamed.cache.stats().rereads;
        Ok(streamed)
    }

    /// The whole tree's bounding sphere (its root's).
    pub fn sphere(&self) -> (Vec3, f32) {
        self.meta.sphere
    }

    /// The hierarchy the front is a cut of now.
    pub fn hierarchy(&self) -> &Hierarchy {
        &self.part.h
    }

    /// [`Streamed::hierarchy`], shared.
    pub fn hierarchy_arc(&self) -> Arc<Hierarchy> {
        self.part.h.clone()
    }

    /// The runtime's settings from now on.
    pub fn set_settings(&mut self, settings: Settings) {
        self.settings = settings;
        self.refiner.settings = settings;
    }

    pub fn part(&self) -> &Part {
        &self.part
    }

    pub fn front(&self) -> &Front {
        &self.refiner.front
    }

    /// The refiner over [`Streamed::hierarchy`].
    pub fn refiner(&self) -> &Refiner {
        &self.refiner
    }

    /// The hierarchy, the front and this frame's vertex updates: what a renderer uploads.
    pub fn output(&mut self) -> (&Hierarchy, &mut Front, &[(u32, Vec3)]) {
        let (front, moved) = self.refiner.output();
        (&self.part.h, front, moved)
    }

    /// Whether page `p` is in the cache now.
    pub fn is_resident(&self, p: u32) -> bool {
        self.cache.is_resident(p)
    }

    pub fn cache_stats(&self) -> CacheStats {
        self.cache.stats()
    }

    /// Pages that could not be read since the last call (each once), with why.
    pub fn take_failures(&mut self) -> Vec<(u32, FormatError)> {
        std::mem::take(&mut self.failures)
    }

    /// Adapts the front to one frame seen from `camera`: takes in a part that is ready, adapts,
    /// asks for the pages the view wants, and begins the next part when pages have arrived.
    /// Never waits for the disk or for a part.
    pub fn update(&mut self, camera: &Camera) -> StreamFrame {
        let new_part = self.take_part(false);
        let stats = self.refiner.update(&self.part.h, camera);
        self.seen = Some((*camera, stats.tolerance_px));
        if std::mem::take(&mut self.taken) {
            // The front has stepped into the new part's pages it wants: the others may go.
            for p in self.arrived.drain(..) {
                self.cache.unpin(p);
            }
        }
        let (part, front) = (&self.part, &self.refiner.front);
        let failures = self.cache.receive_keeping(&|p| part.in_use(p, front));
        self.failures.extend(failures);
        self.ask(camera, stats.tolerance_px);
        self.begin_part();
        StreamFrame {
            stats,
            new_part,
            cache: self.cache.stats(),
        }
    }

    /// Before a first frame seen from `camera`: adapts and waits for what it asks for, part
    /// after part, until nothing more is asked for or `limit` has passed (then the frames go on
    /// from there, and sharpen as the rest arrives).
    pub fn prepare(&mut self, camera: &Camera, limit: std::time::Duration) {
        let start = std::time::Instant::now();
        while start.elapsed() < limit {
            self.update(camera);
            if !self.settle() {
                break;
            }
        }
    }

    /// Waits until what has been asked for has arrived and a part holding it is taken in (for
    /// tests and tools, not for a frame): returns whether anything changed.
    pub fn settle(&mut self) -> bool {
        let (part, front) = (&self.part, &self.refiner.front);
        let failures = self
            .cache
            .receive_waiting_keeping(&|p| part.in_use(p, front));
        self.failures.extend(failures);
        let mut changed = self.take_part(true);
        self.begin_part();
        changed |= self.take_part(true);
        changed
    }

    /// Takes in the part being built when it is ready (`wait`: waits for it).
    fn take_part(&mut self, wait: bool) -> bool {
        let Some(building) = &self.building else {
            return false;
        };
        let ready = if wait {
            building.recv().map_err(|_| TryRecvError::Disconnected)
        } else {
            building.try_recv()
        };
        match ready {
            Err(TryRecvError::Empty) => false,
            Err(TryRecvError::Disconnected) | Ok(None) => {
                self.building = None;
                false
            }
            Ok(Some((part, refiner, kept))) => {
                self.building = None;
                // The cache keeps of each page what the part uses; the rest is read again
                // when the view wants it.
                for (p, was, kept) in kept {
                    self.cache.keep_only(p, &was, kept);
                }
                self.arrived.append(&mut self.arriving);
                self.taken = true;
                self.part = part;
                self.refiner = refiner;
                self.parts += 1;
                true
            }
        }
    }

    /// Begins building a new part when pages have arrived since the last one began.
    fn begin_part(&mut self) {
        let loaded = self.cache.stats().loaded + self.cache.stats().rereads;
        if self.building.is_some() || (loaded == self.loaded_then && !self.stale) {
            return;
        }
        self.loaded_then = loaded;
        self.stale = false;
        let pages = self.cache.resident();
        // Until the new part is taken in and the front has had a frame in it, its pages that
        // are new, and those the front stands in now (it starts again from this cut), stay.
        let front = &self.refiner.front;
        for &(p, _) in &pages {
            if (!self.part.has_page(p) || self.part.in_use(p, front)) && self.cache.pin(p) {
                self.arriving.push(p);
            }
        }
        let mut cut: Vec<[u32; 2]> = self
            .refiner
            .front
            .active()
            .into_iter()
            .map(|u| self.part.whole_range(u))
            .collect();
        cut.sort_unstable();
        let trim = self.seen.map(|(camera, tau)| Trim {
            view: View::new(&camera),
            tests: self.settings.tests,
            tau: tau / TRIM_MARGIN,
            cut: cut.clone(),
            inward: self.meta.inward.unwrap_or(false),
        });
        let (meta, settings) = (self.meta.clone(), self.settings);
        let (send, receive) = channel();
        self.building = Some(receive);
        std::thread::Builder::new()
            .name("vunify-part".into())
            .spawn(move || {
                let built = build_part(&meta, &pages, trim.as_ref()).map(|(part, _, kept)| {
                    let at = part.cut_at(&cut);
                    let front = Front::at_cut(&part.h, &at).expect("a cut of the part");
                    let refiner = Refiner::starting_from(&part.h, front, settings);
                    (part, refiner, kept)
                });
                let _ = send.send(built);
            })
            .expect("a thread starts");
    }

    /// Asks for the pages that the stand-ins on the front want to split into.
    fn ask(&mut self, camera: &Camera, tau: f32) {
        let view = View::new(camera);
        let tests = self.settings.tests;
        let mut wanted: Vec<(u32, f32)> = Vec::new();
        for s in &self.part.stand_ins {
            if !self.refiner.front.is_active(s.leaf) {
                continue;
            }
            let n = tests.view_of(&s.bounds, s.center);
            if tests.sees(&view, &n) {
                let px = tests.projected(&view, &n);
                if px > tau {
                    let wants = s.wants.into_iter().filter(|&p| p != NONE);
                    // All there: the next part splits it (a page that cannot be read never is).
                    self.stale |= wants.clone().all(|p| self.cache.is_whole(p));
                    for p in wants {
                        if self.cache.is_resident(p) && !self.cache.is_whole(p) {
                            self.cache.reread(p, px);
                        } else {
                            wanted.push((p, px));
                        }
                    }
                }
            }
        }
        // A wanted page that has arrived but is not in the part yet is looked into at once:
        // the pages below it that the view wants are asked for now, not a part later.
        let inward = self.meta.inward.unwrap_or(false);
        let mut looked: rustc_hash::FxHashSet<u32> = Default::default();
        while let Some((p, px)) = wanted.pop() {
            self.cache.request(p, px);
            if self.part.has_page(p) || !looked.insert(p) {
                continue;
            }
            let Some(page) = self.cache.get(p) else {
                continue;
            };
            for (i, (&id, node)) in page.ids.iter().zip(&page.nodes).enumerate() {
                if id < self.meta.leaf_count {
                    continue;
                }
                let outside = node
                    .children
                    .map(|c| page.ids.binary_search(&c).is_err().then_some(c));
                if outside == [None, None] {
                    continue;
                }
                let bounds = stand_in_bounds(node, turn_at(&page, i), inward);
                let n = tests.view_of(&bounds, node.position());
                let px = tests.projected(&view, &n);
                if px > tau && tests.sees(&view, &n) {
                    for c in outside.into_iter().flatten() {
                        if let Some(&q) = self.meta.page_of_root.get(&c) {
                            wanted.push((q, px));
                        }
                    }
                }
            }
        }
    }
}

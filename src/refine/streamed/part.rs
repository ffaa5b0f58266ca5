//! The part of a tree that the resident pages hold, as the runtime's hierarchy reads it (see
//! the parent module): which nodes it takes (the front, its ancestors, what the camera may split
//! soon), its tree, its triangles, and what the cache keeps of each page.

use super::super::criteria::View;
use super::super::front::Front;
use super::super::hierarchy::{Bounds, Hierarchy, Whole, stand_in_bounds, turn_bound};
use crate::vtree::{DecodedPage, NONE, Node, VertexTree};
use glam::Vec3;
use rustc_hash::FxHashMap;
use std::sync::Arc;

/// The part of the tree read so far, as the runtime reads it.
pub struct Part {
    pub h: Arc<Hierarchy>,
    /// Per leaf of `h` and one more, the first leaf of the whole tree under it (the last entry
    /// is the whole tree's leaf count): a node's leaves in the whole tree are
    /// `leaf_first[lo]..leaf_first[hi]` for its range `lo..hi` in the part.
    pub(super) leaf_first: Vec<u32>,
    /// Per node of `h`, the page it was read from.
    pub(super) page: Vec<u32>,
    /// The leaves of `h` that stand for subtrees not read yet.
    pub(super) stand_ins: Vec<StandIn>,
    /// The pages it was built from, in increasing order, and each one's nodes:
    /// `page_nodes[page_start[k]..page_start[k + 1]]` are those of `pages[k]`.
    pub(super) pages: Vec<u32>,
    pub(super) page_start: Vec<u32>,
    pub(super) page_nodes: Vec<u32>,
}

/// A leaf of the part that is an internal node of the tree.
#[derive(Clone, Copy, Debug)]
pub(super) struct StandIn {
    pub(super) leaf: u32,
    pub(super) bounds: Bounds,
    pub(super) center: Vec3,
    /// The pages it needs to split ([`NONE`] for none).
    pub(super) wants: [u32; 2],
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
        nodes
            .iter()
            .any(|&u| front.state(u) != super::super::front::BELOW)
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
pub(super) struct Meta {
    pub(super) leaf_count: u32,
    pub(super) node_count: u32,
    pub(super) page_of_root: Arc<FxHashMap<u32, u32>>,
    pub(super) tree: VertexTree,
    pub(super) inward: Option<bool>,
    pub(super) diagonal: f32,
    /// The root's bounding sphere.
    pub(super) sphere: (Vec3, f32),
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
pub(super) fn turn_at(page: &DecodedPage, i: usize) -> f32 {
    page.turns
        .get(i)
        .copied()
        .unwrap_or_else(|| turn_bound(&page.nodes[i]))
}

/// What a part needs of the resident pages: the nodes on and above the front it starts from, and
/// below those only the ones the view may split soon; the rest of a resident page stays out of
/// it until the view wants it (see [`Trim::expands`]). Without it a part is every resident node.
#[derive(Clone)]
pub(super) struct Trim {
    pub(super) view: View,
    pub(super) tests: crate::refine::Tests,
    /// τ over [`TRIM_MARGIN`]: a node whose projected error is below it stays a stand-in.
    pub(super) tau: f32,
    /// The front's nodes' leaves in the whole tree, in order.
    pub(super) cut: Vec<[u32; 2]>,
    pub(super) inward: bool,
}

/// How much finer than τ a part reaches below the front: the camera may come this many times
/// closer before the front needs a new part to refine further.
pub(super) const TRIM_MARGIN: f32 = 4.0;

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
    let (start, nodes) = super::super::hierarchy::group_by(&slot, pages.len());
    (pages, start, nodes)
}

/// Builds the part of the tree that `pages` hold (which must include the root's page), and
/// says whether it winds inward (as given, or guessed from the part).
/// A page as the part found it, and the nodes of it the part uses: what the cache may keep of it.
pub(super) type Kept = (u32, Arc<DecodedPage>, Arc<DecodedPage>);

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

pub(super) fn build_part(
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

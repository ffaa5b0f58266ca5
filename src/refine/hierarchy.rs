//! The vertex tree as the runtime reads it: structure-of-arrays, only what refinement and drawing need,
//! and the triangles regrouped by the node whose split makes them appear.
//!
//! A `.vtree` groups triangles by the merge of the *build* that removed them, which is right for cuts in
//! build order. A front refined in any order needs the purely structural rule instead: a triangle is
//! non-degenerate exactly when its lowest pairwise common ancestor `d(t)` is split, because that is the
//! node whose children two of its corners part into (Luebke & Erikson 1997 call these a node's
//! *subtris*). [`Hierarchy::appearing`] lists them per node.

use crate::vtree::{NONE, VertexTree};
use glam::Vec3;
use rayon::prelude::*;

/// Per-node and per-triangle data of a vertex tree, ready for [`super::Front`].
///
/// Nodes are renumbered depth-first: leaves `0..leaf_count` in depth-first order (so every subtree's
/// leaves are a range of ids), then internal nodes in pre-order, the root first. Nodes and triangles
/// near each other in the tree are near each other in memory, which is what a moving camera touches.
/// Arrays named `internal_*` are indexed by `u - leaf_count`.
#[derive(PartialEq)]
pub struct Hierarchy {
    pub leaf_count: u32,
    /// Position of every node: the vertex it is when it is on the front.
    pub position: Vec<Vec3>,
    pub parent: Vec<u32>,
    /// Unit normal of every node, octahedral-encoded in two `i16` (see [`decode_normal`]), for
    /// shading; [`NO_NORMAL`] when unknown.
    pub normal: Vec<[i16; 2]>,
    /// Linear RGB of every node as RGBA8; empty when the model has no colours.
    pub color: Vec<[u8; 4]>,
    /// Every node's texture coordinates, texture and material (`[u, v, texture, material]`, the
    /// texture an index into `textures` and the material into `materials`, as floats, −1 for
    /// none); empty when the model has neither textures nor materials.
    pub uv_texture: Vec<[f32; 4]>,
    /// The base colour textures' image files (PNG or JPEG, sRGB).
    pub textures: Vec<std::sync::Arc<Vec<u8>>>,
    /// The model's materials (their factors and alpha modes are drawn; their textures index the
    /// tree's images, not `textures`).
    pub materials: Vec<crate::mesh::Material>,
    /// What the view tests read of an internal node `k + leaf_count`, together (see [`Bounds`]).
    pub internal_bounds: Vec<Bounds>,
    /// What a split or unify of internal node `k + leaf_count` reads, in one cache line's quarter (see
    /// [`Internal`]); one more entry at the end closes the last node's appearing range.
    pub internal: Vec<Internal>,
    /// Every input triangle (leaf corners, input winding) grouped by `d(t)`, cyclically rotated so
    /// that corner 2 lies outside the subtree of `d(t)` and corners 0 and 1 inside it.
    pub triangles: Vec<[u32; 3]>,
    /// Per-corner appearance, when the tree has wedges: the drawn vertices are then wedges, not
    /// nodes, and `color` and `uv_texture` are per wedge.
    pub wedges: Option<HierarchyWedges>,
    /// The input's faces wind clockwise seen from outside (negative signed volume, like the horse
    /// model): cones were flipped so that the normal test still culls the far side.
    pub inward: bool,
    /// The model's winding is meant (see [`crate::mesh::Mesh::one_sided`]): a lit mesh, whose
    /// colours are drawn unlit by default.
    pub one_sided: bool,
    pub diagonal: f32,
    /// For the part of a tree read so far (see [`Hierarchy::of_part`]), per leaf the error of
    /// the subtree it stands for (0 for a leaf of the whole tree); empty for a whole tree.
    pub stand_in_error: Vec<f32>,
}

/// A tree's wedges as the runtime reads them (see [`crate::vtree::Wedges`]): renumbered so that
/// node `u`'s are `start[u]..start[u + 1]`, which are also their vertices in the drawn vertex
/// buffer.
#[derive(PartialEq)]
pub struct HierarchyWedges {
    pub start: Vec<u32>,
    /// Each wedge's node, and the wedge it becomes at its node's parent ([`NIL`] at the root).
    pub node: Vec<u32>,
    pub parent: Vec<u32>,
    /// Per triangle of [`Hierarchy::triangles`], its corners' leaf wedges (rotated likewise).
    pub corners: Vec<[u32; 3]>,
    /// Each wedge's unit normal, encoded as [`Hierarchy::normal`] (its node's where the input had
    /// none).
    pub normal: Vec<[i16; 2]>,
    /// Each wedge's tint of its texture, linear RGB as RGBA8 (see [`crate::vtree::Wedges::tint`]);
    /// empty when nothing is tinted.
    pub tint: Vec<[u8; 4]>,
}

impl HierarchyWedges {
    /// The wedge at node `u` (an ancestor of the leaf of `leaf_wedge`, or that leaf) that
    /// `leaf_wedge` has become: `u`'s only one, or found by walking up.
    #[inline]
    pub fn at(&self, leaf_wedge: u32, u: u32) -> u32 {
        let (lo, hi) = (self.start[u as usize], self.start[u as usize + 1]);
        if hi - lo == 1 {
            return lo;
        }
        let mut w = leaf_wedge;
        while !(lo..hi).contains(&w) {
            w = self.parent[w as usize];
        }
        w
    }

    /// The drawn vertices of a triangle with corner nodes `corners` and leaf wedges `leaf_wedges`.
    #[inline]
    pub fn vertices(&self, corners: [u32; 3], leaf_wedges: [u32; 3]) -> [u32; 3] {
        std::array::from_fn(|k| self.at(leaf_wedges[k], corners[k]))
    }

    pub fn len(&self) -> usize {
        self.node.len()
    }

    pub fn is_empty(&self) -> bool {
        self.node.is_empty()
    }
}

/// The view tests' data of an internal node, in one place because every visit reads all of it (as
/// four separate arrays it was four cache misses a visit).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct Bounds {
    /// Radius of a sphere about the node's *position* holding its subtree's surface: one point per
    /// node instead of a separate centre, at the cost of a slightly larger sphere.
    pub radius: f32,
    /// Object-space error (see [`crate::vtree::Node::error`]); never less than a child's.
    pub error: f32,
    /// How far shading may stray where the node stands in for its subtree, as a length: the node's
    /// radius times the sine of the largest angle between a node's normal and its children's in the
    /// subtree. Sub-pixel bumps move no vertex by a pixel but turn normals across many pixels; this
    /// is what the screen-space test weighs them by (see [`super::Tests::shading`]).
    pub shading: f32,
    /// Normal cone of the subtree's faces, oriented outwards (see [`Hierarchy::inward`]): axis
    /// octahedral-encoded, and the sine of the half-angle widened by the encoding's error; a sine of
    /// at least 1 when the cone spans a hemisphere or more (never wholly back-facing).
    pub cone_axis: [i16; 2],
    pub cone_sin: f32,
    /// A strict bound on the node's deviation from the input ([`VertexTree::deviation_bounds`]):
    /// what the screen-space test projects instead of `error` when [`super::Tests::strict`] is set.
    pub bound: f32,
}

/// The structure of an internal node, together because every operation on it reads all of it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C, align(16))]
pub struct Internal {
    /// The node's leaves are `lo..hi`; `mid` is the first leaf of its second child. Pre-order
    /// numbering makes the children follow from these: the first is leaf `lo` if it holds one leaf,
    /// else node `u + 1`; the second is leaf `mid` if it holds one leaf, else node `u + (mid − lo)`,
    /// after the first child's `mid − lo − 1` internal nodes.
    pub lo: u32,
    pub mid: u32,
    pub hi: u32,
    /// `triangles[appear..next.appear]` appear when the node splits (`next` is the following entry).
    pub appear: u32,
}

/// What a part of a tree (see [`Hierarchy::of_part`]) takes from the whole tree.
#[derive(Clone, Debug, Default)]
pub struct Whole {
    /// Whether the whole model winds inward (see [`Hierarchy::inward`]), decided once.
    pub inward: bool,
    /// The whole model's diagonal.
    pub diagonal: f32,
    /// Per leaf of the part (its id in the part's tree), the largest turn of normals in the
    /// subtree it stands for (0 for a true leaf): what the shading term of its ancestors weighs.
    pub leaf_turn: Vec<f32>,
}

/// The view data of a node that stands as a leaf for a subtree not read yet (see
/// [`Hierarchy::of_part`]), as [`Hierarchy::internal_bounds`] would hold it for the node were
/// its subtree read: `turn` the largest turn of normals below it, as far as is known.
pub fn stand_in_bounds(x: &crate::vtree::Node, turn: f32, inward: bool) -> Bounds {
    let center = Vec3::from_slice(&x.sphere);
    let radius = (center.distance(x.position()) + x.sphere[3]) * (1.0 + BOUND_SLACK);
    let (cone_axis, cone_sin) = runtime_cone(x, if inward { -1.0 } else { 1.0 });
    Bounds {
        radius,
        error: x.error,
        shading: radius * turn.min(std::f32::consts::FRAC_PI_2).sin(),
        cone_axis,
        cone_sin,
        bound: x.error,
    }
}

/// How far a normal can turn from a node's to a child's anywhere below the node, from what the
/// node alone says (what [`subtree_turns`] finds by walking the subtree): the subtree's faces,
/// and so its nodes' normals, lie within the node's normal cone, so two of them differ by at most
/// twice the cone's half-angle, and one from the node's own by its angle to the axis plus the
/// half-angle (π for a node without a cone or a normal).
pub fn turn_bound(x: &crate::vtree::Node) -> f32 {
    let (n, axis) = (Vec3::from_array(x.normal), Vec3::from_slice(&x.cone));
    if n == Vec3::ZERO || axis == Vec3::ZERO || x.cone[3] <= 0.0 {
        return std::f32::consts::PI;
    }
    let half = x.cone[3].min(1.0).acos();
    (2.0 * half).max(n.dot(axis).clamp(-1.0, 1.0).acos() + half)
}

/// Widen spheres and cones by this relative amount so float rounding never lets a member poke out.
const BOUND_SLACK: f32 = 1e-5;

/// Largest angle between a unit vector and its 16-bit octahedral encoding, decoded (6e-4 rad measured
/// by the round-trip test; padded), which cone tests add to the half-angle.
pub(crate) const OCT_ERROR_RADIANS: f32 = 2e-3;

impl Hierarchy {
    pub fn new(tree: &VertexTree) -> Hierarchy {
        Hierarchy::build(std::borrow::Cow::Borrowed(tree), None)
    }

    /// [`Hierarchy::new`] of a tree no longer needed: its nodes (84 bytes each, 1.2 GB at 14 M
    /// triangles) are let go as soon as their data is read, before the triangles are grouped,
    /// which is when building the hierarchy holds the most.
    pub fn from_tree(tree: VertexTree) -> Hierarchy {
        Hierarchy::build(std::borrow::Cow::Owned(tree), None)
    }

    /// [`Hierarchy::from_tree`] of the part of a larger tree that has been read (see
    /// `refine::streamed`): some of its leaves stand for subtrees not read yet, and what the
    /// whole tree decides is given rather than guessed from the part.
    pub fn of_part(tree: VertexTree, whole: &Whole) -> Hierarchy {
        Hierarchy::build(std::borrow::Cow::Owned(tree), Some(whole))
    }

    fn build(mut tree: std::borrow::Cow<'_, VertexTree>, whole: Option<&Whole>) -> Hierarchy {
        // Every per-node and per-triangle pass below runs on all cores (each gathers from the
        // tree's nodes in a new order, a cache miss a read: at 14 M triangles this was most of the
        // time before a model's first frame); results are the same on any number of threads.
        let n = tree.leaf_count;
        let n_leaves = n;
        let count = tree.nodes.len();
        let old = &tree.nodes;
        let (new_id, old_of) = depth_first_ids(&tree);
        let node = |id: u32| &old[old_of[id as usize] as usize];
        let renumber = |u: u32| if u == NIL { NIL } else { new_id[u as usize] };
        let position: Vec<Vec3> = (0..count as u32)
            .into_par_iter()
            .map(|u| node(u).position())
            .collect();
        let parent: Vec<u32> = (0..count as u32)
            .into_par_iter()
            .map(|u| renumber(node(u).parent))
            .collect();
        let normal: Vec<[i16; 2]> = (0..count as u32)
            .into_par_iter()
            .map(|u| encode_normal(Vec3::from_array(node(u).normal)))
            .collect();
        let color = colors_of(&tree, &old_of);
        let (uv_texture, textures, materials, layer) = appearance_of(&tree, &old_of);
        let internal: Vec<&crate::vtree::Node> =
            (n..count as u32).into_par_iter().map(node).collect();
        let internal_children: Vec<[u32; 2]> = internal
            .par_iter()
            .map(|x| x.children.map(renumber))
            .collect();
        debug_assert!(
            internal_children
                .iter()
                .enumerate()
                .all(|(k, c)| c[0] < n || c[0] == n + k as u32 + 1)
        );
        let internal_radius: Vec<f32> = internal
            .par_iter()
            .map(|x| {
                let center = Vec3::from_slice(&x.sphere);
                (center.distance(x.position()) + x.sphere[3]) * (1.0 + BOUND_SLACK)
            })
            .collect();
        let leaf_turn = |c: u32| whole.map_or(0.0, |w| w.leaf_turn[old_of[c as usize] as usize]);
        let turn = subtree_turns(
            &internal,
            &internal_children,
            |c| node(c).normal,
            leaf_turn,
            n_leaves,
        );
        let internal_shading: Vec<f32> = turn
            .iter()
            .zip(&internal_radius)
            .map(|(&t, &r)| r * t.min(std::f32::consts::FRAC_PI_2).sin())
            .collect();
        let (lo, hi) = leaf_ranges(&internal_children, n);
        let deviation =
            deviation_bounds(&position, &lo, &hi, &internal_children, tree.position_error);
        #[cfg(debug_assertions)]
        {
            let by_tree = tree.deviation_bounds();
            debug_assert!(deviation.iter().enumerate().all(|(k, &b)| {
                b.to_bits() == by_tree[old_of[n as usize + k] as usize].to_bits()
            }));
        }
        let mut internal_nodes: Vec<Internal> = internal_children
            .iter()
            .enumerate()
            .map(|(k, &[_, c1])| Internal {
                lo: lo[k],
                mid: if c1 < n { c1 } else { lo[(c1 - n) as usize] },
                hi: hi[k],
                appear: 0,
            })
            .collect();
        // A one-sided mesh (a lit room, seen from inside) means its winding even when its volume is
        // negative; anything else seen from outside is taken to be wound inward when it is.
        let inward = whole.map_or_else(|| tree.winds_inward(), |w| w.inward);
        let internal_bounds = bounds_of(
            &internal,
            [&deviation, &internal_radius, &internal_shading],
            inward,
        );
        drop(internal);
        let diagonal = whole.map_or_else(|| tree.diagonal(), |w| w.diagonal);
        if let std::borrow::Cow::Owned(t) = &mut tree {
            t.nodes = Vec::new();
            t.vanish_offsets = Vec::new();
        }
        let keyed = keyed_triangles(&tree, &new_id, &parent, &lo, &hi);
        internal_nodes.push(Internal::default());
        for (node, &appear) in internal_nodes.iter_mut().zip(&keyed.start) {
            node.appear = appear;
        }
        let (color, uv_texture, wedges) = match &tree.wedges {
            Some(w) => wedge_vertices(&tree, w, &new_id, &normal, &keyed, &layer),
            None => (color, uv_texture, None),
        };
        let triangles = keyed.arrange(&tree.triangles, &new_id);

        Hierarchy {
            leaf_count: n,
            position,
            parent,
            normal,
            color,
            uv_texture,
            textures,
            materials,
            internal_bounds,
            internal: internal_nodes,
            triangles,
            wedges,
            inward,
            one_sided: tree.one_sided,
            diagonal,
            stand_in_error: Vec::new(),
        }
    }

    pub fn node_count(&self) -> u32 {
        self.position.len() as u32
    }

    /// The root: the first internal node in pre-order (or the only leaf of a one-vertex tree).
    pub fn root(&self) -> u32 {
        if self.node_count() == 1 {
            0
        } else {
            self.leaf_count
        }
    }

    pub fn is_leaf(&self, u: u32) -> bool {
        u < self.leaf_count
    }

    #[inline]
    pub fn children(&self, u: u32) -> [u32; 2] {
        let Internal { lo, mid, hi, .. } = self.internal[(u - self.leaf_count) as usize];
        let first = if mid - lo == 1 { lo } else { u + 1 };
        let second = if hi - mid == 1 { mid } else { u + (mid - lo) };
        [first, second]
    }

    /// `(lo, hi, u)`: node `u`'s leaves are `lo..hi`.
    #[inline]
    pub fn leaf_range(&self, u: u32) -> (u32, u32, u32) {
        if u < self.leaf_count {
            (u, u + 1, u)
        } else {
            let Internal { lo, hi, .. } = self.internal[(u - self.leaf_count) as usize];
            (lo, hi, u)
        }
    }

    /// Does internal node `u`'s subtree hold `leaf`?
    #[inline]
    pub fn contains(&self, u: u32, leaf: u32) -> bool {
        let Internal { lo, hi, .. } = self.internal[(u - self.leaf_count) as usize];
        (lo..hi).contains(&leaf)
    }

    /// Object-space error of a node; 0 for a leaf.
    pub fn error(&self, u: u32) -> f32 {
        if u < self.leaf_count {
            0.0
        } else {
            self.internal_bounds[(u - self.leaf_count) as usize].error
        }
    }

    /// The error a node is drawn with where it stands: [`Hierarchy::error`], or for a leaf that
    /// stands for a subtree not read yet, that subtree's (what `--color-by error` shows).
    pub fn drawn_error(&self, u: u32) -> f32 {
        match self.stand_in_error.get(u as usize) {
            Some(&e) if u < self.leaf_count => e,
            _ => self.error(u),
        }
    }

    /// Bounding-sphere radius about the node's position; 0 for a leaf (never split, never tested).
    pub fn radius(&self, u: u32) -> f32 {
        if u < self.leaf_count {
            0.0
        } else {
            self.internal_bounds[(u - self.leaf_count) as usize].radius
        }
    }

    /// The triangles that become non-degenerate when internal node `u` splits.
    pub fn appearing(&self, u: u32) -> std::ops::Range<u32> {
        let k = (u - self.leaf_count) as usize;
        self.internal[k].appear..self.internal[k + 1].appear
    }

    /// Which child of internal node `u` holds `leaf` (which must lie in `u`'s subtree).
    #[inline]
    pub fn child_toward(&self, u: u32, leaf: u32) -> u32 {
        let Internal { lo, mid, hi, .. } = self.internal[(u - self.leaf_count) as usize];
        if leaf < mid {
            if mid - lo == 1 { lo } else { u + 1 }
        } else if hi - mid == 1 {
            mid
        } else {
            u + (mid - lo)
        }
    }

    /// Heap bytes of the arrays above.
    pub fn bytes(&self) -> usize {
        use std::mem::size_of_val;
        size_of_val(&self.position[..])
            + size_of_val(&self.parent[..])
            + size_of_val(&self.normal[..])
            + size_of_val(&self.color[..])
            + size_of_val(&self.internal_bounds[..])
            + size_of_val(&self.internal[..])
            + size_of_val(&self.triangles[..])
    }

    /// The input vertex of each leaf (the renumbering is depth-first; see [`Hierarchy`]).
    pub fn input_vertices(tree: &VertexTree) -> Vec<u32> {
        let n = tree.leaf_count;
        let mut out = Vec::with_capacity(n as usize);
        let mut stack = vec![tree.root()];
        while let Some(u) = stack.pop() {
            if u < n {
                out.push(u);
            } else {
                let [c0, c1] = tree.nodes[u as usize].children;
                stack.push(c1);
                stack.push(c0);
            }
        }
        out
    }

    /// The runtime id of every file node (`renumbering[file id]`), as [`Hierarchy::new`] numbers
    /// them: leaves in depth-first order, internal nodes in pre-order.
    pub fn renumbering(tree: &VertexTree) -> Vec<u32> {
        let n = tree.leaf_count;
        let mut out = vec![NIL; tree.nodes.len()];
        let (mut next_leaf, mut next_internal) = (0u32, n);
        let mut stack = vec![tree.root()];
        while let Some(u) = stack.pop() {
            if u < n {
                out[u as usize] = next_leaf;
                next_leaf += 1;
            } else {
                out[u as usize] = next_internal;
                next_internal += 1;
                let [c0, c1] = tree.nodes[u as usize].children;
                stack.push(c1);
                stack.push(c0);
            }
        }
        out
    }

    /// Every node, parents before children: internal nodes in pre-order, then the leaves.
    pub fn top_down(&self) -> impl Iterator<Item = u32> {
        (self.leaf_count..self.node_count()).chain(0..self.leaf_count)
    }

    /// Depth of node `u` below the root (a walk up: for debug colouring, not for inner loops).
    pub fn depth(&self, u: u32) -> u32 {
        let mut d = 0;
        let mut w = u;
        while self.parent[w as usize] != NIL {
            w = self.parent[w as usize];
            d += 1;
        }
        d
    }
}

/// The encoding of an unknown (zero) normal: −32768 never comes out of a unit vector.
pub const NO_NORMAL: [i16; 2] = [i16::MIN, i16::MIN];

/// Octahedral encoding of a unit vector in two snorm16 (Cigolle et al. 2014); zero gives
/// [`NO_NORMAL`].
pub fn encode_normal(n: Vec3) -> [i16; 2] {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    if l1 == 0.0 || !l1.is_finite() {
        return NO_NORMAL;
    }
    let (mut x, mut y) = (n.x / l1, n.y / l1);
    if n.z < 0.0 {
        (x, y) = ((1.0 - y.abs()) * x.signum(), (1.0 - x.abs()) * y.signum());
    }
    [x, y].map(|v| (v.clamp(-1.0, 1.0) * 32767.0).round() as i16)
}

/// The unit vector of [`encode_normal`] (zero for [`NO_NORMAL`]).
pub fn decode_normal(e: [i16; 2]) -> Vec3 {
    if e == NO_NORMAL {
        return Vec3::ZERO;
    }
    let (x, y) = (e[0] as f32 / 32767.0, e[1] as f32 / 32767.0);
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    let v = Vec3::new(x - t * x.signum(), y - t * y.signum(), z);
    v.normalize()
}

/// Marks the end of a list or a missing link.
pub const NIL: u32 = NONE;

/// Depth-first numbering of the tree's nodes (leaves `0..leaf_count` in the order a depth-first walk
/// meets them, internal nodes after them in pre-order): `new_id[old]`, and the old id of each new
/// one.
fn depth_first_ids(tree: &VertexTree) -> (Vec<u32>, Vec<u32>) {
    let n = tree.leaf_count;
    let count = tree.nodes.len();
    let old = &tree.nodes;
    let mut new_id = vec![NIL; count];
    let mut old_of = vec![NIL; count];
    let (mut next_leaf, mut next_internal) = (0u32, n);
    let mut stack = vec![tree.root()];
    while let Some(u) = stack.pop() {
        let id = if u < n {
            next_leaf += 1;
            next_leaf - 1
        } else {
            next_internal += 1;
            next_internal - 1
        };
        new_id[u as usize] = id;
        old_of[id as usize] = u;
        if u >= n {
            let [c0, c1] = old[u as usize].children;
            stack.push(c1);
            stack.push(c0);
        }
    }
    (new_id, old_of)
}

/// Each internal node's [`Bounds`] from its node in the tree and its `[bound, radius, shading]`,
/// the cone turned inside out when the mesh winds `inward`.
fn bounds_of(
    internal: &[&crate::vtree::Node],
    [bound, radius, shading]: [&[f32]; 3],
    inward: bool,
) -> Vec<Bounds> {
    let flip = if inward { -1.0 } else { 1.0 };
    internal
        .par_iter()
        .enumerate()
        .map(|(k, x)| {
            let (cone_axis, cone_sin) = runtime_cone(x, flip);
            Bounds {
                bound: bound[k],
                radius: radius[k],
                error: x.error,
                shading: shading[k],
                cone_axis,
                cone_sin,
            }
        })
        .collect()
}

/// The tree's triangles in the hierarchy's order: grouped by `d(t)`, in index order within a group.
struct Keyed {
    /// Each group's start in `order`, per internal node `d − leaf_count`, and one more at the end.
    start: Vec<u32>,
    /// The tree's triangle indices, in this order.
    order: Vec<u32>,
    /// Per tree triangle, its corner outside the subtree of `d(t)` (0, 1 or 2): rotated last.
    outside: Vec<u8>,
}

impl Keyed {
    /// Per-triangle `corners` (the tree's triangles, or their wedges) in this order, each renamed
    /// by `renumber` and rotated so that its outside corner comes last.
    fn arrange(&self, corners: &[[u32; 3]], renumber: &[u32]) -> Vec<[u32; 3]> {
        self.order
            .par_iter()
            .map(|&t| {
                let c = corners[t as usize].map(|x| renumber[x as usize]);
                let outside = self.outside[t as usize] as usize;
                [c[(outside + 1) % 3], c[(outside + 2) % 3], c[outside]]
            })
            .collect()
    }
}

/// Items grouped by their `group` (each below `groups`) with a counting sort, stable: where each
/// group begins in the order (and one more at the end), and the items' indices in that order.
pub(super) fn group_by(group: &[u32], groups: usize) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; groups + 1];
    for &g in group {
        start[g as usize + 1] += 1;
    }
    for k in 0..groups {
        start[k + 1] += start[k];
    }
    let mut next = start.clone();
    let mut order = vec![0u32; group.len()];
    for (t, &g) in group.iter().enumerate() {
        order[next[g as usize] as usize] = t as u32;
        next[g as usize] += 1;
    }
    (start, order)
}

/// Every triangle's `d(t)` in this numbering and its outside corner, and the triangles grouped by
/// it with a counting sort (stable, so in index order within a group): 9 bytes a triangle, where
/// sorting `(d, corners, index, corner)` records took 64 with the sort's buffer (at 14 M triangles
/// 0.9 GB of fresh memory before the first frame).
fn keyed_triangles(
    tree: &VertexTree,
    new_id: &[u32],
    parent: &[u32],
    lo: &[u32],
    hi: &[u32],
) -> Keyed {
    let n = tree.leaf_count;
    let contains = |u: u32, leaf: u32| {
        let k = (u - n) as usize;
        (lo[k]..hi[k]).contains(&leaf)
    };
    let (group, outside): (Vec<u32>, Vec<u8>) = tree
        .triangles
        .par_iter()
        .map(|t| {
            let [x, y, z] = t.map(|v| new_id[v as usize]);
            let mut a = parent[x as usize];
            while !contains(a, y) && !contains(a, z) {
                a = parent[a as usize];
            }
            // `a` is the lowest ancestor of x holding y or z. Holding both, the lowest pairwise
            // ancestor is that of y and z (both in a's other child), and x is the outside corner.
            let (d, outside) = match (contains(a, y), contains(a, z)) {
                (true, true) => {
                    let mut b = parent[y as usize];
                    while !contains(b, z) {
                        b = parent[b as usize];
                    }
                    (b, 0)
                }
                (true, false) => (a, 2),
                _ => (a, 1),
            };
            (d - n, outside)
        })
        .unzip();
    let (start, order) = group_by(&group, lo.len());
    Keyed {
        start,
        order,
        outside,
    }
}

/// [`VertexTree::deviation_bounds`] of the internal nodes, in this numbering and with the same
/// bits: each node's leaves are the range `lo[k]..hi[k]` of `position`, read in order on every
/// core, where the tree's own walks up from every leaf to the root and meets each ancestor at
/// random (at 14 M triangles a fifth of building the hierarchy).
fn deviation_bounds(
    position: &[Vec3],
    lo: &[u32],
    hi: &[u32],
    internal_children: &[[u32; 2]],
    position_error: f32,
) -> Vec<f32> {
    let n = position.len() - lo.len();
    let mut bound: Vec<f32> = (0..lo.len())
        .into_par_iter()
        .map(|k| {
            let p = position[n + k];
            position[lo[k] as usize..hi[k] as usize]
                .iter()
                .map(|q| (q.distance(p) + 2.0 * position_error) * (1.0 + BOUND_SLACK))
                .fold(0f32, f32::max)
                .max(position_error)
        })
        .collect();
    // Pre-order reversed meets children first.
    for k in (0..lo.len()).rev() {
        for c in internal_children[k] {
            let below = if (c as usize) < n {
                position_error
            } else {
                bound[c as usize - n]
            };
            bound[k] = bound[k].max(below);
        }
    }
    bound
}

/// The leaves under each internal node, `lo[k]..hi[k]` (depth-first numbering makes them a range).
/// Internal nodes are in pre-order, so a reverse sweep meets children first.
fn leaf_ranges(internal_children: &[[u32; 2]], n: u32) -> (Vec<u32>, Vec<u32>) {
    let mut lo = vec![0u32; internal_children.len()];
    let mut hi = vec![0u32; internal_children.len()];
    for k in (0..internal_children.len()).rev() {
        let [c0, c1] = internal_children[k];
        let first = if c0 < n { c0 } else { lo[(c0 - n) as usize] };
        let end = if c1 < n {
            c1 + 1
        } else {
            hi[(c1 - n) as usize]
        };
        (lo[k], hi[k]) = (first, end);
    }
    (lo, hi)
}

/// The largest angle between a node's normal and any normal below it, per internal node, children
/// first (pre-order reversed); `normal_of(c)` is node `c`'s normal.
fn subtree_turns(
    internal: &[&crate::vtree::Node],
    internal_children: &[[u32; 2]],
    normal_of: impl Fn(u32) -> [f32; 3],
    leaf_turn: impl Fn(u32) -> f32,
    n_leaves: u32,
) -> Vec<f32> {
    let mut turn = vec![0f32; internal.len()];
    for k in (0..internal.len()).rev() {
        let n = Vec3::from_array(internal[k].normal);
        for c in internal_children[k] {
            let cn = Vec3::from_array(normal_of(c));
            let angle = if n == Vec3::ZERO || cn == Vec3::ZERO {
                0.0
            } else {
                n.dot(cn).clamp(-1.0, 1.0).acos()
            };
            let below = if c >= n_leaves {
                turn[(c - n_leaves) as usize]
            } else {
                leaf_turn(c)
            };
            turn[k] = turn[k].max(angle).max(below);
        }
    }
    turn
}

/// A node's normal cone as the back-face test reads it: the axis (flipped for inward-wound models)
/// encoded, and the sine of the half-angle padded for rounding and the encoding; infinite for a cone
/// that can never face wholly away.
fn runtime_cone(x: &crate::vtree::Node, flip: f32) -> ([i16; 2], f32) {
    let axis = Vec3::from_slice(&x.cone) * flip;
    let cos = x.cone[3];
    if axis == Vec3::ZERO || cos <= 0.0 {
        // Empty (no faces) or a hemisphere and more: never wholly back-facing.
        return (NO_NORMAL, f32::INFINITY);
    }
    let angle = cos.min(1.0).acos() * (1.0 + BOUND_SLACK) + OCT_ERROR_RADIANS;
    let sin = if angle >= std::f32::consts::FRAC_PI_2 {
        f32::INFINITY
    } else {
        angle.sin()
    };
    (encode_normal(axis), sin)
}

/// A node's colour as 8-bit RGBA.
/// Every node's `[u, v, texture, material]` in the hierarchy's order (`old_of`: the tree's id of
/// each), the texture as its layer among the drawn textures and both as floats, −1 for none; and the
/// drawn textures and the materials; empty for a tree with neither textures nor materials.
#[allow(clippy::type_complexity)]
fn appearance_of(
    tree: &VertexTree,
    old_of: &[u32],
) -> (
    Vec<[f32; 4]>,
    Vec<std::sync::Arc<Vec<u8>>>,
    Vec<crate::mesh::Material>,
    Vec<f32>,
) {
    let Some(materials) = (tree.appearance.is_some() || tree.materials.is_some()).then(|| {
        tree.materials
            .as_ref()
            .map_or_else(Vec::new, |m| m.list.clone())
    }) else {
        return (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    };
    // Only base colour textures are drawn: each gets a layer (the other maps a material carries
    // are not uploaded).
    let mut layer = Vec::new();
    let mut drawn = Vec::new();
    if let Some(a) = &tree.appearance {
        layer = vec![-1.0f32; a.textures.len()];
        // With wedges, every wedge's texture: a node's first wedge shows only one of them.
        let wedge_textures = tree.wedges.as_ref().map_or(&[][..], |w| &w.texture[..]);
        for &t in a.texture_of.iter().chain(wedge_textures) {
            if t != crate::mesh::NO_TEXTURE && layer[t as usize] < 0.0 {
                layer[t as usize] = drawn.len() as f32;
                drawn.push(a.textures[t as usize].clone());
            }
        }
    }
    let uv_texture = old_of
        .iter()
        .map(|&old| {
            let old = old as usize;
            let material = tree.materials.as_ref().map_or(-1.0, |m| m.of[old] as f32);
            let Some(a) = &tree.appearance else {
                return [0.0, 0.0, -1.0, material];
            };
            let t = a.texture_of[old];
            let t = if t == crate::mesh::NO_TEXTURE {
                -1.0
            } else {
                layer[t as usize]
            };
            [a.uvs[old][0], a.uvs[old][1], t, material]
        })
        .collect();
    (uv_texture, drawn, materials, layer)
}

/// Every node's display colour in the hierarchy's order; empty for a tree without colours.
fn colors_of(tree: &VertexTree, old_of: &[u32]) -> Vec<[u8; 4]> {
    if !tree.has_colors {
        return Vec::new();
    }
    old_of
        .iter()
        .map(|&old| display_color(&tree.nodes[old as usize]))
        .collect()
}

fn display_color(node: &crate::vtree::Node) -> [u8; 4] {
    let c = node
        .color
        .map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8);
    [c[0], c[1], c[2], 255]
}

/// The tree's wedges renumbered by their nodes' new ids (`new_id`), and each triangle's corners'
/// leaf wedges in `keyed`'s order and rotation.
fn wedges_of(
    w: &crate::vtree::Wedges,
    new_id: &[u32],
    keyed: &Keyed,
) -> (HierarchyWedges, Vec<u32>) {
    let nodes = new_id.len();
    let mut start = vec![0u32; nodes + 1];
    for &u in &w.node {
        start[new_id[u as usize] as usize + 1] += 1;
    }
    for u in 0..nodes {
        start[u + 1] += start[u];
    }
    let mut next = start.clone();
    let renumbered: Vec<u32> = w
        .node
        .iter()
        .map(|&u| {
            let slot = &mut next[new_id[u as usize] as usize];
            *slot += 1;
            *slot - 1
        })
        .collect();
    let mut node = vec![0; w.len()];
    let mut parent = vec![NIL; w.len()];
    for (old, &new) in renumbered.iter().enumerate() {
        node[new as usize] = new_id[w.node[old] as usize];
        let p = w.parent[old];
        parent[new as usize] = if p == NONE {
            NIL
        } else {
            renumbered[p as usize]
        };
    }
    let corners = keyed.arrange(&w.corners, &renumbered);
    (
        HierarchyWedges {
            start,
            node,
            parent,
            corners,
            normal: Vec::new(),
            tint: Vec::new(),
        },
        renumbered,
    )
}

/// A tree's wedges renumbered (see [`wedges_of`]) and their colours and `[u, v, layer, material]`
/// (see [`wedge_appearance`]).
#[allow(clippy::type_complexity)]
fn wedge_vertices(
    tree: &VertexTree,
    w: &crate::vtree::Wedges,
    new_id: &[u32],
    normal: &[[i16; 2]],
    keyed: &Keyed,
    layer: &[f32],
) -> (Vec<[u8; 4]>, Vec<[f32; 4]>, Option<HierarchyWedges>) {
    let (mut hw, renumbered) = wedges_of(w, new_id, keyed);
    hw.normal = vec![NO_NORMAL; w.len()];
    for (old, &new) in renumbered.iter().enumerate() {
        // A wedge without a normal of its own shows its node's (`normal`, in the new ids).
        let own = Vec3::from_array(w.normal[old]);
        hw.normal[new as usize] = if own == Vec3::ZERO {
            normal[new_id[w.node[old] as usize] as usize]
        } else {
            encode_normal(own)
        };
    }
    if !w.tint.is_empty() {
        hw.tint = vec![[255; 4]; w.len()];
        for (old, &new) in renumbered.iter().enumerate() {
            let c = w.tint[old].map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8);
            hw.tint[new as usize] = [c[0], c[1], c[2], 255];
        }
    }
    let (c, uv) = wedge_appearance(w, &renumbered, layer, tree.materials.is_some());
    let c = if tree.has_colors { c } else { Vec::new() };
    (c, uv, Some(hw))
}

/// Per wedge, in the hierarchy's order (`renumbered`: each tree wedge's id there), its display
/// colour and `[u, v, layer, material]` (`layer`: each texture's layer, −1 for none).
fn wedge_appearance(
    w: &crate::vtree::Wedges,
    renumbered: &[u32],
    layer: &[f32],
    has_materials: bool,
) -> (Vec<[u8; 4]>, Vec<[f32; 4]>) {
    let mut color = vec![[0u8; 4]; w.len()];
    let mut uv_texture = vec![[0f32; 4]; w.len()];
    for (old, &new) in renumbered.iter().enumerate() {
        let c = w.color[old].map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8);
        color[new as usize] = [c[0], c[1], c[2], 255];
        let t = w.texture[old];
        let t = if t == crate::mesh::NO_TEXTURE {
            -1.0
        } else {
            layer.get(t as usize).copied().unwrap_or(-1.0)
        };
        let material = if has_materials {
            w.material[old] as f32
        } else {
            -1.0
        };
        uv_texture[new as usize] = [w.uv[old][0], w.uv[old][1], t, material];
    }
    (color, uv_texture)
}

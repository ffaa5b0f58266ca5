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

/// Per-node and per-triangle data of a vertex tree, ready for [`super::Front`].
///
/// Node numbering is the file's: leaves `0..leaf_count` (the input's vertices), then internal nodes,
/// children before parents, the root last. Arrays named `internal_*` are indexed by `u - leaf_count`.
pub struct Hierarchy {
    pub leaf_count: u32,
    /// Position of every node: the vertex it is when it is on the front.
    pub position: Vec<Vec3>,
    pub parent: Vec<u32>,
    /// Unit normal of every node, for shading (zero when unknown).
    pub normal: Vec<Vec3>,
    /// Linear RGB of every node; empty when the model has no colours.
    pub color: Vec<[f32; 3]>,
    pub internal_children: Vec<[u32; 2]>,
    /// Object-space error (see [`crate::vtree::Node::error`]); never less than a child's.
    pub internal_error: Vec<f32>,
    /// Radius of a sphere about the node's *position* holding its subtree's surface: one point per
    /// node instead of a separate centre, at the cost of a slightly larger sphere.
    pub internal_radius: Vec<f32>,
    /// Normal cone of the subtree's faces: `(axis, sin of the half-angle)`, oriented outwards (see
    /// [`Hierarchy::inward`]); `sin ≥ 1` when the cone spans a hemisphere or more.
    pub internal_cone: Vec<[f32; 4]>,
    /// Leaves of the subtree are those with `leaf_rank` in `[lo, hi)`; the first child's are below
    /// `internal_mid`. Depth-first order makes every subtree a range of ranks.
    pub internal_mid: Vec<u32>,
    pub leaf_rank: Vec<u32>,
    /// Every input triangle (leaf corners, input winding) grouped by `d(t)`, cyclically rotated so
    /// that corner 2 lies outside the subtree of `d(t)` and corners 0 and 1 inside it.
    pub triangles: Vec<[u32; 3]>,
    /// `triangles[appear_offsets[k]..appear_offsets[k + 1]]` appear when internal node `k` splits.
    pub appear_offsets: Vec<u32>,
    /// Depth of every node below the root (saturating), for debug colouring.
    pub depth: Vec<u8>,
    /// The input's faces wind clockwise seen from outside (negative signed volume, like the horse
    /// model): cones were flipped so that the normal test still culls the far side.
    pub inward: bool,
    pub diagonal: f32,
}

/// Widen spheres and cones by this relative amount so float rounding never lets a member poke out.
const BOUND_SLACK: f32 = 1e-5;

impl Hierarchy {
    pub fn new(tree: &VertexTree) -> Hierarchy {
        let n = tree.leaf_count;
        let count = tree.nodes.len();
        let nodes = &tree.nodes;
        let position: Vec<Vec3> = nodes.iter().map(|x| x.position()).collect();
        let parent: Vec<u32> = nodes.iter().map(|x| x.parent).collect();
        let normal = nodes.iter().map(|x| Vec3::from_array(x.normal)).collect();
        let color = if tree.has_colors {
            nodes.iter().map(|x| x.color).collect()
        } else {
            Vec::new()
        };
        let internal = &nodes[n as usize..];
        let internal_children: Vec<[u32; 2]> = internal.iter().map(|x| x.children).collect();
        let internal_error = internal.iter().map(|x| x.error).collect();
        let internal_radius = internal
            .iter()
            .map(|x| {
                let center = Vec3::from_slice(&x.sphere);
                (center.distance(x.position()) + x.sphere[3]) * (1.0 + BOUND_SLACK)
            })
            .collect();

        // Depth-first leaf ranks; `lo`/`hi` per internal node only while building.
        let mut leaf_rank = vec![0u32; n as usize];
        let mut lo = vec![0u32; internal.len()];
        let mut hi = vec![0u32; internal.len()];
        let mut internal_mid = vec![0u32; internal.len()];
        let mut depth = vec![0u8; count];
        let mut next_rank = 0;
        // (node, children done?) — iterative, the tree may be deep.
        let mut stack = vec![(tree.root(), false)];
        while let Some((u, done)) = stack.pop() {
            if u < n {
                leaf_rank[u as usize] = next_rank;
                next_rank += 1;
                continue;
            }
            let k = (u - n) as usize;
            let [c0, c1] = internal_children[k];
            if done {
                hi[k] = next_rank;
                internal_mid[k] = if c1 < n {
                    leaf_rank[c1 as usize]
                } else {
                    lo[(c1 - n) as usize]
                };
                continue;
            }
            lo[k] = next_rank;
            for c in [c0, c1] {
                depth[c as usize] = depth[u as usize].saturating_add(1);
            }
            stack.push((u, true));
            stack.push((c1, false));
            stack.push((c0, false));
        }
        let contains = |u: u32, leaf: u32| {
            let k = (u - n) as usize;
            (lo[k]..hi[k]).contains(&leaf_rank[leaf as usize])
        };

        // d(t) and the rotation that puts the outside corner last.
        let inward = signed_volume(&position, &tree.triangles) < 0.0;
        let mut keyed: Vec<(u32, [u32; 3])> = tree
            .triangles
            .iter()
            .map(|&t| {
                let [x, y, z] = t;
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
                let rotated = [t[(outside + 1) % 3], t[(outside + 2) % 3], t[outside]];
                (d - n, rotated)
            })
            .collect();
        keyed.sort_by_key(|&(k, _)| k);
        let mut appear_offsets = vec![0u32; internal.len() + 1];
        for &(k, _) in &keyed {
            appear_offsets[k as usize + 1] += 1;
        }
        for k in 0..internal.len() {
            appear_offsets[k + 1] += appear_offsets[k];
        }
        let triangles = keyed.into_iter().map(|(_, t)| t).collect();

        let flip = if inward { -1.0 } else { 1.0 };
        let internal_cone = internal
            .iter()
            .map(|x| {
                let axis = Vec3::from_slice(&x.cone) * flip;
                let cos = x.cone[3];
                if axis == Vec3::ZERO || cos <= 0.0 {
                    // Empty (no faces) or a hemisphere and more: never wholly back-facing.
                    return [Vec3::Z.x, Vec3::Z.y, Vec3::Z.z, f32::INFINITY];
                }
                let sin = (1.0 - cos * cos).max(0.0).sqrt() * (1.0 + BOUND_SLACK) + BOUND_SLACK;
                [axis.x, axis.y, axis.z, sin]
            })
            .collect();

        Hierarchy {
            leaf_count: n,
            position,
            parent,
            normal,
            color,
            internal_children,
            internal_error,
            internal_radius,
            internal_cone,
            internal_mid,
            leaf_rank,
            triangles,
            appear_offsets,
            depth,
            inward,
            diagonal: tree.diagonal(),
        }
    }

    pub fn node_count(&self) -> u32 {
        self.position.len() as u32
    }

    pub fn root(&self) -> u32 {
        self.node_count() - 1
    }

    pub fn is_leaf(&self, u: u32) -> bool {
        u < self.leaf_count
    }

    pub fn children(&self, u: u32) -> [u32; 2] {
        self.internal_children[(u - self.leaf_count) as usize]
    }

    /// Object-space error of a node; 0 for a leaf.
    pub fn error(&self, u: u32) -> f32 {
        if u < self.leaf_count {
            0.0
        } else {
            self.internal_error[(u - self.leaf_count) as usize]
        }
    }

    /// Bounding-sphere radius about the node's position; 0 for a leaf (never split, never tested).
    pub fn radius(&self, u: u32) -> f32 {
        if u < self.leaf_count {
            0.0
        } else {
            self.internal_radius[(u - self.leaf_count) as usize]
        }
    }

    /// The triangles that become non-degenerate when internal node `u` splits.
    pub fn appearing(&self, u: u32) -> std::ops::Range<u32> {
        let k = (u - self.leaf_count) as usize;
        self.appear_offsets[k]..self.appear_offsets[k + 1]
    }

    /// Which child of internal node `u` holds `leaf` (which must lie in `u`'s subtree).
    #[inline]
    pub fn child_toward(&self, u: u32, leaf: u32) -> u32 {
        let k = (u - self.leaf_count) as usize;
        let side = (self.leaf_rank[leaf as usize] >= self.internal_mid[k]) as usize;
        self.internal_children[k][side]
    }

    /// Heap bytes of the arrays above.
    pub fn bytes(&self) -> usize {
        use std::mem::size_of_val;
        size_of_val(&self.position[..])
            + size_of_val(&self.parent[..])
            + size_of_val(&self.normal[..])
            + size_of_val(&self.color[..])
            + size_of_val(&self.internal_children[..])
            + size_of_val(&self.internal_error[..])
            + size_of_val(&self.internal_radius[..])
            + size_of_val(&self.internal_cone[..])
            + size_of_val(&self.internal_mid[..])
            + size_of_val(&self.leaf_rank[..])
            + size_of_val(&self.triangles[..])
            + size_of_val(&self.appear_offsets[..])
            + size_of_val(&self.depth[..])
    }
}

/// Six times the signed volume enclosed by the triangles (positive when they wind counter-clockwise
/// seen from outside). Open meshes give a rough answer, which is all the orientation guess needs.
fn signed_volume(position: &[Vec3], triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| position[v as usize].as_dvec3());
            a.dot(b.cross(c))
        })
        .sum()
}

/// Marks the end of a list or a missing link.
pub const NIL: u32 = NONE;

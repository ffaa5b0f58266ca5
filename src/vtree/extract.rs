//! Static levels of detail taken from the tree: a *cut* (front) through it and the mesh it stands for.
//! This is the export of Chen's QEM report, and how the tree is compared with other simplifiers.

use super::VertexTree;
use crate::mesh::{Mesh, Part};
use glam::Vec3;

/// A front through the tree as a mesh: `nodes[i]` is the tree node behind vertex `i` of `mesh`.
#[derive(Clone, Debug)]
pub struct Cut {
    pub nodes: Vec<u32>,
    pub mesh: Mesh,
    /// Triangles dropped because, on this front, they were degenerate or repeated another (possible
    /// only for fronts that are not a prefix of the build order).
    pub dropped: usize,
}

/// The front where an internal node is split (its children are shown) exactly when `split(u)`. The
/// predicate must be closed upwards: a split node's parent is split.
pub fn cut_where(tree: &VertexTree, split: impl Fn(u32) -> bool) -> Cut {
    let count = tree.nodes.len();
    let n = tree.leaf_count;
    // rep[u]: the front node standing for u (u itself when u is on the front). Parents come after
    // children, so a reverse sweep sees each parent first.
    let mut rep = vec![u32::MAX; count];
    let mut index = vec![u32::MAX; count];
    let mut nodes = Vec::new();
    for u in (0..count as u32).rev() {
        let p = tree.nodes[u as usize].parent;
        let on_front = !(u >= n && split(u)) && (p == super::NONE || (p >= n && split(p)));
        // A split node's entry is never read: its children are on the front or below it.
        rep[u as usize] = if on_front || p == super::NONE {
            u
        } else {
            rep[p as usize]
        };
        if on_front {
            index[u as usize] = nodes.len() as u32;
            nodes.push(u);
        }
    }
    nodes.reverse();
    for (i, &u) in nodes.iter().enumerate() {
        index[u as usize] = i as u32;
    }
    let mut triangles = Vec::new();
    let mut seen = std::collections::HashSet::new();
    let mut dropped = 0;
    for u in n..count as u32 {
        if !split(u) {
            continue;
        }
        for t in tree.vanishing(u) {
            let c = t.map(|v| index[rep[v as usize] as usize]);
            let mut key = c;
            key.sort_unstable();
            if c[0] == c[1] || c[1] == c[2] || c[0] == c[2] || !seen.insert(key) {
                dropped += 1;
                continue;
            }
            triangles.push(c);
        }
    }
    let pick = |f: fn(&super::Node) -> Vec3| {
        nodes
            .iter()
            .map(|&u| f(&tree.nodes[u as usize]))
            .collect::<Vec<_>>()
    };
    let mesh = Mesh {
        positions: pick(|n| Vec3::from_array(n.position)),
        colors: tree.has_colors.then(|| pick(|n| Vec3::from_array(n.color))),
        normals: tree
            .has_normals
            .then(|| pick(|n| Vec3::from_array(n.normal))),
        radiosity: None,
        parts: vec![Part {
            name: "lod".into(),
            triangles: 0..triangles.len() as u32,
        }],
        triangles,
        unreferenced_vertices: 0,
        one_sided: tree.one_sided,
        uvs: tree.appearance.as_ref().map(|a| {
            nodes
                .iter()
                .map(|&u| glam::Vec2::from_array(a.uvs[u as usize]))
                .collect()
        }),
        texture_of: tree
            .appearance
            .as_ref()
            .map(|a| nodes.iter().map(|&u| a.texture_of[u as usize]).collect()),
        textures: tree
            .appearance
            .as_ref()
            .map_or_else(Vec::new, |a| a.textures.clone()),
        materials: tree
            .materials
            .as_ref()
            .map_or_else(Vec::new, |m| m.list.clone()),
        material_of: tree
            .materials
            .as_ref()
            .map(|m| nodes.iter().map(|&u| m.of[u as usize]).collect()),
    };
    Cut {
        nodes,
        mesh,
        dropped,
    }
}

/// The mesh after the first `merges` merges of the build (0: the input, `leaf_count − 1`: one vertex).
pub fn cut_at_merges(tree: &VertexTree, merges: u32) -> Cut {
    let first_unmerged = tree.leaf_count + merges.min(tree.internal_count());
    cut_where(tree, |u| u >= first_unmerged)
}

/// The build-order mesh with the most triangles not above `target`.
pub fn cut_at_triangles(tree: &VertexTree, target: u32) -> Cut {
    let total = tree.triangles.len() as u32;
    // After k merges, total − vanish_offsets[k] triangles remain; vanish_offsets is non-decreasing.
    let k = tree
        .vanish_offsets
        .partition_point(|&gone| total - gone > target);
    cut_at_merges(tree, k as u32)
}

/// The coarsest front whose every node's deviation bound ([`VertexTree::deviation_bounds`]) is at
/// most `bound` (object-space units): no point of the input surface is drawn farther than `bound`
/// from where it is (counting the edges and points that thin parts collapse to as drawn).
pub fn cut_at_bound(tree: &VertexTree, bound: f32) -> Cut {
    let bounds = tree.deviation_bounds();
    cut_where(tree, |u| bounds[u as usize] > bound)
}

/// The coarsest front whose every node has an error of at most `error` (object-space units).
pub fn cut_at_error(tree: &VertexTree, error: f32) -> Cut {
    cut_where(tree, |u| tree.nodes[u as usize].error > error)
}

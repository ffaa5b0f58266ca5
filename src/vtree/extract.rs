//! Static levels of detail taken from the tree: a *cut* (front) through it and the mesh it stands for.
//! This is the export of Chen's QEM report, and how the tree is compared with other simplifiers.

use super::VertexTree;
use crate::mesh::{Mesh, Part};
use glam::Vec3;

/// A front through the tree as a mesh: `nodes[i]` is the tree node behind vertex `i` of `mesh` (with
/// wedges, several vertices may share a node: one a wedge).
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
    // The tree's index of each kept triangle, for its wedges.
    let mut sources = Vec::new();
    for u in n..count as u32 {
        if !split(u) {
            continue;
        }
        let k = (u - n) as usize;
        let first = tree.vanish_offsets[k];
        for (i, t) in tree.vanishing(u).iter().enumerate() {
            let c = t.map(|v| index[rep[v as usize] as usize]);
            let mut key = c;
            key.sort_unstable();
            if c[0] == c[1] || c[1] == c[2] || c[0] == c[2] || !seen.insert(key) {
                dropped += 1;
                continue;
            }
            triangles.push(c);
            sources.push(first + i as u32);
        }
    }
    if let Some(w) = &tree.wedges {
        return wedge_cut(tree, w, &index, &sources, dropped);
    }
    let mesh = level_mesh(tree, &nodes, &nodes, None, triangles);
    Cut {
        nodes,
        mesh,
        dropped,
    }
}

/// A level's mesh: vertex `i` at node `nodes[i]`, with the appearance of entry `looks[i]` of the
/// wedges (when given) or of the tree's nodes.
fn level_mesh(
    tree: &VertexTree,
    nodes: &[u32],
    looks: &[u32],
    wedges: Option<&super::Wedges>,
    triangles: Vec<[u32; 3]>,
) -> Mesh {
    let pick = |f: fn(&super::Node) -> Vec3| {
        nodes
            .iter()
            .map(|&u| f(&tree.nodes[u as usize]))
            .collect::<Vec<_>>()
    };
    let each = |f: &dyn Fn(usize) -> u32| looks.iter().map(|&x| f(x as usize)).collect();
    let colors = || match wedges {
        Some(w) => looks
            .iter()
            .map(|&x| Vec3::from_array(w.color[x as usize]))
            .collect(),
        None => pick(|n| Vec3::from_array(n.color)),
    };
    Mesh {
        positions: pick(|n| Vec3::from_array(n.position)),
        colors: tree.has_colors.then(colors),
        normals: tree.has_normals.then(|| {
            let by_node = pick(|n| Vec3::from_array(n.normal));
            match wedges {
                Some(w) => looks
                    .iter()
                    .zip(by_node)
                    .map(|(&x, node)| {
                        let own = Vec3::from_array(w.normal[x as usize]);
                        if own == Vec3::ZERO { node } else { own }
                    })
                    .collect(),
                None => by_node,
            }
        }),
        radiosity: None,
        parts: vec![Part {
            name: "lod".into(),
            triangles: 0..triangles.len() as u32,
        }],
        triangles,
        unreferenced_vertices: 0,
        one_sided: tree.one_sided,
        uvs: tree.appearance.as_ref().map(|a| {
            looks
                .iter()
                .map(|&x| {
                    let uv = wedges.map_or(&a.uvs, |w| &w.uv)[x as usize];
                    glam::Vec2::from_array(uv)
                })
                .collect()
        }),
        texture_of: tree
            .appearance
            .as_ref()
            .map(|a| each(&|x| wedges.map_or(&a.texture_of, |w| &w.texture)[x])),
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
            .map(|m| each(&|x| wedges.map_or(&m.of, |w| &w.material)[x])),
        tints: wedges.filter(|w| !w.tint.is_empty()).map(|w| {
            looks
                .iter()
                .map(|&x| Vec3::from_array(w.tint[x as usize]))
                .collect()
        }),
    }
}

/// A cut of a tree with wedges: a vertex for each wedge its triangles' corners show (`sources`:
/// the tree's index of each triangle kept; `index`: each front node's vertex, `u32::MAX` off the
/// front), at its node's place with its own appearance.
fn wedge_cut(
    tree: &VertexTree,
    w: &super::Wedges,
    index: &[u32],
    sources: &[u32],
    dropped: usize,
) -> Cut {
    // Each wedge's wedge on the front (parents come after their children).
    let mut front = vec![super::NONE; w.len()];
    for x in (0..w.len()).rev() {
        let p = w.parent[x];
        front[x] = if index[w.node[x] as usize] != u32::MAX || p == super::NONE {
            x as u32
        } else {
            front[p as usize]
        };
    }
    let mut vertex = vec![u32::MAX; w.len()];
    let mut shown: Vec<u32> = Vec::new();
    let triangles: Vec<[u32; 3]> = sources
        .iter()
        .map(|&t| {
            w.corners[t as usize].map(|leaf| {
                let x = front[leaf as usize] as usize;
                if vertex[x] == u32::MAX {
                    vertex[x] = shown.len() as u32;
                    shown.push(x as u32);
                }
                vertex[x]
            })
        })
        .collect();
    let node_of: Vec<u32> = shown.iter().map(|&x| w.node[x as usize]).collect();
    let mesh = level_mesh(tree, &node_of, &shown, Some(w), triangles);
    Cut {
        nodes: node_of,
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

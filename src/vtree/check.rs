//! Invariant checks of a vertex tree, for tests and for `vunify info --check`. The file reader runs the
//! structural part ([`check`]) on everything it loads.

use super::{NONE, VertexTree};
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashSet;

/// What a tree [`check`] or [`check_cut`] found wrong: the first broken invariant, with the nodes
/// or triangles involved.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TreeProblem {
    #[error("the tree has no leaves")]
    NoLeaves,
    #[error("{nodes} nodes for {leaves} leaves: a binary tree with one root has {}", 2 * *leaves as u64 - 1)]
    NodeCount { nodes: usize, leaves: usize },
    #[error("node {0} has a non-finite or negative value")]
    BadValue(usize),
    #[error("leaf {0} has children")]
    LeafWithChildren(usize),
    #[error("node {node} has children {s}, {t}: they must be distinct and built before it")]
    BadChildren { node: usize, s: u32, t: u32 },
    #[error("node {child} is a child of {node} but names {parent} as its parent")]
    ChildNamesOtherParent {
        child: u32,
        node: usize,
        parent: u32,
    },
    #[error(
        "error decreases upwards: node {child} has {child_error} under node {node} with {error}"
    )]
    ErrorDecreases {
        child: u32,
        child_error: f32,
        node: usize,
        error: f32,
    },
    #[error("the sphere of node {node} does not contain that of its child {child}")]
    SphereMissesChild { node: usize, child: u32 },
    #[error("the sphere of node {0} does not contain its own position")]
    SphereMissesPosition(usize),
    #[error("the last node {node} must be the root, but has parent {parent}")]
    LastNotRoot { node: usize, parent: u32 },
    #[error("node {node} has parent {parent}: every node but the root has a later parent")]
    BadParent { node: usize, parent: u32 },
    #[error("the triangle groups do not tile the triangle list")]
    GroupsDoNotTile,
    #[error("triangle group offsets decrease")]
    GroupOffsetsDecrease,
    #[error("triangle {index} {corners:?} is not three distinct leaves")]
    BadTriangle { index: usize, corners: [u32; 3] },
    #[error("triangle {index} {corners:?} repeats another in the input")]
    RepeatedInput { index: usize, corners: [u32; 3] },
    #[error("triangle {triangle} is still on the front after its node {node}")]
    LiveAfterNode { triangle: u32, node: u32 },
    #[error("triangle {triangle} is degenerate after merge {merge} but vanishes only at {node}")]
    DegenerateEarly {
        triangle: u32,
        merge: usize,
        node: u32,
    },
    #[error("triangle {triangle} repeats another after merge {merge}")]
    RepeatedAfterMerge { triangle: u32, merge: usize },
    #[error(
        "triangle {triangle} vanishes at node {node} but is neither degenerate nor coincident there"
    )]
    VanishesWithoutCause { triangle: u32, node: usize },
    #[error(
        "node {node} lists {expected} vanishing triangles but {found} of them touch its children"
    )]
    VanishingCount {
        node: usize,
        expected: usize,
        found: usize,
    },
    #[error("the build does not end in one vertex without triangles")]
    DoesNotEnd,
    #[error("wedge {wedge}: {what}")]
    Wedge { wedge: usize, what: String },
}

/// Structure: one binary tree with one root, links consistent, indices in range, triangle groups
/// tiling the triangle list, finite numbers, errors never decreasing upwards, spheres nested.
pub fn check(tree: &VertexTree) -> Result<(), TreeProblem> {
    let n = tree.leaf_count as usize;
    let count = tree.nodes.len();
    if n == 0 {
        return Err(TreeProblem::NoLeaves);
    }
    if count != 2 * n - 1 {
        return Err(TreeProblem::NodeCount {
            nodes: count,
            leaves: n,
        });
    }
    // Nodes are checked in parallel runs; the first problem in node order is reported. Each node
    // reads its two children, scattered over the array: their records are requested a few nodes
    // ahead, so that the loads overlap (the check runs alongside every write of a tree).
    const RUN: usize = 16_384;
    const AHEAD: usize = 8;
    let problem = tree
        .nodes
        .par_chunks(RUN)
        .enumerate()
        .map(|(k, run)| {
            for (i, node) in run.iter().enumerate() {
                if let Some(next) = run.get(i + AHEAD) {
                    for c in next.children.into_iter().filter(|&c| c != NONE) {
                        if let Some(child) = tree.nodes.get(c as usize) {
                            crate::prefetch(&child.parent);
                            crate::prefetch(&child.sphere);
                        }
                    }
                }
                check_node(tree, k * RUN + i, node)?;
            }
            Ok(())
        })
        .find_first(Result::is_err);
    if let Some(problem) = problem {
        return problem;
    }
    let offsets = &tree.vanish_offsets;
    if offsets.len() != count - n + 1
        || offsets[0] != 0
        || *offsets.last().unwrap_or(&0) as usize != tree.triangles.len()
    {
        return Err(TreeProblem::GroupsDoNotTile);
    }
    if offsets.windows(2).any(|w| w[0] > w[1]) {
        return Err(TreeProblem::GroupOffsetsDecrease);
    }
    for (i, t) in tree.triangles.iter().enumerate() {
        if t.iter().any(|&v| v as usize >= n) || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            return Err(TreeProblem::BadTriangle {
                index: i,
                corners: *t,
            });
        }
    }
    match &tree.wedges {
        Some(w) => check_wedges(tree, w),
        None => Ok(()),
    }
}

/// Wedges: one array length for all, each wedge's node in range and its parent a wedge of the
/// node's parent (none at the root), every node with one wedge or more, colours and coordinates
/// finite, textures and materials in range, and each triangle corner's leaf wedge one of its
/// leaf's.
fn check_wedges(tree: &VertexTree, w: &super::Wedges) -> Result<(), TreeProblem> {
    let count = w.node.len();
    let bad = |wedge: usize, what: String| Err(TreeProblem::Wedge { wedge, what });
    if [
        w.parent.len(),
        w.uv.len(),
        w.texture.len(),
        w.material.len(),
        w.color.len(),
    ]
    .iter()
    .any(|&l| l != count)
        || !(w.tint.is_empty() || w.tint.len() == count)
        || w.corners.len() != tree.triangles.len()
    {
        return bad(
            0,
            "its arrays differ in length from each other or the triangles".into(),
        );
    }
    let textures = tree.appearance.as_ref().map_or(0, |a| a.textures.len());
    let materials = tree.materials.as_ref().map_or(1, |m| m.list.len());
    let mut has = vec![false; tree.nodes.len()];
    for i in 0..count {
        let u = w.node[i] as usize;
        let Some(node) = tree.nodes.get(u) else {
            return bad(i, format!("its node {u} is out of range"));
        };
        has[u] = true;
        let p = w.parent[i];
        let parent_ok = if node.parent == NONE {
            p == NONE
        } else {
            (p as usize) < count && w.node[p as usize] == node.parent
        };
        if !parent_ok {
            return bad(
                i,
                format!("its parent {p} is not a wedge of node {u}'s parent"),
            );
        }
        let texture = w.texture[i];
        if (texture as usize >= textures && texture != crate::mesh::NO_TEXTURE)
            || w.material[i] as usize >= materials
            || !w.uv[i]
                .iter()
                .chain(&w.color[i])
                .chain(&w.normal[i])
                .all(|x| x.is_finite())
        {
            return bad(
                i,
                "its texture, material, coordinates, colour or normal are invalid".into(),
            );
        }
    }
    if let Some(u) = has.iter().position(|h| !h) {
        return bad(count, format!("node {u} has no wedge"));
    }
    for (t, (corners, leaves)) in w.corners.iter().zip(&tree.triangles).enumerate() {
        for (&c, &leaf) in corners.iter().zip(leaves) {
            if w.node.get(c as usize) != Some(&leaf) {
                return bad(
                    c as usize,
                    format!("triangle {t}'s corner at leaf {leaf} names it"),
                );
            }
        }
    }
    Ok(())
}

/// [`check`]'s invariants of node `u` itself and of its links to its children and parent.
fn check_node(tree: &VertexTree, u: usize, node: &super::Node) -> Result<(), TreeProblem> {
    let (n, count) = (tree.leaf_count as usize, tree.nodes.len());
    let finite = node
        .position
        .iter()
        .chain(&node.color)
        .chain(&node.normal)
        .chain(&node.sphere)
        .chain(&node.cone)
        .all(|x| x.is_finite());
    if !finite || !node.error.is_finite() || node.error < 0.0 || node.sphere[3] < 0.0 {
        return Err(TreeProblem::BadValue(u));
    }
    if u < n {
        if node.children != [NONE, NONE] {
            return Err(TreeProblem::LeafWithChildren(u));
        }
    } else {
        let [s, t] = node.children;
        if s == t || s as usize >= u || t as usize >= u {
            return Err(TreeProblem::BadChildren { node: u, s, t });
        }
        for c in [s, t] {
            let child = &tree.nodes[c as usize];
            if child.parent as usize != u {
                return Err(TreeProblem::ChildNamesOtherParent {
                    child: c,
                    node: u,
                    parent: child.parent,
                });
            }
            if child.error > node.error {
                return Err(TreeProblem::ErrorDecreases {
                    child: c,
                    child_error: child.error,
                    node: u,
                    error: node.error,
                });
            }
            let (cu, cc) = (
                Vec3::from_slice(&node.sphere),
                Vec3::from_slice(&child.sphere),
            );
            let slack = 1e-5 * (node.sphere[3] + cu.abs().max_element() + 1e-6);
            if crate::mesh::diagonal_of(cu - cc) + child.sphere[3] > node.sphere[3] + slack {
                return Err(TreeProblem::SphereMissesChild { node: u, child: c });
            }
        }
        if !node.sphere_contains(node.position()) {
            return Err(TreeProblem::SphereMissesPosition(u));
        }
    }
    // That each parent lists its child follows from the rest, so it is not read (it would be
    // a second random access per node, half of this check's time on large trees): the
    // `count − 1` child links, each confirmed by its child's parent, name `count − 1` distinct
    // children (a child named twice would have two parents), all before the last node. So
    // every node but the root is the child of exactly the parent it names.
    let p = node.parent;
    if u + 1 == count {
        if p != NONE {
            return Err(TreeProblem::LastNotRoot { node: u, parent: p });
        }
    } else if p == NONE || p as usize <= u || p as usize >= count {
        return Err(TreeProblem::BadParent { node: u, parent: p });
    }
    Ok(())
}

impl super::Node {
    fn sphere_contains(&self, p: Vec3) -> bool {
        let c = Vec3::from_slice(&self.sphere);
        crate::mesh::diagonal_of(c - p)
            <= self.sphere[3] * (1.0 + 1e-5) + 1e-6 * (1.0 + c.abs().max_element())
    }
}

/// Replays the build order and checks every cut along it: each triangle vanishes exactly at its node
/// (degenerate there, or coincident with a surviving triangle) and, until then, is neither degenerate
/// nor a repeat of another triangle; at the end one vertex and no triangle are left.
pub fn check_cut(tree: &VertexTree) -> Result<(), TreeProblem> {
    check(tree)?;
    let n = tree.leaf_count as usize;
    let count = tree.nodes.len();
    // The node whose merge makes each triangle vanish.
    let mut vanish_node = vec![0u32; tree.triangles.len()];
    for k in 0..count - n {
        for i in tree.vanish_offsets[k]..tree.vanish_offsets[k + 1] {
            vanish_node[i as usize] = (n + k) as u32;
        }
    }
    // The front: parent-pointer forest over current nodes (path-compressed on lookup).
    let mut up: Vec<u32> = vec![NONE; count];
    let find = |up: &mut Vec<u32>, v: u32| {
        let mut r = v;
        while up[r as usize] != NONE {
            r = up[r as usize];
        }
        let mut x = v;
        while up[x as usize] != NONE {
            let next = up[x as usize];
            up[x as usize] = r;
            x = next;
        }
        r
    };
    let mut around: Vec<Vec<u32>> = vec![Vec::new(); count];
    let mut keys: HashSet<[u32; 3]> = HashSet::with_capacity(tree.triangles.len());
    for (i, t) in tree.triangles.iter().enumerate() {
        let mut k = *t;
        k.sort_unstable();
        if !keys.insert(k) {
            return Err(TreeProblem::RepeatedInput {
                index: i,
                corners: *t,
            });
        }
        for &v in t {
            around[v as usize].push(i as u32);
        }
    }
    let mut alive = vec![true; tree.triangles.len()];
    let mut live_vertices = n;
    for u in n..count {
        let [s, t] = tree.nodes[u].children;
        let mut touched = std::mem::take(&mut around[s as usize]);
        touched.append(&mut around[t as usize]);
        touched.sort_unstable();
        touched.dedup();
        touched.retain(|&f| alive[f as usize]);
        let key_of = |up: &mut Vec<u32>, f: u32| {
            let mut k = tree.triangles[f as usize].map(|v| find(up, v));
            k.sort_unstable();
            k
        };
        for &f in &touched {
            let k = key_of(&mut up, f);
            keys.remove(&k);
        }
        up[s as usize] = u as u32;
        up[t as usize] = u as u32;
        live_vertices -= 1;
        // Survivors first, so that a coincident vanishing triangle finds its survivor in `keys`.
        for &f in &touched {
            if vanish_node[f as usize] as usize != u {
                if (vanish_node[f as usize] as usize) < u {
                    return Err(TreeProblem::LiveAfterNode {
                        triangle: f,
                        node: vanish_node[f as usize],
                    });
                }
                let k = key_of(&mut up, f);
                if k[0] == k[1] || k[1] == k[2] {
                    return Err(TreeProblem::DegenerateEarly {
                        triangle: f,
                        merge: u,
                        node: vanish_node[f as usize],
                    });
                }
                if !keys.insert(k) {
                    return Err(TreeProblem::RepeatedAfterMerge {
                        triangle: f,
                        merge: u,
                    });
                }
            }
        }
        let mut vanished = 0;
        for &f in &touched {
            if vanish_node[f as usize] as usize == u {
                let k = key_of(&mut up, f);
                if !(k[0] == k[1] || k[1] == k[2] || keys.contains(&k)) {
                    return Err(TreeProblem::VanishesWithoutCause {
                        triangle: f,
                        node: u,
                    });
                }
                alive[f as usize] = false;
                vanished += 1;
            }
        }
        let expected = (tree.vanish_offsets[u - n + 1] - tree.vanish_offsets[u - n]) as usize;
        if vanished != expected {
            return Err(TreeProblem::VanishingCount {
                node: u,
                expected,
                found: vanished,
            });
        }
        let keep: Vec<u32> = touched.into_iter().filter(|&f| alive[f as usize]).collect();
        around[u] = keep;
    }
    if live_vertices != 1 || alive.iter().any(|&a| a) {
        return Err(TreeProblem::DoesNotEnd);
    }
    Ok(())
}

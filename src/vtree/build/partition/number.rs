//! Numbering a partitioned build's nodes into one tree.

use super::Ref;
use super::spill::Spilled;
use crate::mesh::Mesh;
use crate::vtree::build::NONE;
use crate::vtree::build::geometry_tree;
use crate::vtree::build::{BuildError, BuildOptions};
use crate::vtree::{Node, VertexTree};
use rustc_hash::FxHashMap as HashMap;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// The tree: `leaf_nodes` (the input's vertices), then the levels' nodes (`levels`, on disk) level
/// by level, each level's interleaved by error (each cell's in the order it made them), read one
/// record of each cell at a time.
pub(super) fn number(
    mesh: &Mesh,
    options: &BuildOptions,
    leaf_nodes: Vec<Node>,
    spilled: Vec<Spilled>,
) -> Result<VertexTree, BuildError> {
    let total: usize = spilled.iter().map(|m| m.count as usize).sum();
    // Each cell's nodes' numbers, known as they are numbered: a node's children are made in its
    // cell or below it, so they are numbered before it.
    let mut number: HashMap<u32, Vec<u32>> = spilled
        .iter()
        .map(|m| (m.cell, vec![NONE; m.count as usize]))
        .collect();
    let mut nodes = leaf_nodes;
    nodes.reserve_exact(total);
    let mut triangles = Vec::with_capacity(mesh.triangles.len());
    let mut vanish_offsets = Vec::with_capacity(total + 1);
    vanish_offsets.push(0);
    for level in levels(&spilled) {
        // Each cell's next record and how many it has read; the heap orders them by error (the
        // cell and index break ties), which is [`level_order`]'s merge, one record at a time.
        let mut readers = Vec::with_capacity(level.len());
        let mut heads = BinaryHeap::new();
        for (j, &i) in level.iter().enumerate() {
            let mut reader = spilled[i as usize].read()?;
            if let Some(record) = reader.next()? {
                heads.push(Reverse((record.node.error.to_bits(), i, 0u32, j)));
                readers.push((reader, Some(record)));
            } else {
                readers.push((reader, None));
            }
        }
        while let Some(Reverse((_, i, k, j))) = heads.pop() {
            let (reader, head) = &mut readers[j];
            let record = head.take().expect("a head for each cell in the heap");
            let cell = spilled[i as usize].cell;
            let u = nodes.len() as u32;
            let resolve = |r: Ref| match r.as_leaf() {
                Some(v) => v,
                None => {
                    let (cell, k) = r.cell_and_index();
                    number.get(&cell).map_or(NONE, |l| l[k as usize])
                }
            };
            let mut node = record.node;
            node.children = record.children.map(resolve);
            node.parent = NONE;
            for c in node.children {
                nodes[c as usize].parent = u;
            }
            nodes.push(node);
            triangles.extend(record.vanished.iter().map(|&f| mesh.triangles[f as usize]));
            vanish_offsets.push(triangles.len() as u32);
            if let Some(list) = number.get_mut(&cell) {
                list[k as usize] = u;
            }
            if let Some(next) = reader.next()? {
                heads.push(Reverse((next.node.error.to_bits(), i, k + 1, j)));
                *head = Some(next);
            }
        }
    }
    Ok(geometry_tree(
        mesh,
        options,
        nodes,
        triangles,
        vanish_offsets,
    ))
}

/// The levels' files (indices into `spilled`) level by level, lowest first, each level's in cell
/// order.
///
/// Within a level the cells' nodes are interleaved by error, each cell's in the order it made
/// them. Every triangle's merges lie in the cells on the path from its leaf cell to the root,
/// whose order this keeps (levels one after another), so each cut of this order is a cut the
/// cells themselves passed through, side by side. (A freer order, cheapest first among the nodes
/// whose children are numbered, was tried: it lets a higher level's merge come before a lower
/// one's that it was priced after, and some cuts then hold a triangle twice.)
fn levels(spilled: &[Spilled]) -> Vec<Vec<u32>> {
    let mut by_level: Vec<u32> = (0..spilled.len() as u32).collect();
    by_level.sort_by_key(|&i| (spilled[i as usize].height, spilled[i as usize].cell));
    by_level
        .chunk_by(|&a, &b| spilled[a as usize].height == spilled[b as usize].height)
        .map(<[u32]>::to_vec)
        .collect()
}

//! Numbering a partitioned build's nodes into one tree.

use super::{Made, Ref, Shared};
use crate::vtree::VertexTree;
use crate::vtree::build::NONE;
use crate::vtree::build::part_infos;
use rustc_hash::FxHashMap as HashMap;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

impl Shared<'_> {
    /// The tree: the leaves, then the cells' nodes level by level, each level's interleaved by
    /// error (each cell's in the order it made them).
    pub(super) fn number(&self, made: Vec<Made>) -> VertexTree {
        let leaf_count = self.mesh.positions.len() as u32;
        let order = build_order(&made);
        // Each cell's nodes' numbers.
        let mut number: HashMap<u32, Vec<u32>> = made
            .iter()
            .map(|m| (m.cell, vec![NONE; m.nodes.len()]))
            .collect();
        for (j, &(i, k)) in order.iter().enumerate() {
            let cell = made[i as usize].cell;
            if let Some(list) = number.get_mut(&cell) {
                list[k as usize] = leaf_count + j as u32;
            }
        }
        let resolve = |r: Ref| match r.as_leaf() {
            Some(v) => v,
            None => {
                let (cell, k) = r.cell_and_index();
                number.get(&cell).map_or(NONE, |l| l[k as usize])
            }
        };
        let mut nodes = self.leaf_nodes.clone();
        nodes.reserve(order.len());
        let mut triangles = Vec::with_capacity(self.mesh.triangles.len());
        let mut vanish_offsets = Vec::with_capacity(order.len() + 1);
        vanish_offsets.push(0);
        for &(i, k) in &order {
            let m = &made[i as usize];
            let k = k as usize;
            let mut node = m.nodes[k];
            node.children = m.children[k].map(resolve);
            node.parent = NONE;
            let u = nodes.len() as u32;
            for c in node.children {
                nodes[c as usize].parent = u;
            }
            nodes.push(node);
            let gone = &m.vanished[m.offsets[k] as usize..m.offsets[k + 1] as usize];
            triangles.extend(gone.iter().map(|&f| self.mesh.triangles[f as usize]));
            vanish_offsets.push(triangles.len() as u32);
        }
        VertexTree {
            leaf_count,
            nodes,
            triangles,
            vanish_offsets,
            metric: self.options.metric,
            has_colors: self.mesh.colors.is_some(),
            has_normals: self.mesh.normals.is_some(),
            one_sided: self.mesh.one_sided,
            appearance: None,
            materials: None,
            wedges: None,
            position_error: 0.0,
            parts: part_infos(self.mesh),
        }
    }
}

/// The order in which the tree numbers the cells' nodes, as (index into `made`, k): level by
/// level (a kd-tree node's after all of its descendants'), and within a level the cells' nodes
/// interleaved by error, each cell's in the order it made them.
///
/// Every triangle's merges lie in the cells on the path from its leaf cell to the root, whose
/// order this keeps, so each cut of this order is a cut the cells themselves passed through, side
/// by side. (A freer order, cheapest first among the nodes whose children are numbered, was
/// tried: it lets a higher level's merge come before a lower one's that it was priced after, and
/// some cuts then hold a triangle twice.)
fn build_order(made: &[Made]) -> Vec<(u32, u32)> {
    let mut by_level: Vec<u32> = (0..made.len() as u32).collect();
    by_level.sort_by_key(|&i| (made[i as usize].height, made[i as usize].cell));
    let mut order = Vec::with_capacity(made.iter().map(|m| m.nodes.len()).sum());
    for level in by_level.chunk_by(|&a, &b| made[a as usize].height == made[b as usize].height) {
        let key =
            |i: u32, k: u32| Reverse((made[i as usize].nodes[k as usize].error.to_bits(), i, k));
        let mut heads: BinaryHeap<_> = level
            .iter()
            .filter(|&&i| !made[i as usize].nodes.is_empty())
            .map(|&i| key(i, 0))
            .collect();
        while let Some(Reverse((_, i, k))) = heads.pop() {
            order.push((i, k));
            if (k as usize + 1) < made[i as usize].nodes.len() {
                heads.push(key(i, k + 1));
            }
        }
    }
    order
}

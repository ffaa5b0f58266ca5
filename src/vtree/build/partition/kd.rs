//! The kd-tree of a partitioned build's cells: the triangles split at the median of their
//! centroids until each cell is small enough, and which cells each vertex's triangles lie in.

use crate::mesh::Mesh;
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::Ordering;

/// A kd-tree node: its triangles (a range of [`Split::order`]), its leaf cells, its children.
pub(super) struct KdNode {
    pub(super) triangles: Range<usize>,
    pub(super) cells: Range<u32>,
    pub(super) children: Option<[u32; 2]>,
    /// 0 for a cell; one more than the higher child otherwise.
    pub(super) height: u32,
}

/// The kd-tree over the triangles' centroids.
pub(super) struct Split {
    /// Triangle indices, each cell's a contiguous run.
    pub(super) order: Vec<u32>,
    pub(super) nodes: Vec<KdNode>,
    pub(super) root: u32,
}

impl Split {
    pub(super) fn new(mesh: &Mesh, cell_triangles: usize) -> Split {
        let centroids: Vec<Vec3> = mesh
            .triangles
            .par_iter()
            .map(|t| t.iter().map(|&v| mesh.positions[v as usize]).sum::<Vec3>() / 3.0)
            .collect();
        let mut order: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
        let nodes = split(&mut order, 0, &centroids, cell_triangles.max(1));
        let root = nodes.len() as u32 - 1;
        Split { order, nodes, root }
    }

    /// The deepest kd-tree node whose cells include `cells`.
    pub(super) fn holding(&self, cells: Range<u32>) -> u32 {
        let mut at = self.root;
        'down: loop {
            if let Some(children) = self.nodes[at as usize].children {
                for c in children {
                    let span = &self.nodes[c as usize].cells;
                    if span.start <= cells.start && cells.end <= span.end {
                        at = c;
                        continue 'down;
                    }
                }
            }
            return at;
        }
    }
}

/// Splits `order` (the triangles at `start..` of the whole order) at the median centroid along
/// the longest axis of their centroids' box until each part holds at most `cell` triangles, the
/// halves at once. Returns the kd-tree's nodes, each subtree's before its root (the root last),
/// its cells numbered from 0 left to right.
fn split(order: &mut [u32], start: usize, centroids: &[Vec3], cell: usize) -> Vec<KdNode> {
    let len = order.len();
    if len <= cell {
        return vec![KdNode {
            triangles: start..start + len,
            cells: 0..1,
            children: None,
            height: 0,
        }];
    }
    let (lo, hi) = order
        .par_iter()
        .fold(
            || (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &t| (lo.min(centroids[t as usize]), hi.max(centroids[t as usize])),
        )
        .reduce(
            || (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
    let extent = hi - lo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = len / 2;
    order.select_nth_unstable_by(mid, |&a, &b| {
        centroids[a as usize][axis]
            .total_cmp(&centroids[b as usize][axis])
            .then(a.cmp(&b))
    });
    let (left, right) = order.split_at_mut(mid);
    let (mut nodes, right) = rayon::join(
        || split(left, start, centroids, cell),
        || split(right, start + mid, centroids, cell),
    );
    let (offset, cells) = (nodes.len() as u32, nodes[nodes.len() - 1].cells.end);
    nodes.extend(right.into_iter().map(|k| KdNode {
        cells: k.cells.start + cells..k.cells.end + cells,
        children: k.children.map(|c| c.map(|i| i + offset)),
        ..k
    }));
    let (l, r) = (offset - 1, nodes.len() as u32 - 1);
    let (lc, rc) = (&nodes[l as usize], &nodes[r as usize]);
    let node = KdNode {
        triangles: start..start + len,
        cells: 0..rc.cells.end,
        children: Some([l, r]),
        height: 1 + lc.height.max(rc.height),
    };
    nodes.push(node);
    nodes
}

/// Each vertex's lowest and highest cell, of the triangles around it (`(u32::MAX, 0)` for a vertex
/// of no triangle), the cells at once.
pub(super) fn cell_ranges(mesh: &Mesh, split: &Split) -> Vec<(u32, u32)> {
    use std::sync::atomic::AtomicU32;
    let n = mesh.positions.len();
    let lo: Vec<AtomicU32> = (0..n).map(|_| AtomicU32::new(u32::MAX)).collect();
    let hi: Vec<AtomicU32> = (0..n).map(|_| AtomicU32::new(0)).collect();
    split
        .nodes
        .par_iter()
        .filter(|k| k.children.is_none())
        .for_each(|node| {
            let c = node.cells.start;
            for &t in &split.order[node.triangles.clone()] {
                for v in mesh.triangles[t as usize] {
                    lo[v as usize].fetch_min(c, Ordering::Relaxed);
                    hi[v as usize].fetch_max(c, Ordering::Relaxed);
                }
            }
        });
    lo.into_iter()
        .zip(hi)
        .map(|(l, h)| (l.into_inner(), h.into_inner()))
        .collect()
}

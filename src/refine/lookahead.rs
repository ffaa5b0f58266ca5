//! The look-ahead: while the per-frame visit is at front-list position `cursor`, ask the memory
//! system for what the visits a few dozen positions ahead will read, so that their loads overlap
//! with this visit's work instead of queueing after it.
//!
//! # Why it exists, and why it is this small
//! A frame's visit walks the front list (in memory order, mostly) and reads, per node, its
//! position, view data and parent. With the rasteriser running between frames none of that is in
//! cache: without hints each visit waits on a load from memory. Measured in one sitting on
//! 2026-12-01 with the product's own command, `vunify render dragon.vtree --path fly.json --size
//! 1920x1080 --tau 1` (the dragon's fly-in), three alternations, per-frame refine time from
//! `stats.csv` as median / p95 of each run:
//!
//! | hints | refine ms (median / p95) |
//! |---|---|
//! | none | 6.10 / 9.29, 5.81 / 8.82, 6.04 / 8.80 |
//! | **the visit's data (this module)** | **2.63 / 3.92, 2.36 / 4.00, 2.37 / 4.00** |
//! | + view tests decided ahead, the operation's list heads asked for | 2.60 / 3.87, 2.63 / 3.84, 2.62 / 3.73 |
//! | + sixteen stages along the operation's triangle lists | 2.69 / 3.86, 2.83 / 3.90, 2.60 / 4.09 |
//!
//! The visit's own data halves the frame's refinement time; the later stages, which earlier
//! sessions tuned for operations per second in a warm benchmark, did not move the frame and were
//! deleted.
//!
//! # The distances
//! A visit takes ~40 ns and a load from memory ~150 ns here. The parent's data needs the parent's
//! id, which the first hint loads, so it is asked for ten visits later; both are far enough ahead
//! that the loads have arrived when the cursor comes.

use super::hierarchy::{Hierarchy, NIL};

/// Visits ahead at which a node's own data is asked for.
const VISIT_AHEAD: usize = 72;
/// Visits ahead at which its parent's data is asked for (after the parent id has arrived).
const PARENT_AHEAD: usize = 62;

/// Asks for what the visits ahead of `cursor` in the front `list` will read. Only a hint: it
/// changes no result.
#[inline]
pub(crate) fn prefetch_ahead(h: &Hierarchy, list: &[u32], cursor: usize) {
    if let Some(&v) = list.get(cursor + VISIT_AHEAD) {
        prefetch_visit(h, v, false);
    }
    if let Some(&v) = list.get(cursor + PARENT_AHEAD) {
        prefetch_visit(h, v, true);
    }
}

/// What visiting front node `u` reads — its position, view data and parent — or, at the `parent`
/// stage, what weighing its parent for a unify reads.
#[inline]
fn prefetch_visit(h: &Hierarchy, u: u32, parent: bool) {
    let n = h.leaf_count;
    let node = if parent { h.parent[u as usize] } else { u };
    if node == NIL {
        return;
    }
    crate::prefetch(&h.position[node as usize]);
    if node >= n {
        crate::prefetch(&h.internal_bounds[(node - n) as usize]);
        // A split of the node, or the unify test of the parent, reads its structure.
        crate::prefetch(&h.internal[(node - n) as usize]);
    }
    if !parent {
        crate::prefetch(&h.parent[u as usize]);
    }
}

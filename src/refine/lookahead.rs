//! The look-ahead: work done some front-list positions ahead of the per-frame visit, so that the
//! loads of the visits and operations to come overlap with this one's work instead of queueing
//! after it.
//!
//! # Why it exists
//! A frame's visit walks the front list (in memory order, mostly) and reads, per node, its
//! position, view data and parent; an operation then walks linked lists of triangle records
//! scattered through memory. With the rasteriser running between frames none of that is in cache:
//! each visit would wait ~150 ns per load, each operation for a chain of them. Measured in one
//! sitting on 2026-12-01 with the product's own command (the dragon's fly-in, `vunify render
//! dragon.vtree --path fly.json --size 1920x1080 --tau 1`, five alternations, median of each run's
//! per-frame refine time in `stats.csv`):
//!
//! | look-ahead | refine median | refine p95 |
//! |---|---|---|
//! | all stages (kept) | 2.32–2.53 ms | 3.60–4.59 ms |
//! | none | 4.55–5.88 ms | 7.61–8.86 ms |
//!
//! so it halves the per-frame refinement time a user meets. (The stages are compared in
//! BENCHMARKS.md.)
//!
//! # The stages, in visits ahead of the cursor
//! A visit takes ~40 ns and a load from memory ~150 ns here, so each stage comes a few visits after
//! the one whose loads it needs:
//! 1. `VISIT_AHEAD`: the visit's own data; `PARENT_AHEAD`: its parent's (which needs the parent
//!    id the first stage loaded).
//! 2. `DECIDE_AHEAD`: the view tests are decided early (they depend only on the node and the view,
//!    so the decision holds when the visit comes; the front's state, which can change meanwhile,
//!    is checked then), and for a split or unify the states, list heads and appearing triangles it
//!    will touch are asked for (`Front::prefetch_split` / `prefetch_unify`).
//! 3. `RECORDS_AHEAD`: the records around the node, one hop along its lists per stage
//!    (`Front::prefetch_lists`): a list is a pointer chase, which no single prefetch covers. Sixteen
//!    stages three visits apart cover lists of up to sixteen records (an operation walks about two
//!    dozen, in one or two lists) with a hop's load time between stages.
//!
//! Everything here is a hint: it changes no result (the tests run the same walks with and
//! without it), only when memory arrives.

use super::front::Front;
use super::hierarchy::{Hierarchy, NIL};

const VISIT_AHEAD: usize = 72;
const PARENT_AHEAD: usize = 62;
const DECIDE_AHEAD: usize = 52;
const RECORDS_AHEAD: [usize; 16] = [49, 46, 43, 40, 37, 34, 31, 28, 25, 22, 19, 16, 13, 10, 7, 4];
/// Decisions made ahead, by list position modulo this (a power of two above `DECIDE_AHEAD`).
const RING: usize = 64;

/// What the view tests ask of an active node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Decision {
    pub(crate) node: u32,
    /// Split the node.
    pub(crate) split: bool,
    /// Unify its parent (weighed from the first child only: the second would ask the same);
    /// `None` when not weighed because the parent could not unify then (its second child was not
    /// on the front), which the visit checks again.
    pub(crate) unify_parent: Option<bool>,
}

impl Decision {
    fn wants_operation(&self) -> bool {
        self.split || self.unify_parent == Some(true)
    }
}

const UNDECIDED: Decision = Decision {
    node: NIL,
    split: false,
    unify_parent: Some(false),
};

/// The look-ahead's state within a frame.
pub(crate) struct LookAhead {
    /// Decisions made ahead of the cursor, by list position modulo `RING`.
    ahead: [Decision; RING],
    /// The list position of the last decision made ahead that asks for an operation: until the
    /// cursor passes it, visits prefetch along its lists.
    operation_ahead: usize,
}

impl LookAhead {
    pub(crate) fn new() -> LookAhead {
        LookAhead {
            ahead: [UNDECIDED; RING],
            operation_ahead: 0,
        }
    }

    /// Forgets every decision: they hold for one frame's view only.
    pub(crate) fn reset(&mut self) {
        *self = LookAhead::new();
    }

    /// The cursor went back to the start of the list.
    pub(crate) fn restart(&mut self) {
        self.operation_ahead = 0;
    }

    /// The decision made ahead for `u` at list position `cursor`, if one was.
    pub(crate) fn decision(&self, cursor: usize, u: u32) -> Option<Decision> {
        let d = self.ahead[cursor % RING];
        (d.node == u).then_some(d)
    }

    /// Works ahead of `cursor` in the front list: prefetches, and decisions by `decide`. The front
    /// list changes only at the cursor and at its end, so the entries ahead stay where they are
    /// until the cursor reaches them.
    pub(crate) fn run(
        &mut self,
        h: &Hierarchy,
        front: &Front,
        cursor: usize,
        decide: impl Fn(u32) -> Decision,
    ) {
        let list = front.list();
        let at = |i: usize| list.get(cursor + i).copied();
        if let Some(v) = at(VISIT_AHEAD) {
            prefetch_visit(h, v, false);
        }
        if let Some(v) = at(PARENT_AHEAD) {
            prefetch_visit(h, v, true);
        }
        if let Some(v) = at(DECIDE_AHEAD) {
            let slot = (cursor + DECIDE_AHEAD) % RING;
            // (A node that has left the front gets a decision too: its entry is dropped unused.)
            if self.ahead[slot].node != v {
                let d = decide(v);
                if d.split {
                    front.prefetch_split(h, v);
                } else if d.unify_parent == Some(true) {
                    front.prefetch_unify(h, h.parent[v as usize]);
                }
                if d.wants_operation() {
                    self.operation_ahead = cursor + DECIDE_AHEAD;
                }
                self.ahead[slot] = d;
            }
        }
        if self.operation_ahead <= cursor {
            return;
        }
        for (hop, ahead) in RECORDS_AHEAD.into_iter().enumerate() {
            let Some(v) = at(ahead) else { continue };
            let d = self.ahead[(cursor + ahead) % RING];
            if d.node != v {
                continue;
            }
            if hop == RECORDS_AHEAD.len() - 1 && d.wants_operation() {
                front.prefetch_scratch(!d.split);
            }
            if d.split {
                front.prefetch_lists(h, &[v], hop, true);
            } else if d.unify_parent == Some(true) {
                front.prefetch_lists(h, &h.children(h.parent[v as usize]), hop, false);
            }
        }
    }
}

/// What visiting front node `u` reads — its position, view data and parent — or, at the `parent`
/// stage (which needs the first one's load of the parent id), what weighing its parent for a unify
/// reads.
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

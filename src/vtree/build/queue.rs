//! The candidate pairs as the schedules hold them: a cost key and two slots, with flags.

use std::cmp::Ordering;

// Flags in the high bits of a queued pair's `b`.
pub(super) const NO_EDGE: u32 = 1 << 31;
pub(super) const PENALIZED: u32 = 1 << 30;
pub(super) const SLOT: u32 = PENALIZED - 1;

/// Greedy schedule: a merge that would flip a triangle costs this many times more, plus a quarter of its
/// squared length (a fold moves the surface by about that much), when it comes round again.
pub(super) const FLIP_PENALTY: f64 = 10.0;

/// A priced pair. `cost` is `f32::to_bits` of a non-negative cost: for those, integer order is
/// numeric order, and integer compares keep sorting and the heap cheap.
#[derive(Clone, Copy, Debug)]
pub(super) struct Entry {
    pub(super) cost: u32,
    pub(super) a: u32,
    pub(super) b: u32,
}

/// A pair in the greedy schedule's queue, ordered as its entry: valid while neither slot changed
/// after merge number `created`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Queued {
    pub(super) entry: Entry,
    pub(super) created: u32,
}

impl PartialOrd for Queued {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Queued {
    fn cmp(&self, o: &Self) -> Ordering {
        self.entry.cmp(&o.entry)
    }
}

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    /// Reversed: `BinaryHeap` is a max-heap and the cheapest pair must come first. Ties break on the
    /// slots so that builds are deterministic.
    fn cmp(&self, o: &Self) -> Ordering {
        o.cost
            .cmp(&self.cost)
            .then(o.a.cmp(&self.a))
            .then(o.b.cmp(&self.b))
    }
}

/// The queue key of a cost (see [`Entry::cost`]); NaN, which a finite mesh never produces, sorts last.
pub(super) fn key(cost: f64) -> u32 {
    let c = cost as f32;
    if c >= 0.0 {
        c.to_bits()
    } else if c.is_nan() {
        u32::MAX
    } else {
        0
    }
}

/// The queue key of a merge deferred because it would flip a triangle: [`FLIP_PENALTY`] times its
/// cost plus a quarter of its squared length `gap2` (a fold moves the surface by about that much).
/// Both schedules defer this way.
pub(super) fn penalized_key(cost: f64, gap2: f64) -> u32 {
    key(FLIP_PENALTY * cost + 0.25 * gap2)
}

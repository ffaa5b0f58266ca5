//! The front as the per-frame visit reads it: one entry per active node, in the order of their
//! leaves, each holding what the view tests read of the node *and of its parent*, so that a frame's
//! visit is one walk along one array.
//!
//! # Why
//! With the rasteriser running between frames, nothing of the hierarchy is in cache when a frame
//! starts. A visit that reads a node's position, bounds and parent from the hierarchy's arrays, and
//! the parent's bounds and children, waits on memory several times per node, even with the reads
//! asked for ahead: on the dragon's fly-in that was ~130 ns a node, 2.4 ms a frame. An entry here
//! is one cache line, and the walk is sequential, which the hardware prefetcher follows on its own.
//!
//! # The order
//! Leaves are numbered depth-first, so every node's leaves are a range, and the active nodes' ranges
//! tile the leaves. In that order a node's children are neighbours: a split replaces an entry by
//! its two children in place, a unify replaces two neighbouring siblings by their parent. Each
//! sweep therefore rewrites the array as a stream: entries are read ahead of where they are written
//! back, split children are visited as they appear, and a parent whose two children have both been
//! written is weighed for a unify against the last entry written.
//!
//! # One array, not two
//! The entries read and those written share one buffer: before a sweep the unread part moves to the
//! buffer's end, leaving a gap that the writes fill (split children grow it; the buffer grows if the
//! gap closes). Two buffers would save that move (~50 µs for the dragon's front), at twice the
//! memory.

use super::criteria::{NodeView, Tests};
use super::front::Front;
use super::hierarchy::{Hierarchy, NIL};

/// One active node and what a visit reads: its view data (unused for leaves, which never split)
/// and its parent's (unused for the root).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub(super) struct Entry {
    pub node: u32,
    pub parent: u32,
    pub own: NodeView,
    pub up: NodeView,
}

impl Entry {
    pub fn new(h: &Hierarchy, tests: &Tests, u: u32) -> Entry {
        let parent = h.parent[u as usize];
        Entry {
            node: u,
            parent,
            own: if h.is_leaf(u) {
                NodeView::default()
            } else {
                tests.node_view(h, u)
            },
            up: if parent == NIL {
                NodeView::default()
            } else {
                tests.node_view(h, parent)
            },
        }
    }

    /// The entry of `u`, a child of the node of entry `parent`, whose view data it copies instead
    /// of reading it again.
    pub fn under(h: &Hierarchy, tests: &Tests, u: u32, parent: &Entry) -> Entry {
        debug_assert_eq!(h.parent[u as usize], parent.node);
        Entry {
            node: u,
            parent: parent.node,
            own: if h.is_leaf(u) {
                NodeView::default()
            } else {
                tests.node_view(h, u)
            },
            up: parent.own,
        }
    }

    /// The entry is the second child of the parent of `left`, its neighbour: both children of
    /// that parent are on the front.
    #[inline]
    pub fn pairs_with(&self, left: &Entry) -> bool {
        self.parent != NIL && self.parent == left.parent
    }
}

/// The least gap left for a sweep's growth, in entries.
const MIN_GAP: usize = 256;

/// The front's entries, in leaf order (see the module's text).
#[derive(Clone, Default)]
pub(super) struct Stream {
    /// Between sweeps the entries are `buf[..len]`; during one, those written are `buf[..write]`
    /// and those still to read `buf[read..]`.
    buf: Vec<Entry>,
    len: usize,
    write: usize,
    read: usize,
    /// The tests the entries' view data were gathered for.
    pub tests: Tests,
}

impl Stream {
    /// The entries of every node active on `front`.
    pub fn of_front(h: &Hierarchy, front: &Front, tests: Tests) -> Stream {
        let mut active = front.active();
        active.sort_unstable_by_key(|&u| h.leaf_range(u).0);
        let buf: Vec<Entry> = active.iter().map(|&u| Entry::new(h, &tests, u)).collect();
        Stream {
            len: buf.len(),
            buf,
            write: 0,
            read: 0,
            tests,
        }
    }

    pub fn len(&self) -> usize {
        self.len
    }

    /// Gathers every entry's view data again, for other tests.
    pub fn regather(&mut self, h: &Hierarchy, tests: Tests) {
        for e in &mut self.buf[..self.len] {
            *e = Entry::new(h, &tests, e.node);
        }
        self.tests = tests;
    }

    /// Starts a sweep at entry `start`: the entries before it stay as they are, the rest are read.
    pub fn begin(&mut self, start: usize) {
        let start = start.min(self.len);
        // A gap of at least a sixteenth of the entries; when it is short, room for an eighth, so
        // that a growing front makes the buffer grow every few dozen frames, not every frame.
        if self.buf.len() < self.len + (self.len / 16).max(MIN_GAP) {
            let size = self.len + (self.len / 8).max(MIN_GAP);
            // Exactly: a `Vec`'s doubling would leave up to twice the front's entries allocated.
            self.buf.reserve_exact(size - self.buf.len());
            self.buf.resize(size, Entry::default());
        }
        let tail = self.buf.len() - (self.len - start);
        self.buf.copy_within(start..self.len, tail);
        self.write = start;
        self.read = tail;
    }

    /// The next entry to visit, if any is left.
    #[inline]
    pub fn next(&mut self) -> Option<Entry> {
        let e = self.buf.get(self.read).copied();
        self.read += e.is_some() as usize;
        e
    }

    /// Writes `e` after the last entry written.
    #[inline]
    pub fn push(&mut self, e: Entry) {
        if self.write == self.read {
            self.widen();
        }
        self.buf[self.write] = e;
        self.write += 1;
    }

    /// The last entry written: the left neighbour of the next one.
    #[inline]
    pub fn last(&self) -> Option<&Entry> {
        self.write.checked_sub(1).map(|i| &self.buf[i])
    }

    /// How many entries are written.
    pub fn written(&self) -> usize {
        self.write
    }

    /// Takes back the last entry written.
    #[inline]
    pub fn pop(&mut self) {
        self.write -= 1;
    }

    /// The writes caught up with the reads: more room between them.
    #[cold]
    fn widen(&mut self) {
        let old = self.buf.len();
        let more = (old / 8).max(MIN_GAP);
        self.buf.reserve_exact(more);
        self.buf.resize(old + more, Entry::default());
        self.buf.copy_within(self.read..old, self.read + more);
        self.read += more;
    }

    /// Ends the sweep, the unread entries kept after the written ones; returns the position of the
    /// first unread entry (the length when all were read).
    pub fn end(&mut self) -> usize {
        let rest = self.buf.len() - self.read;
        self.buf.copy_within(self.read.., self.write);
        self.len = self.write + rest;
        self.read = self.buf.len();
        self.write
    }

    /// Replaces every pair of neighbouring siblings whose parent is in `unified` (sorted) by the
    /// parent: the front's unifies done outside a sweep (geomorphs arriving).
    pub fn merge(&mut self, h: &Hierarchy, unified: &[u32]) {
        let mut w = 0;
        for i in 0..self.len {
            let mut e = self.buf[i];
            while w > 0
                && e.pairs_with(&self.buf[w - 1])
                && unified.binary_search(&e.parent).is_ok()
            {
                w -= 1;
                e = Entry::new(h, &self.tests, e.parent);
            }
            self.buf[w] = e;
            w += 1;
        }
        self.len = w;
    }

    /// The entries, between sweeps.
    pub fn entries(&self) -> &[Entry] {
        &self.buf[..self.len]
    }

    /// Heap bytes.
    pub fn bytes(&self) -> usize {
        self.buf.capacity() * std::mem::size_of::<Entry>()
    }
}

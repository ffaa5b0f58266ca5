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
//! # Runs
//! The entries are kept in runs of up to [`RUN`] (a few kilobytes each). A sweep rewrites a run
//! into a new one without moving the rest, and passes a run by untouched when nothing in it would
//! change: in tolerance mode a frame first reads every run on all cores, without writing, for
//! whether one of its entries wants a split or a unify ([`Stream::changing`]), then rewrites only
//! those. On a big model's front (the 14 M-triangle dragon's fly-in: 165 k entries, 10 MB) most
//! runs hold still in any one frame, and one array read and written whole every frame (moved
//! whole, too, to open the gap its writes filled) was most of the frame's refinement.

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

/// Entries a run holds at most: a sweep that has written this many starts another.
pub(super) const RUN: usize = 64;

/// Empty run buffers kept between sweeps for the runs the next one writes.
const SPARE_RUNS: usize = 256;

/// Runs ahead whose margins a frame's weighing asks for.
const AHEAD: usize = 4;

/// An entry's `until` when nothing is known: it is weighed in the next frame.
pub(super) const EXPIRED: f32 = f32::NEG_INFINITY;

/// A run of entries and, beside each, until when nothing can change it (see [`Stream::changing`]):
/// a value of the refiner's odometer, kept apart from the entries so that a frame reads 4 bytes
/// an entry to find the few it must weigh.
#[derive(Clone, Default)]
struct Run {
    entries: Vec<Entry>,
    until: Vec<f32>,
}

impl Run {
    fn with_capacity(n: usize) -> Run {
        Run {
            entries: Vec::with_capacity(n),
            until: Vec::with_capacity(n),
        }
    }

    fn len(&self) -> usize {
        self.entries.len()
    }

    fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    fn clear(&mut self) {
        self.entries.clear();
        self.until.clear();
    }

    fn push(&mut self, e: Entry, until: f32) {
        self.entries.push(e);
        self.until.push(until);
    }

    fn pop(&mut self) -> bool {
        self.until.pop();
        self.entries.pop().is_some()
    }

    fn append(&mut self, other: &Run) {
        self.entries.extend_from_slice(&other.entries);
        self.until.extend_from_slice(&other.until);
    }

    fn tail(&self, from: usize) -> Run {
        Run {
            entries: self.entries[from..].to_vec(),
            until: self.until[from..].to_vec(),
        }
    }
}

/// The front's entries, in leaf order (see the module's text).
#[derive(Clone, Default)]
pub(super) struct Stream {
    /// Between sweeps, the front; during one, the runs still to read are `runs[next..]`.
    runs: Vec<Run>,
    next: usize,
    /// During a sweep: the runs written, the run being written, and the run being read (its
    /// entries from `read` on still to read).
    out: Vec<Run>,
    open: Run,
    reading: Run,
    read: usize,
    /// Buffers of runs read to their end, for runs written.
    spare: Vec<Run>,
    /// Entries between sweeps.
    len: usize,
    /// The tests the entries' view data were gathered for.
    pub tests: Tests,
}

impl Stream {
    /// The entries of every node active on `front`.
    pub fn of_front(h: &Hierarchy, front: &Front, tests: Tests) -> Stream {
        let mut active = front.active();
        active.sort_unstable_by_key(|&u| h.leaf_range(u).0);
        let entries: Vec<Entry> = active.iter().map(|&u| Entry::new(h, &tests, u)).collect();
        Stream::of_entries(&entries, tests)
    }

    fn of_entries(entries: &[Entry], tests: Tests) -> Stream {
        Stream {
            runs: entries
                .chunks(RUN)
                .map(|c| Run {
                    entries: c.to_vec(),
                    until: vec![EXPIRED; c.len()],
                })
                .collect(),
            len: entries.len(),
            tests,
            ..Stream::default()
        }
    }

    /// Entries on the front (between sweeps).
    pub fn len(&self) -> usize {
        self.len
    }

    /// Runs on the front (between sweeps): where a sweep can start.
    pub fn runs(&self) -> usize {
        self.runs.len()
    }

    /// Gathers every entry's view data again, for other tests.
    pub fn regather(&mut self, h: &Hierarchy, tests: Tests) {
        for run in &mut self.runs {
            for e in &mut run.entries {
                *e = Entry::new(h, &tests, e.node);
            }
            run.until.fill(EXPIRED);
        }
        self.tests = tests;
    }

    /// Forgets every entry's margin (the odometer starts again).
    pub fn expire(&mut self) {
        for run in &mut self.runs {
            run.until.fill(EXPIRED);
        }
    }

    /// Per run (between sweeps), whether one of its entries may change, read on every core.
    ///
    /// `settled` weighs an entry after its left neighbour (the entry before it, `None` for the
    /// first): `None` when a visit could change it, else how far the camera may travel before one
    /// could. Each entry keeps until when (a value of the refiner's odometer, `now` being this
    /// frame's) it cannot change, and only entries whose time has come are weighed again, unless
    /// `all` (the view changed otherwise than by the camera's move). Also returns how many were
    /// weighed.
    pub fn changing(
        &mut self,
        now: f32,
        all: bool,
        settled: impl Fn(&Entry, bool) -> Option<f32> + Sync,
    ) -> (Vec<bool>, usize) {
        use rayon::prelude::*;
        // Of each run's left neighbour, its parent: a pair needs no more.
        let lefts: Vec<u32> = (0..self.runs.len()).map(|k| self.left_parent(k)).collect();
        self.runs
            .par_chunks_mut(32)
            .zip(lefts.par_chunks(32))
            .flat_map_iter(|(runs, lefts)| {
                let mut flags = Vec::with_capacity(runs.len());
                for run in runs.iter().take(AHEAD) {
                    crate::prefetch_address(run.until.as_ptr() as usize);
                }
                for k in 0..runs.len() {
                    // The next run's margins, asked for ahead (each run is its own block).
                    if let Some(next) = runs.get(k + AHEAD) {
                        crate::prefetch_address(next.until.as_ptr() as usize);
                    }
                    let run = &mut runs[k];
                    // The entries to weigh, asked for all at once so that their reads overlap.
                    let mut due: smallvec::SmallVec<[u16; RUN]> = smallvec::SmallVec::new();
                    for (i, &until) in run.until.iter().enumerate() {
                        if all || until <= now {
                            due.push(i as u16);
                            crate::prefetch(&run.entries[i]);
                            if i > 0 {
                                crate::prefetch(&run.entries[i - 1].parent);
                            }
                        }
                    }
                    let mut changes = false;
                    for &i in &due {
                        let i = i as usize;
                        let e = &run.entries[i];
                        // Only the entries weighed are read, and their left neighbours' parents.
                        let left = match i {
                            0 => lefts[k],
                            _ => run.entries[i - 1].parent,
                        };
                        let paired = e.parent != NIL && e.parent == left;
                        run.until[i] = match settled(e, paired) {
                            Some(margin) => later(now, margin),
                            None => {
                                changes = true;
                                EXPIRED
                            }
                        };
                    }
                    flags.push((changes, due.len()));
                }
                flags
            })
            .collect::<Vec<(bool, usize)>>()
            .into_iter()
            .fold((Vec::new(), 0), |(mut flags, weighed), (changes, due)| {
                flags.push(changes);
                (flags, weighed + due)
            })
    }

    /// The node before run `k` (between sweeps); [`NIL`] before the first.
    pub fn left_of_run(&self, k: usize) -> u32 {
        k.checked_sub(1)
            .and_then(|j| self.runs[j].entries.last())
            .map_or(NIL, |e| e.node)
    }

    /// The parent of the node before run `k` (between sweeps); [`NIL`] before the first.
    fn left_parent(&self, k: usize) -> u32 {
        k.checked_sub(1)
            .and_then(|j| self.runs[j].entries.last())
            .map_or(NIL, |e| e.parent)
    }

    /// Starts a sweep at run `start`: the runs before it stay as they are, the rest are read.
    pub fn begin(&mut self, start: usize) {
        let start = start.min(self.runs.len());
        self.out = Vec::with_capacity(self.runs.len() + 16);
        self.out.extend(self.runs.drain(..start));
        self.next = 0;
        self.reading.clear();
        self.read = 0;
    }

    /// Whether a run is left to read (its entries then come from [`Stream::next`]).
    pub fn has_run(&self) -> bool {
        self.next < self.runs.len()
    }

    /// Starts reading the next run; false when none is left.
    pub fn take_run(&mut self) -> bool {
        let Some(run) = self.runs.get_mut(self.next) else {
            return false;
        };
        self.next += 1;
        // The buffer read to its end is reused for a run written later.
        let mut done = std::mem::replace(&mut self.reading, std::mem::take(run));
        if done.entries.capacity() >= RUN {
            done.clear();
            self.spare.push(done);
        }
        self.read = 0;
        true
    }

    /// The next entry of the run being read, with its `until`; `None` at its end.
    #[inline]
    pub fn next(&mut self) -> Option<(Entry, f32)> {
        let e = self.reading.entries.get(self.read).copied()?;
        let until = self.reading.until[self.read];
        self.read += 1;
        Some((e, until))
    }

    /// Passes the next run by, as it is (only between runs); returns its length. A short run
    /// joins the one before it where both fit in one, so that rewritten runs, which end wherever
    /// a pass begins, do not leave the front in ever shorter pieces.
    pub fn pass(&mut self) -> usize {
        debug_assert_eq!(self.read, self.reading.len());
        let mut run = std::mem::take(&mut self.runs[self.next]);
        self.next += 1;
        let len = run.len();
        let before = if self.open.is_empty() {
            self.out.last_mut()
        } else {
            Some(&mut self.open)
        };
        match before {
            Some(before) if before.len() + len <= RUN => {
                before.append(&run);
                run.clear();
                self.spare.push(run);
                if self.open.len() >= RUN {
                    self.close();
                }
            }
            _ => {
                self.close();
                self.out.push(run);
            }
        }
        len
    }

    /// Writes `e` after the last entry written, to be weighed in the next frame.
    #[inline]
    pub fn push(&mut self, e: Entry) {
        self.push_until(e, EXPIRED);
    }

    /// Writes `e` after the last entry written, unchanged until `until`.
    #[inline]
    pub fn push_until(&mut self, e: Entry, until: f32) {
        self.open.push(e, until);
        if self.open.len() >= RUN {
            self.close();
        }
    }

    /// Ends the run being written.
    fn close(&mut self) {
        if !self.open.is_empty() {
            let fresh = self.spare.pop().unwrap_or_else(|| Run::with_capacity(RUN));
            self.out.push(std::mem::replace(&mut self.open, fresh));
        }
    }

    /// The last entry written: the left neighbour of the next one.
    #[inline]
    pub fn last(&self) -> Option<&Entry> {
        self.open
            .entries
            .last()
            .or_else(|| self.out.last().and_then(|r| r.entries.last()))
    }

    /// Runs written so far (the last one closed): where a sweep that stops here resumes.
    pub fn written(&mut self) -> usize {
        self.close();
        self.out.len()
    }

    /// Takes back the last entry written.
    #[inline]
    pub fn pop(&mut self) {
        if self.open.pop() {
            return;
        }
        if let Some(run) = self.out.last_mut() {
            run.pop();
            if run.is_empty() {
                self.out.pop();
            }
        }
    }

    /// Ends the sweep, the unread entries kept after the written ones (as a run of their own,
    /// then the runs not reached).
    pub fn end(&mut self) {
        self.close();
        if self.read < self.reading.len() {
            self.out.push(self.reading.tail(self.read));
        }
        self.reading.clear();
        self.read = 0;
        let rest: Vec<Run> = self.runs.drain(self.next..).collect();
        self.out.extend(rest);
        self.runs = std::mem::take(&mut self.out);
        self.next = 0;
        // Runs joined in passes give back more buffers than a sweep takes: keep a sweep's worth.
        self.spare.truncate(SPARE_RUNS);
        self.len = self.runs.iter().map(Run::len).sum();
    }

    /// Replaces every pair of neighbouring siblings whose parent is in `unified` (sorted) by the
    /// parent: the front's unifies done outside a sweep (geomorphs arriving).
    pub fn merge(&mut self, h: &Hierarchy, unified: &[u32]) {
        let mut out: Vec<Entry> = Vec::with_capacity(self.len);
        for e in self.entries() {
            let mut e = e;
            while let Some(left) = out.last()
                && e.pairs_with(left)
                && unified.binary_search(&e.parent).is_ok()
            {
                out.pop();
                e = Entry::new(h, &self.tests, e.parent);
            }
            out.push(e);
        }
        *self = Stream::of_entries(&out, self.tests);
    }

    /// The entries, between sweeps.
    pub fn entries(&self) -> Vec<Entry> {
        self.runs.iter().flat_map(|r| &r.entries).copied().collect()
    }

    /// Heap bytes.
    pub fn bytes(&self) -> usize {
        self.runs
            .iter()
            .map(|r| {
                r.entries.capacity() * std::mem::size_of::<Entry>()
                    + r.until.capacity() * std::mem::size_of::<f32>()
            })
            .sum::<usize>()
            + self.runs.capacity() * std::mem::size_of::<Run>()
    }
}

/// The odometer value `margin` past `now`, rounded down (and a thousandth short, against the
/// rounding of the margins' own arithmetic).
#[inline]
fn later(now: f32, margin: f32) -> f32 {
    if margin == f32::INFINITY {
        return f32::INFINITY;
    }
    (now + margin * 0.999).next_down()
}

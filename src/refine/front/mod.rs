//! The live front: the current vertex chain (a cut through the tree) and the current triangle chain,
//! changed one `vsplit` / `vunify` at a time, in any order the tree allows.
//!
//! # Why per-node triangle lists, not Hoppe's legality conditions
//! Hoppe's view-dependent progressive meshes (1997 §5) split and unify through neighbour pointers of a
//! manifold neighbourhood and allow an operation only where that neighbourhood is the one it was built
//! with. Our trees merge vertices that share no edge and handle non-manifold input, so there is no such
//! neighbourhood. We keep Luebke & Erikson's (1997) rule instead, which holds for any order:
//!
//! * every live triangle's corners are the active ancestors of its input corners (Tao et al.'s `g(v)`);
//! * a triangle is live exactly when its lowest pairwise common ancestor is split
//!   ([`Hierarchy::appearing`]), i.e. when its three corners are distinct;
//! * of live triangles with the same three corners (coincident, Tao et al.'s Fig. 3b) one is drawn.
//!
//! Each active node heads a list of the live triangles around it, threaded through the triangles'
//! records (`next[k]` follows corner `k`, as a link naming the next record and its corner at the
//! node), so a split or unify costs time in proportion to the triangles around the node and never
//! scans the front or the triangle list. Only live triangles have a record (40 bytes, recycled); the
//! rest cost 4 bytes each, so memory follows the front, not the model. Coincident triangles share all
//! three corners, so all of them are in the lists an operation walks: resolving which is drawn stays
//! local too.
//!
//! # Output
//! Vertices are the tree's nodes, by node id: a renderer uploads [`Hierarchy::position`] once and then
//! only the vertices a geomorph moves. Drawn triangles are packed at the front of [`Front::indices`]
//! (removal swaps the last one into the hole), and the blocks written since the last
//! [`Front::take_dirty`] are reported as ranges.

mod ops;

use super::hierarchy::{Hierarchy, NIL};

/// Node states. A node is `ACTIVE` on the front, `SPLIT` above it, `BELOW` under it.
pub const BELOW: u8 = 0;
pub const ACTIVE: u8 = 1;
pub const SPLIT: u8 = 2;

/// `slot` of a live triangle that is not drawn: another live triangle has the same corners.
const HIDDEN: u32 = u32::MAX;
/// `slot` of a record degenerating in the unify under way: in both children's lists, taken out of
/// its third corner's list and freed once both have been walked.
const DYING: u32 = u32::MAX - 1;

/// The least room [`Front::make_room`] leaves in each array, in elements.
const MIN_ROOM: usize = 512;

/// Room [`Front::make_room`] leaves in the scratch lists: an operation around a node of this many
/// triangles or fewer grows none.
const SCRATCH_ROOM: usize = 64;

/// Dirty tracking granularity, in triangles: one bit per 64 triangles (768 bytes of indices).
const DIRTY_BLOCK: u32 = 64;

/// A live triangle.
#[derive(Clone, Copy, Debug)]
struct Record {
    /// Its corners: the active nodes standing for its input corners (in input winding).
    corner: [u32; 3],
    /// The next record around corner `k`'s node, as a link ([`Front::link`]).
    next: [u32; 3],
    /// Its input corners (leaves), kept here because every operation on the triangle reads them.
    input: [u32; 3],
    /// Its index in [`Hierarchy::triangles`] (what a renderer of wedges reads its corners' leaf
    /// wedges by).
    triangle: u32,
    /// Its draw slot, or `HIDDEN`, `DYING`.
    slot: u32,
}

/// The corners in increasing order, packed in one integer: what coincident triangles share. A
/// sorting network and one comparison per pair (a slice sort of three was a fifth of an operation's
/// time).
#[inline]
fn key([a, b, c]: [u32; 3]) -> u128 {
    let (lo, hi) = (a.min(b), a.max(b));
    let (mid, top) = (hi.min(c), hi.max(c));
    (lo.min(mid) as u128) << 64 | (lo.max(mid) as u128) << 32 | top as u128
}

/// The corner sets of a unify under way, to find coincident triangles among those that got new
/// corners (about a dozen): an open-addressed hash table of record ids, each entry stamped with
/// the operation it belongs to, so that no operation has to clear it. A unify sorts its group by
/// [`key`] only when this finds a coincidence.
#[derive(Clone)]
struct Seen {
    /// `stamp << 32 | record`; an entry with another stamp is empty.
    table: Box<[u64; 1 << SEEN_BITS]>,
    stamp: u32,
    /// A triangle with the same corners as an earlier one was added, or too many were.
    coincident: bool,
}

/// The multiplier of [`Seen`]'s hash.
const SEEN_HASH: u64 = 0x9E37_79B9_7F4A_7C15;
/// log2 of [`Seen`]'s table size.
const SEEN_BITS: u32 = 10;
/// Past this many triangles in one operation (high-valence nodes of coarse fronts), [`Seen`] gives
/// up and the operation sorts its group.
const SEEN_LIMIT: usize = 1 << (SEEN_BITS - 2);

impl Seen {
    fn new() -> Seen {
        Seen {
            table: Box::new([0; 1 << SEEN_BITS]),
            stamp: 0,
            coincident: false,
        }
    }

    #[inline(always)]
    fn start(&mut self) {
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.table.fill(0);
            self.stamp = 1;
        }
        self.coincident = false;
    }

    /// Adds record `r`, whose corners are now `corners`, after `added` others.
    #[inline(always)]
    fn add(&mut self, records: &[Record], r: u32, corners: [u32; 3], added: usize) {
        if added >= SEEN_LIMIT {
            self.coincident = true;
            return;
        }
        // A hash that is the same in any order of the three corners (equal ones for different
        // corner sets cost a comparison of keys).
        let mask = self.table.len() - 1;
        let mut i = (((corners[0] ^ corners[1] ^ corners[2]) as u64).wrapping_mul(SEEN_HASH)
            >> (64 - SEEN_BITS)) as usize;
        loop {
            let entry = self.table[i & mask];
            if (entry >> 32) as u32 != self.stamp {
                self.table[i & mask] = (self.stamp as u64) << 32 | r as u64;
                return;
            }
            if key(records[entry as u32 as usize].corner) == key(corners) {
                self.coincident = true;
                return;
            }
            i += 1;
        }
    }
}

/// The drawn triangles: their corners packed for the renderer, the record behind each slot, and
/// one dirty bit for each block of `DIRTY_BLOCK` slots.
#[derive(Clone, Default)]
struct Drawn {
    indices: Vec<[u32; 3]>,
    slot_record: Vec<u32>,
    /// Covers every slot: [`Drawn::push`] grows it.
    dirty: Vec<u64>,
}

impl Drawn {
    /// Writes a drawn triangle's corners to its slot and marks the slot's block dirty.
    ///
    /// # Safety
    /// `slot` must be a drawn record's slot: [`Drawn::push`] hands out slots below
    /// `indices.len()`, and [`Drawn::release`] moves the last one into a freed slot before
    /// shrinking, so a drawn record's slot is always in range, and `dirty` always covers `indices`.
    #[inline(always)]
    unsafe fn write(&mut self, slot: u32, corners: [u32; 3]) {
        let block = (slot / DIRTY_BLOCK) as usize;
        debug_assert!((slot as usize) < self.indices.len() && block / 64 < self.dirty.len());
        // SAFETY: the caller's promise.
        unsafe {
            *self.indices.get_unchecked_mut(slot as usize) = corners;
            *self.dirty.get_unchecked_mut(block / 64) |= 1 << (block % 64);
        }
    }

    /// A new slot at the end, for record `r`.
    #[inline(always)]
    fn push(&mut self, r: u32) -> u32 {
        let slot = self.indices.len() as u32;
        self.indices.push([0; 3]);
        self.slot_record.push(r);
        if (slot / (DIRTY_BLOCK * 64)) as usize >= self.dirty.len() {
            self.dirty.push(0);
        }
        slot
    }

    /// Gives `rec` (record `r`) a slot if it has none and writes its corners there.
    #[inline(always)]
    fn draw(&mut self, rec: &mut Record, r: u32) {
        if rec.slot == HIDDEN {
            rec.slot = self.push(r);
        }
        // SAFETY: the record is drawn now.
        unsafe { self.write(rec.slot, rec.corner) };
    }

    /// Takes record `r` out of the drawn list (if it is there), moving the last drawn triangle into
    /// its slot.
    fn release(&mut self, records: &mut [Record], r: u32) {
        let s = records[r as usize].slot;
        if s >= DYING {
            return;
        }
        records[r as usize].slot = HIDDEN;
        let last = self.indices.len() as u32 - 1;
        if s != last {
            let moved = self.slot_record[last as usize];
            let corners = self.indices[last as usize];
            // SAFETY: `s` was the released record's drawn slot.
            unsafe { self.write(s, corners) };
            self.slot_record[s as usize] = moved;
            records[moved as usize].slot = s;
        }
        self.indices.pop();
        self.slot_record.pop();
    }
}

/// `records[r]` without a bounds check, for the hot loops of [`Front::split`] and
/// [`Front::unify`].
///
/// # Safety
/// `r` must be a record id taken from a node's list: links are only ever made from ids
/// `Front::new_record` returned, and records are recycled, never removed, so those are in range.
#[inline(always)]
unsafe fn record(records: &[Record], r: u32) -> &Record {
    debug_assert!((r as usize) < records.len());
    // SAFETY: the caller's promise.
    unsafe { records.get_unchecked(r as usize) }
}

/// The same, for writing.
///
/// # Safety
/// As for [`record`].
#[inline(always)]
unsafe fn record_mut(records: &mut [Record], r: u32) -> &mut Record {
    debug_assert!((r as usize) < records.len());
    // SAFETY: the caller's promise.
    unsafe { records.get_unchecked_mut(r as usize) }
}

/// The corner after corner `k`, around a triangle.
const NEXT: [usize; 3] = [1, 2, 0];

/// The active nodes around a split and the leaves under each: the outside corner of a triangle
/// that appears is the one holding its third input corner. Seven times in ten no triangle around
/// the node has that leaf for an input corner, and the node's leaf range must be read; reading the
/// ranges as the walk meets the corners lets those loads overlap with the walk instead of
/// queueing after it.
/// Scratch of the front, so that no split has to clear it.
#[derive(Clone)]
struct Candidates {
    /// `(lo, hi, node)`: the node's leaves are `lo..hi`.
    ranges: Box<[(u32, u32, u32); CANDIDATES]>,
    len: usize,
}

/// At most this many candidates are kept (one a triangle around the split node); past that,
/// [`Front::outside_corner`] searches the group.
const CANDIDATES: usize = 48;

impl Candidates {
    fn new() -> Candidates {
        Candidates {
            ranges: Box::new([(0, 0, 0); CANDIDATES]),
            len: 0,
        }
    }

    #[inline(always)]
    fn add(&mut self, h: &Hierarchy, w: u32) {
        if self.len < CANDIDATES {
            self.ranges[self.len] = h.leaf_range(w);
            self.len += 1;
        }
    }

    /// The candidate holding `leaf`.
    #[inline(always)]
    fn holding(&self, leaf: u32) -> Option<u32> {
        // Every candidate looked at, without a branch on the data: the one that holds the leaf
        // is anywhere among them, and an early exit would be mispredicted on every call.
        let mut found = NIL;
        for &(lo, hi, w) in &self.ranges[..self.len] {
            // (Ranges of distinct active nodes are disjoint: at most one matches.)
            found = if leaf.wrapping_sub(lo) < hi - lo {
                w
            } else {
                found
            };
        }
        (found != NIL).then_some(found)
    }
}

#[inline]
fn has_corner(c: [u32; 3], u: u32) -> bool {
    (c[0] == u) | (c[1] == u) | (c[2] == u)
}

/// The live state of one view of a [`Hierarchy`].
pub struct Front {
    /// Each node's state.
    state: Vec<u8>,
    /// The first record around each active node, as a link.
    head: Vec<u32>,
    active_count: usize,
    records: Vec<Record>,
    free_records: Vec<u32>,
    /// Drawn triangles as node ids, packed.
    drawn: Drawn,
    /// Scratch of an operation: the records that got new corners, those of them not drawn yet, the
    /// degenerating ones, and the group with keys when coincident triangles are sorted out.
    group: Vec<u32>,
    pending: Vec<u32>,
    dying: Vec<u32>,
    keyed: Vec<(u128, u32)>,
    seen: Seen,
    candidates: Candidates,
    /// When set, every operation is appended here (`u` for `vsplit(u)`, `!p` for `vunify(p)`), so
    /// that a run can be replayed without the view tests (benchmarks time the operations alone).
    #[cfg(feature = "trace")]
    pub log: Option<Vec<u32>>,
    /// The capacities of the arrays [`Front::make_room`] looks after when it last touched them.
    touched: [usize; 4],
    pub splits: u64,
    pub unifies: u64,
}

/// A copy with the same room to grow as the original: a front is cloned to go on running (a
/// snapshot, a benchmark's starting point), and a copy whose arrays had to grow again at once
/// would not behave like the one it copies.
impl Clone for Front {
    fn clone(&self) -> Front {
        fn with_room<T: Clone>(v: &Vec<T>) -> Vec<T> {
            let mut copy = Vec::with_capacity(v.capacity());
            copy.extend_from_slice(v);
            copy
        }
        Front {
            state: with_room(&self.state),
            head: with_room(&self.head),
            active_count: self.active_count,
            records: with_room(&self.records),
            free_records: with_room(&self.free_records),
            drawn: Drawn {
                indices: with_room(&self.drawn.indices),
                slot_record: with_room(&self.drawn.slot_record),
                dirty: with_room(&self.drawn.dirty),
            },
            group: with_room(&self.group),
            pending: with_room(&self.pending),
            dying: with_room(&self.dying),
            keyed: with_room(&self.keyed),
            seen: self.seen.clone(),
            candidates: self.candidates.clone(),
            #[cfg(feature = "trace")]
            log: self.log.clone(),
            // A copy's spare capacity is new memory.
            touched: [0; 4],
            splits: self.splits,
            unifies: self.unifies,
        }
    }
}

/// Why a list of nodes is not a cut through the tree (see [`Front::at_cut`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CutError {
    #[error("node {0} is not in the tree")]
    NotInTree(u32),
    #[error("node {0} is listed twice")]
    ListedTwice(u32),
    #[error("leaf {0} is under no node of the cut")]
    LeafUncovered(u32),
    #[error("node {0} lies under another node of the cut")]
    Nested(u32),
}

impl Front {
    /// The coarsest front: the root alone, no triangle.
    pub fn new(h: &Hierarchy) -> Front {
        let nodes = h.node_count() as usize;
        let root = h.root();
        // Written, not allocated zeroed: zeroed memory comes from the system untouched, and the
        // operations would fault its pages in as the front reaches them.
        let mut state = Vec::with_capacity(nodes);
        state.resize(nodes, BELOW);
        state[root as usize] = ACTIVE;
        Front {
            state,
            head: vec![NIL; nodes],
            active_count: 1,
            records: Vec::new(),
            free_records: Vec::new(),
            drawn: Drawn::default(),
            group: Vec::new(),
            pending: Vec::new(),
            dying: Vec::new(),
            keyed: Vec::new(),
            seen: Seen::new(),
            candidates: Candidates::new(),
            #[cfg(feature = "trace")]
            log: None,
            touched: [0; 4],
            splits: 0,
            unifies: 0,
        }
    }

    /// The front at a given cut: `nodes` must be a cut through the tree (every leaf under exactly one
    /// of them), for example a static LOD's (`vtree::cut_at_error` renumbered with
    /// [`Hierarchy::renumbering`]). Reached by splitting down from the root, so its triangles are
    /// exactly those the cut implies.
    pub fn at_cut(h: &Hierarchy, nodes: &[u32]) -> Result<Front, CutError> {
        let mut on_cut = vec![false; h.node_count() as usize];
        for &u in nodes {
            let slot = on_cut.get_mut(u as usize).ok_or(CutError::NotInTree(u))?;
            if std::mem::replace(slot, true) {
                return Err(CutError::ListedTwice(u));
            }
        }
        let mut front = Front::new(h);
        let mut stack = vec![h.root()];
        while let Some(u) = stack.pop() {
            if on_cut[u as usize] {
                continue;
            }
            if h.is_leaf(u) {
                return Err(CutError::LeafUncovered(u));
            }
            front.split(h, u);
            stack.extend(h.children(u));
        }
        if let Some(&u) = nodes.iter().find(|&&u| !front.is_active(u)) {
            return Err(CutError::Nested(u));
        }
        Ok(front)
    }

    #[inline]
    pub fn state(&self, u: u32) -> u8 {
        self.state[u as usize]
    }

    #[inline]
    pub fn is_active(&self, u: u32) -> bool {
        self.state(u) == ACTIVE
    }

    /// The active nodes (the current vertex chain), in node order. A scan of every node's state:
    /// for tests and set-up, not for every frame.
    pub fn active(&self) -> Vec<u32> {
        (0..self.state.len() as u32)
            .filter(|&u| self.is_active(u))
            .collect()
    }

    /// How many nodes are active.
    pub fn active_count(&self) -> usize {
        self.active_count
    }

    /// The drawn triangles, as node ids (vertex indices into the node arrays).
    pub fn indices(&self) -> &[[u32; 3]] {
        &self.drawn.indices
    }

    /// Drawn triangles `range` as a renderer draws them, into `out`: their corners' vertices in the
    /// drawn vertex buffer, which are node ids ([`Front::indices`]) or, for a tree with wedges,
    /// the wedges the corners show ([`super::hierarchy::HierarchyWedges`]).
    pub fn vertices(&self, h: &Hierarchy, range: std::ops::Range<u32>, out: &mut Vec<[u32; 3]>) {
        let range = range.start as usize..range.end as usize;
        let Some(w) = &h.wedges else {
            out.extend_from_slice(&self.drawn.indices[range]);
            return;
        };
        out.extend(self.drawn.slot_record[range].iter().map(|&r| {
            let rec = &self.records[r as usize];
            w.vertices(rec.corner, w.corners[rec.triangle as usize])
        }));
    }

    /// Every drawn triangle as a renderer draws it (see [`Front::vertices`]).
    pub fn all_vertices(&self, h: &Hierarchy) -> Vec<[u32; 3]> {
        let mut out = Vec::with_capacity(self.triangle_count());
        self.vertices(h, 0..self.triangle_count() as u32, &mut out);
        out
    }

    /// The input triangle (leaf corners) behind each drawn one.
    pub fn drawn_input_triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        self.drawn
            .slot_record
            .iter()
            .map(|&r| self.records[r as usize].input)
    }

    /// Whether some drawn triangle around active node `u` satisfies `test`, given its corners
    /// (active nodes) in drawing order. Walks the node's list of live triangles.
    pub fn any_drawn_around(&self, u: u32, mut test: impl FnMut([u32; 3]) -> bool) -> bool {
        let mut l = self.head[u as usize];
        while l != NIL {
            let (r, k) = Self::unlink(l);
            let rec = &self.records[r as usize];
            if rec.slot < DYING && test(rec.corner) {
                return true;
            }
            l = rec.next[k];
        }
        false
    }

    pub fn triangle_count(&self) -> usize {
        self.drawn.indices.len()
    }

    /// Can `u` split: active and not a leaf?
    pub fn can_split(&self, h: &Hierarchy, u: u32) -> bool {
        self.is_active(u) && !h.is_leaf(u)
    }

    /// Can `p` unify: both children active?
    pub fn can_unify(&self, h: &Hierarchy, p: u32) -> bool {
        !h.is_leaf(p) && h.children(p).iter().all(|&c| self.is_active(c))
    }

    /// Slot ranges of [`Front::indices`] written since the last call, merged, clipped to the current
    /// length; clears the record.
    pub fn take_dirty(&mut self) -> Vec<std::ops::Range<u32>> {
        let len = self.drawn.indices.len() as u32;
        let mut out: Vec<std::ops::Range<u32>> = Vec::new();
        for (w, bits) in self.drawn.dirty.iter_mut().enumerate() {
            let mut b = std::mem::take(bits);
            while b != 0 {
                let i = b.trailing_zeros();
                b &= b - 1;
                let start = (w as u32 * 64 + i) * DIRTY_BLOCK;
                if start >= len {
                    continue;
                }
                let end = (start + DIRTY_BLOCK).min(len);
                match out.last_mut() {
                    Some(last) if last.end == start => last.end = end,
                    _ => out.push(start..end),
                }
            }
        }
        out
    }

    /// Heap bytes of the live structures.
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        self.state.capacity()
            + self.head.capacity() * 4
            + self.records.capacity() * size_of::<Record>()
            + self.free_records.capacity() * 4
            + self.drawn.indices.capacity() * size_of::<[u32; 3]>()
            + self.drawn.slot_record.capacity() * 4
            + self.drawn.dirty.capacity() * 8
            + (self.group.capacity() + self.pending.capacity() + self.dying.capacity()) * 4
            + self.keyed.capacity() * size_of::<(u128, u32)>()
            + size_of::<[u64; 1 << SEEN_BITS]>()
            + size_of::<[(u32, u32, u32); CANDIDATES]>()
    }

    /// Makes room ahead of need in the arrays that grow with the front (records, free records,
    /// drawn triangles), and touches it: the operations then take new memory without
    /// waiting for the system. Growing a `Vec` inside an operation copies it and faults its new
    /// pages in one at a time (~2 µs each here, and the kernel's zeroing of each page evicts what
    /// was fetched ahead): on the dragon's fly-in, whose front doubles, that halved the
    /// operations' rate. Called between operations (by the runtime once a frame); an array grows
    /// by an eighth of its length once less than a thirty-second is left, so the capacity stays
    /// within 1.125× of the length plus a little (a frame's operations add a few hundred
    /// triangles: a thirty-second of a front is room for several frames).
    pub fn make_room(&mut self) {
        /// Grows `v` if it is short of room, and touches its spare capacity unless `touched`, the
        /// capacity it had when last touched, says that is done.
        fn room<T: Copy>(v: &mut Vec<T>, touched: &mut usize, fill: T) {
            let len = v.len();
            if v.capacity() - len < len / 32 + MIN_ROOM {
                v.reserve_exact(len / 8 + 2 * MIN_ROOM);
            }
            if v.capacity() != *touched {
                // Touched by writing and dropping: no unsafe code, and the writes cannot be
                // skipped (the memory is not known to be zero).
                v.resize(v.capacity(), fill);
                v.truncate(len);
                *touched = v.capacity();
            }
        }
        const BLANK: Record = Record {
            corner: [NIL; 3],
            next: [NIL; 3],
            input: [NIL; 3],
            triangle: NIL,
            slot: HIDDEN,
        };
        let [records, free, indices, slots] = &mut self.touched;
        room(&mut self.records, records, BLANK);
        room(&mut self.free_records, free, 0);
        room(&mut self.drawn.indices, indices, [0; 3]);
        room(&mut self.drawn.slot_record, slots, 0);
        // Dirty bits for every slot there is room for.
        let words = (self.drawn.indices.capacity()).div_ceil((DIRTY_BLOCK * 64) as usize);
        let dirty = &mut self.drawn.dirty;
        dirty.reserve(words.saturating_sub(dirty.len()));
        // The scratch lists, once.
        for scratch in [&mut self.group, &mut self.pending, &mut self.dying] {
            scratch.reserve(SCRATCH_ROOM);
        }
        self.keyed.reserve(SCRATCH_ROOM);
    }

    /// Applies a [`Front::log`] recorded from the same starting front.
    #[cfg(feature = "trace")]
    pub fn replay(&mut self, h: &Hierarchy, log: &[u32]) {
        for &op in log {
            if op < h.node_count() {
                self.split(h, op);
            } else {
                self.unify(h, !op);
            }
        }
    }

    /// Splits until every active node is a leaf: the input mesh.
    pub fn refine_all(&mut self, h: &Hierarchy) {
        let mut stack: Vec<u32> = self.active();
        while let Some(u) = stack.pop() {
            if self.can_split(h, u) {
                self.split(h, u);
                stack.extend(h.children(u));
            }
        }
    }

    /// Unifies until the root alone is active.
    pub fn coarsen_all(&mut self, h: &Hierarchy) {
        // Internal nodes are in pre-order: a reverse sweep unifies each split node after its
        // children.
        for p in (h.leaf_count..h.node_count()).rev() {
            if self.state(p) == SPLIT {
                self.unify(h, p);
            }
        }
    }
}

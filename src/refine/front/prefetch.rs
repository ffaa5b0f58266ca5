//! Hints for the memory system, asked for by the look-ahead (`refine::lookahead`, where the reasons
//! and the measurements are) some visits before an operation: only hints, never loads.

use super::*;

impl Front {
    /// A hint for the memory system, some visits before `split(u)`: the states and list heads
    /// of `u` and its children, and the triangles that appear. [`Front::prefetch_lists`] asks for
    /// the first records once the heads have arrived.
    pub(crate) fn prefetch_split(&self, h: &Hierarchy, u: u32) {
        let [c0, c1] = h.children(u);
        for v in [u, c0, c1] {
            crate::prefetch(&self.state[v as usize]);
            crate::prefetch(&self.head[v as usize]);
        }
        // The appearing triangles (usually two, and 12 bytes each: a third of the time on two
        // cache lines), and the next node's entry, which ends their range (a quarter of the time on
        // another line). Neither loaded here: that would stall the visit instead. Asking for the
        // second triangle and the next entry too took the fly-in's operations from 5.0 to 5.9 M/s.
        let k = (u - h.leaf_count) as usize;
        if let Some(next) = h.internal.get(k + 1) {
            crate::prefetch(next);
        }
        let first = h.internal[k].appear as usize;
        for t in h.triangles.iter().skip(first).take(2) {
            crate::prefetch(t);
        }
        // The records the appearing triangles will take.
        for &r in self.free_records.iter().rev().take(2) {
            let rec = &self.records[r as usize];
            crate::prefetch(&rec.corner);
            crate::prefetch(&rec.slot);
        }
    }

    /// A hint for the memory system, some visits before `unify(p)`: the states and list heads of
    /// `p` and its children.
    pub(crate) fn prefetch_unify(&self, h: &Hierarchy, p: u32) {
        let [c0, c1] = h.children(p);
        for v in [p, c0, c1] {
            crate::prefetch(&self.state[v as usize]);
            crate::prefetch(&self.head[v as usize]);
        }
    }

    /// The later stages of [`Front::prefetch_split`] and [`Front::prefetch_unify`]: record `hop`
    /// (0 for the first) of the list around each active one of `nodes`, reached through the
    /// records that earlier stages asked for.
    pub(crate) fn prefetch_lists(&self, h: &Hierarchy, nodes: &[u32], hop: usize, split: bool) {
        for (i, &v) in nodes.iter().enumerate() {
            if !self.is_active(v) {
                continue;
            }
            let mut l = self.head[v as usize];
            let mut last = None;
            for at in 0..hop {
                if l == NIL {
                    break;
                }
                let (r, k) = Self::unlink(l);
                let rec = &self.records[r as usize];
                (l, last) = (rec.next[k], Some(rec.slot));
                if !split && at + 1 == hop {
                    // The coincidence table's entry for its corners after the unify.
                    let p = h.parent[v as usize];
                    let c = rec.corner;
                    crate::prefetch(self.seen.slot(c[0] ^ c[1] ^ c[2] ^ v ^ p));
                }
                if !split && i == 0 && has_corner(rec.corner, nodes[1]) {
                    // It degenerates in the unify, which takes it out of its third corner's list:
                    // that list follows this one, some stages behind.
                    let third = rec.corner[0] ^ rec.corner[1] ^ rec.corner[2] ^ v ^ nodes[1];
                    self.prefetch_chain(third, hop - at - 1);
                }
                if split {
                    // The corner after v is a candidate for the appearing triangles' outside
                    // corners (see `Candidates`): the split reads its leaf range, and the list
                    // head of the one that is.
                    let w = rec.corner[NEXT[k]];
                    crate::prefetch(&self.head[w as usize]);
                    if !h.is_leaf(w) {
                        crate::prefetch(&h.internal[(w - h.leaf_count) as usize]);
                    }
                }
            }
            // The drawn triangle of the record the last stage asked for: the operation rewrites it.
            if let Some(drawn) = last.and_then(|s| self.drawn.indices.get(s as usize)) {
                crate::prefetch(drawn);
            }
            if l != NIL {
                // Records are 40 bytes: half of them straddle two cache lines.
                let rec = &self.records[Self::unlink(l).0 as usize];
                crate::prefetch(&rec.corner);
                crate::prefetch(&rec.slot);
            }
        }
    }

    /// A hint for the memory system, a few visits before an operation: the ends of the arrays
    /// every operation reads or writes (the drawn triangles' last slot, the free records' top, the
    /// scratch lists), which the visits between two operations evict; before a unify, also the
    /// records of the last drawn triangles.
    pub(crate) fn prefetch_scratch(&self, unify: bool) {
        if let Some(last) = self.drawn.indices.last() {
            crate::prefetch(last);
        }
        if let Some(last) = self.drawn.slot_record.last() {
            crate::prefetch(last);
        }
        for bits in self.drawn.dirty.iter().step_by(8) {
            crate::prefetch(bits);
        }
        if let Some(top) = self.free_records.last() {
            crate::prefetch(top);
        }
        if unify {
            // The unify's degenerate triangles (usually two) release their draw slots, the last
            // drawn triangles move into them, and their records are told (orbit x1.08; a split
            // releases none, and asking for them there cost 4 %).
            for &r in self.drawn.slot_record.iter().rev().take(2) {
                if let Some(rec) = self.records.get(r as usize) {
                    crate::prefetch(&rec.slot);
                }
            }
        }
        crate::prefetch_address(self.pending.as_ptr() as usize);
        crate::prefetch_address(self.dying.as_ptr() as usize);
        crate::prefetch(&self.candidates.ranges[0]);
        crate::prefetch(&self.candidates.ranges[5]);
    }

    /// Record `hop` of the list around `w`, or its head for `hop` 0 (what [`Front::unlink_from`]
    /// walks).
    fn prefetch_chain(&self, w: u32, hop: usize) {
        let Some(head) = self.head.get(w as usize) else {
            return;
        };
        if hop == 0 {
            crate::prefetch(head);
            return;
        }
        let mut l = *head;
        for _ in 1..hop {
            if l == NIL {
                return;
            }
            let (r, k) = Self::unlink(l);
            l = self.records[r as usize].next[k];
        }
        if l != NIL {
            crate::prefetch(&self.records[Self::unlink(l).0 as usize].next);
        }
    }
}

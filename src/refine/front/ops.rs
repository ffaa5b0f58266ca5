//! `vsplit` and `vunify` on the live front, and what they share: activating nodes, finding a
//! triangle's corner outside the node, drawing one of each set of coincident triangles.

use super::*;

impl Front {
    pub(super) fn activate(&mut self, u: u32) {
        self.state[u as usize] = ACTIVE;
        self.head[u as usize] = NIL;
        self.active_count += 1;
    }

    /// Takes `u` off the front; returns the first record around it.
    pub(super) fn deactivate(&mut self, u: u32, to: u8) -> u32 {
        self.state[u as usize] = to;
        self.active_count -= 1;
        self.head[u as usize]
    }

    /// A link in a node's triangle list: the record and which of its corners is the node, so that a
    /// walk goes from record to record without comparing corners (each hop is one load).
    #[inline]
    pub(super) fn link(r: u32, k: usize) -> u32 {
        debug_assert!(r < 1 << 30, "more than 2^30 live triangles");
        debug_assert!(k < 3);
        r << 2 | k as u32
    }

    #[inline]
    pub(super) fn unlink(l: u32) -> (u32, usize) {
        (l >> 2, (l & 3) as usize)
    }

    /// The active node standing for `leaf`, which lies outside the subtree of split node `u`, where
    /// [`Front::outside_corner`] finds none. Two walks find it: up from `u` to an ancestor holding
    /// the leaf, then down through split nodes; and up from the leaf through nodes below the front.
    /// The first is short where the front is coarse, the second where it is fine; taking them a step
    /// each in turn costs the shorter (and their loads, independent of each other, overlap).
    #[inline]
    pub(super) fn find_active_outside(&self, h: &Hierarchy, u: u32, leaf: u32) -> u32 {
        let mut down = h.parent[u as usize];
        let mut descending = false;
        let mut up = leaf;
        loop {
            if self.state(up) != BELOW {
                return up;
            }
            up = h.parent[up as usize];
            if descending {
                if self.state(down) != SPLIT {
                    return down;
                }
                down = h.child_toward(down, leaf);
            } else if h.contains(down, leaf) {
                descending = true;
            } else {
                down = h.parent[down as usize];
            }
        }
    }

    /// The active node standing for `leaf`, looked for among the corners of `group` (the live
    /// triangles around a split, in cache) other than the split's children: first a triangle with
    /// `leaf` for an input corner (on a manifold, an appearing triangle's neighbours across its
    /// edges to the outside corner are such), then a corner whose subtree holds `leaf` (the edge
    /// the appearing triangle was has another triangle on it). Their loads are independent of each
    /// other, where a walk in the tree waits on every step.
    #[inline]
    pub(super) fn outside_corner(
        &self,
        h: &Hierarchy,
        group: &[u32],
        children: [u32; 2],
        leaf: u32,
    ) -> Option<u32> {
        let by_input = group.iter().find_map(|&r| {
            // SAFETY: the group holds ids taken from the operation's lists, see `record`.
            let rec = unsafe { record(&self.records, r) };
            let j = rec.input.iter().position(|&x| x == leaf)?;
            Some(rec.corner[j])
        });
        by_input.or_else(|| {
            group.iter().find_map(|&r| {
                // SAFETY: as above.
                let rec = unsafe { record(&self.records, r) };
                rec.corner.into_iter().find(|&w| {
                    w != children[0] && w != children[1] && !h.is_leaf(w) && h.contains(w, leaf)
                })
            })
        })
    }

    /// The active node standing for `leaf` (Tao et al.'s `g(v)`), walking up from the leaf.
    pub fn representative(&self, h: &Hierarchy, leaf: u32) -> u32 {
        let mut w = leaf;
        while self.state(w) == BELOW {
            w = h.parent[w as usize];
        }
        w
    }

    pub(super) fn new_record(&mut self, record: Record) -> u32 {
        match self.free_records.pop() {
            Some(r) => {
                self.records[r as usize] = record;
                r
            }
            None => {
                self.records.push(record);
                self.records.len() as u32 - 1
            }
        }
    }

    /// `vsplit(u)`: `u` leaves the front for its two children.
    pub fn split(&mut self, h: &Hierarchy, u: u32) {
        debug_assert!(
            self.can_split(h, u),
            "split of {u}, which is not an active internal node"
        );
        let children = h.children(u);
        // Leaves below `mid` are the first child's (see `Internal`).
        let mid = h.internal[(u - h.leaf_count) as usize].mid;
        let side = |leaf: u32| (leaf >= mid) as usize;
        let mut l = self.deactivate(u, SPLIT);
        self.activate(children[0]);
        self.activate(children[1]);
        // The children's lists, built here and stored at the end.
        let mut heads = [NIL; 2];
        self.pending.clear();
        // Whether two live triangles may now have the same corners (see `Front::finish`).
        let mut coincident = false;
        // The other corners of the triangles around u, with their leaf ranges: the appearing
        // triangles' outside corners are among them (see `Candidates`).
        self.candidates.len = 0;
        // The triangles around u go to the child holding their input corner. Drawn ones are
        // rewritten at once, while their record is at hand.
        while l != NIL {
            let (r, k) = Self::unlink(l);
            // SAFETY: `l` is a link `Front::link` made (not `NIL`), whose corner is below 3.
            unsafe { std::hint::assert_unchecked(k < 3) };
            // SAFETY: `r` comes from a list link, see `record`.
            let rec = unsafe { record_mut(&mut self.records, r) };
            debug_assert_eq!(rec.corner[k], u);
            let next = rec.next[k];
            let slot = rec.slot;
            // Around a manifold vertex each neighbour follows u in one triangle (elsewhere the
            // search below finds the ones missed).
            self.candidates.add(h, rec.corner[NEXT[k]]);
            let i = side(rec.input[k]);
            rec.corner[k] = children[i];
            rec.next[k] = heads[i];
            heads[i] = Self::link(r, k);
            let corners = rec.corner;
            if slot == HIDDEN {
                // It had the same corners as another triangle around u, which may have gone to
                // the other child (looked at below).
                self.pending.push(r);
            } else {
                // SAFETY: `slot` is the slot of a drawn record.
                unsafe { self.drawn.write(slot, corners) };
            }
            l = next;
        }
        // A hidden triangle is drawn unless another one with its corners went to the same child.
        for i in 0..self.pending.len() {
            let corners = self.records[self.pending[i] as usize].corner;
            let child = has_corner(corners, children[1]) as usize;
            coincident |= self.has_coincident(heads[child], self.pending[i]);
        }
        // The triangles whose corners u kept together appear: corners 0 and 1 in different
        // children, corner 2 outside u's subtree. Two of them coincide when they have the same
        // outside corner; none coincides with another triangle, which has at most one of the
        // children for a corner.
        let mut outsides = [NIL; 8];
        for (n, t) in h.appearing(u).enumerate() {
            let input = h.triangles[t as usize];
            let i = side(input[0]);
            debug_assert_eq!(side(input[1]), 1 - i);
            let outside = match self.candidates.holding(input[2]) {
                Some(w) => w,
                None => {
                    self.collect_group(&heads);
                    self.outside_corner(h, &self.group, children, input[2])
                        .unwrap_or_else(|| self.find_active_outside(h, u, input[2]))
                }
            };
            debug_assert_eq!(outside, self.representative(h, input[2]));
            let corner = [children[i], children[1 - i], outside];
            debug_assert!(outside != children[0] && outside != children[1]);
            match outsides.get_mut(n) {
                Some(slot) => *slot = outside,
                None => coincident = true,
            }
            let r = self.new_record(Record {
                corner,
                next: [heads[i], heads[1 - i], self.head[outside as usize]],
                input,
                triangle: t,
                slot: HIDDEN,
            });
            heads[i] = Self::link(r, 0);
            heads[1 - i] = Self::link(r, 1);
            self.head[outside as usize] = Self::link(r, 2);
            self.pending.push(r);
        }
        let appeared = h.appearing(u).len().min(outsides.len());
        coincident |= (1..appeared).any(|n| outsides[..n].contains(&outsides[n]));
        self.head[children[0] as usize] = heads[0];
        self.head[children[1] as usize] = heads[1];
        self.finish(&heads, coincident);
        self.splits += 1;
        #[cfg(feature = "trace")]
        if let Some(log) = &mut self.log {
            log.push(u);
        }
    }

    /// `vunify(p)`: the two children of `p` leave the front for `p`.
    pub fn unify(&mut self, h: &Hierarchy, p: u32) {
        debug_assert!(
            self.can_unify(h, p),
            "unify of {p}, whose children are not both active"
        );
        let [c0, c1] = h.children(p);
        let heads = [self.deactivate(c0, BELOW), self.deactivate(c1, BELOW)];
        self.activate(p);
        let mut head = NIL;
        self.pending.clear();
        self.seen.start();
        let mut added = 0;
        for (l, c, other) in [(heads[0], c0, c1), (heads[1], c1, c0)] {
            let mut l = l;
            while l != NIL {
                let (r, k) = Self::unlink(l);
                // SAFETY: `l` is a link `Front::link` made (not `NIL`), whose corner is below 3.
                unsafe { std::hint::assert_unchecked(k < 3) };
                // SAFETY: `r` comes from a list link, see `record`.
                let rec = unsafe { record_mut(&mut self.records, r) };
                debug_assert_eq!(rec.corner[k], c);
                let next = rec.next[k];
                let slot = rec.slot;
                if slot == DYING {
                    // Marked by the first child's walk.
                } else if has_corner(rec.corner, other) {
                    // Both children were corners: the triangle degenerates.
                    self.drawn.release(&mut self.records, r);
                    self.records[r as usize].slot = DYING;
                    self.dying.push(r);
                } else {
                    rec.corner[k] = p;
                    rec.next[k] = head;
                    head = Self::link(r, k);
                    let corners = rec.corner;
                    if slot == HIDDEN {
                        self.pending.push(r);
                    } else {
                        // SAFETY: `slot` is the slot of a drawn record.
                        unsafe { self.drawn.write(slot, corners) };
                    }
                    self.seen.add(&self.records, r, corners, added);
                    added += 1;
                }
                l = next;
            }
        }
        self.head[p as usize] = head;
        // The degenerated triangles leave their third corner's list and free their records.
        for i in 0..self.dying.len() {
            let r = self.dying[i];
            // SAFETY: `r` comes from a list link, see `record`.
            let c = unsafe { record(&self.records, r) }.corner;
            self.unlink_from(c[0] ^ c[1] ^ c[2] ^ c0 ^ c1, r);
            self.free_records.push(r);
        }
        self.dying.clear();
        self.finish(&[head], self.seen.coincident);
        self.unifies += 1;
        #[cfg(feature = "trace")]
        if let Some(log) = &mut self.log {
            log.push(!p);
        }
    }

    /// Whether the list from link `l` holds a record other than `r` with `r`'s corners.
    pub(super) fn has_coincident(&self, mut l: u32, r: u32) -> bool {
        let corners = key(self.records[r as usize].corner);
        while l != NIL {
            let (q, k) = Self::unlink(l);
            let rec = &self.records[q as usize];
            if q != r && key(rec.corner) == corners {
                return true;
            }
            l = rec.next[k];
        }
        false
    }

    /// The records in `lists` (each a list head), once each, into `group`: an operation's group,
    /// collected only when it is needed.
    #[cold]
    pub(super) fn collect_group(&mut self, lists: &[u32]) {
        self.group.clear();
        for &l in lists {
            let mut l = l;
            while l != NIL {
                let (r, k) = Self::unlink(l);
                self.group.push(r);
                l = self.records[r as usize].next[k];
            }
        }
        // An appearing triangle is in both children's lists.
        self.group.sort_unstable();
        self.group.dedup();
    }

    /// The end of an operation whose new nodes head `lists`. The triangles in them are every live
    /// triangle that got new corners (so every triangle coincident with one of them is there
    /// too), drawn ones already rewritten; `pending` holds those of them to draw (a split's
    /// appearing triangles and hidden ones that no longer coincide with another). Unless the
    /// operation found that two of them may now coincide (4 % of operations), they are drawn;
    /// otherwise [`Front::settle`] picks one of each set.
    pub(super) fn finish(&mut self, lists: &[u32], coincident: bool) {
        if coincident {
            self.collect_group(lists);
            let group = std::mem::take(&mut self.group);
            self.settle(&group);
            self.group = group;
        } else {
            for i in 0..self.pending.len() {
                let r = self.pending[i];
                self.drawn.draw(&mut self.records[r as usize], r);
            }
        }
        #[cfg(debug_assertions)]
        {
            // Exactly one triangle of each set of coincident ones is drawn.
            self.collect_group(lists);
            let mut keyed: Vec<(u128, bool)> = (self.group.iter())
                .map(|&r| {
                    let rec = &self.records[r as usize];
                    (key(rec.corner), rec.slot != HIDDEN)
                })
                .collect();
            keyed.sort_unstable();
            for run in keyed.chunk_by(|a, b| a.0 == b.0) {
                let drawn = run.iter().filter(|x| x.1).count();
                assert_eq!(
                    drawn,
                    1,
                    "{} coincident triangles, {drawn} drawn",
                    run.len()
                );
            }
        }
    }

    /// Of each set of coincident triangles in `group` one is drawn (one already drawn, if any, to
    /// keep slots still) and the others are released; the rest of the group is drawn.
    #[cold]
    pub(super) fn settle(&mut self, group: &[u32]) {
        let mut keyed = std::mem::take(&mut self.keyed);
        keyed.clear();
        keyed.extend(
            group
                .iter()
                .map(|&r| (key(self.records[r as usize].corner), r)),
        );
        keyed.sort_unstable();
        for run in keyed.chunk_by(|a, b| a.0 == b.0) {
            let keeper = run
                .iter()
                .find(|&&(_, r)| self.records[r as usize].slot != HIDDEN)
                .unwrap_or(&run[0])
                .1;
            for &(_, r) in run {
                if r != keeper {
                    self.drawn.release(&mut self.records, r);
                }
            }
            self.drawn.draw(&mut self.records[keeper as usize], keeper);
        }
        self.keyed = keyed;
    }

    /// Takes record `r` out of active node `w`'s list.
    pub(super) fn unlink_from(&mut self, w: u32, r: u32) {
        // The link that points at the current record: the head, or a record's `next`.
        let mut at: Option<(u32, usize)> = None;
        let mut l = self.head[w as usize];
        while l != NIL {
            let (q, k) = Self::unlink(l);
            // SAFETY: `l` is a link `Front::link` made (not `NIL`), whose corner is below 3, and
            // `q` comes from it, see `record`.
            unsafe { std::hint::assert_unchecked(k < 3) };
            // SAFETY: as above.
            let next = unsafe { record(&self.records, q) }.next[k];
            if q == r {
                match at {
                    None => self.head[w as usize] = next,
                    // SAFETY: as above.
                    Some((q, j)) => unsafe { record_mut(&mut self.records, q) }.next[j] = next,
                }
                return;
            }
            at = Some((q, k));
            l = next;
        }
        debug_assert!(false, "record {r} is not in the list of node {w}");
    }
}

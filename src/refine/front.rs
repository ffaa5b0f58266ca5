//! The live front: the current vertex chain (a cut through the tree) and the current triangle chain,
//! changed one `vsplit` / `vunify` at a time, in any order the tree allows.
//!
//! # Why per-node triangle lists, not Hoppe's legality conditions
//! Hoppe's view-dependent progressive meshes (1997 §5) split and unify through neighbour pointers of a
//! manifold neighbourhood and allow an operation only where that neighbourhood is the one it was built
//! with. Our trees merge vertices that share no edge and handle non-manifold input, so there is no such
//! neighbourhood. We keep Luebke & Erikson's (1997) rule instead, which holds for any order:
//!
//! * every live triangle's corners are the active ancestors of its input corners (seed 001's `g(v)`);
//! * a triangle is live exactly when its lowest pairwise common ancestor is split
//!   ([`Hierarchy::appearing`]), i.e. when its three corners are distinct;
//! * of live triangles with the same three corners (coincident, seed 001 Fig. 3b) one is drawn.
//!
//! Each active node heads a list of the live triangles around it, threaded through the triangles
//! themselves (`next[t][k]` follows corner `k`), so a split or unify costs time in proportion to the
//! triangles around the node and never scans the front or the triangle list. Coincident triangles share
//! all three corners, so all of them are in the lists an operation walks: resolving which is drawn
//! stays local too.
//!
//! # Output
//! Vertices are the tree's nodes, by node id: a renderer uploads [`Hierarchy::position`] once and then
//! only the vertices a geomorph moves. Drawn triangles are packed at the front of [`Front::indices`]
//! (removal swaps the last one into the hole), and the blocks written since the last
//! [`Front::take_dirty`] are reported as ranges.

use super::hierarchy::{Hierarchy, NIL};

/// Node states. A node is `ACTIVE` on the front, `SPLIT` above it, `BELOW` under it.
pub const BELOW: u8 = 0;
pub const ACTIVE: u8 = 1;
pub const SPLIT: u8 = 2;

/// `slot` of a triangle that is not live (two corners coincide).
const DEAD: u32 = u32::MAX;
/// `slot` of a live triangle that is not drawn: another live triangle has the same corners.
const HIDDEN: u32 = u32::MAX - 1;

fn key(mut c: [u32; 3]) -> [u32; 3] {
    c.sort_unstable();
    c
}

/// Up to this many triangles around an operation, coincident ones are looked for by comparing every
/// pair; more (rare: high-valence nodes of coarse fronts) are sorted.
const SCAN_LIMIT: usize = 32;

/// Dirty tracking granularity, in triangles: one bit per 64 triangles (768 bytes of indices).
const DIRTY_BLOCK: u32 = 64;

/// The live state of one view of a [`Hierarchy`].
pub struct Front {
    state: Vec<u8>,
    /// First live triangle around each active node.
    head: Vec<u32>,
    /// Position of each active node in `active`.
    front_index: Vec<u32>,
    /// The active nodes, in no particular order.
    active: Vec<u32>,
    /// Current corners of each triangle: exact while it is live, otherwise ancestors of its input
    /// corners that [`Front::find_active`] starts from.
    corner: Vec<[u32; 3]>,
    next: Vec<[u32; 3]>,
    /// Draw slot of each triangle, or `HIDDEN` / `DEAD`.
    slot: Vec<u32>,
    /// Drawn triangles as node ids, packed.
    indices: Vec<[u32; 3]>,
    slot_triangle: Vec<u32>,
    dirty: Vec<u64>,
    group: Vec<([u32; 3], u32)>,
    pub splits: u64,
    pub unifies: u64,
}

impl Front {
    /// The coarsest front: the root alone, no triangle.
    pub fn new(h: &Hierarchy) -> Front {
        let nodes = h.node_count() as usize;
        let triangles = h.triangles.len();
        let root = h.root();
        let mut state = vec![BELOW; nodes];
        state[root as usize] = ACTIVE;
        let mut front_index = vec![NIL; nodes];
        front_index[root as usize] = 0;
        Front {
            state,
            head: vec![NIL; nodes],
            front_index,
            active: vec![root],
            corner: h.triangles.clone(),
            next: vec![[NIL; 3]; triangles],
            slot: vec![DEAD; triangles],
            indices: Vec::new(),
            slot_triangle: Vec::new(),
            dirty: Vec::new(),
            group: Vec::new(),
            splits: 0,
            unifies: 0,
        }
    }

    pub fn state(&self, u: u32) -> u8 {
        self.state[u as usize]
    }

    pub fn is_active(&self, u: u32) -> bool {
        self.state[u as usize] == ACTIVE
    }

    /// The active nodes (the current vertex chain), in no particular order.
    pub fn active(&self) -> &[u32] {
        &self.active
    }

    /// The drawn triangles, as node ids (vertex indices into the node arrays).
    pub fn indices(&self) -> &[[u32; 3]] {
        &self.indices
    }

    pub fn triangle_count(&self) -> usize {
        self.indices.len()
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
        let len = self.indices.len() as u32;
        let mut out: Vec<std::ops::Range<u32>> = Vec::new();
        for (w, bits) in self.dirty.iter_mut().enumerate() {
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
            + self.front_index.capacity() * 4
            + self.active.capacity() * 4
            + self.corner.capacity() * size_of::<[u32; 3]>()
            + self.next.capacity() * size_of::<[u32; 3]>()
            + self.slot.capacity() * 4
            + self.indices.capacity() * size_of::<[u32; 3]>()
            + self.slot_triangle.capacity() * 4
            + self.dirty.capacity() * 8
    }

    fn activate(&mut self, u: u32) {
        self.state[u as usize] = ACTIVE;
        self.front_index[u as usize] = self.active.len() as u32;
        self.active.push(u);
    }

    fn deactivate(&mut self, u: u32, to: u8) {
        self.state[u as usize] = to;
        let i = self.front_index[u as usize] as usize;
        let last = self.active.pop().expect("an active node is on the front");
        if last != u {
            self.active[i] = last;
            self.front_index[last as usize] = i as u32;
        }
        self.front_index[u as usize] = NIL;
    }

    /// The corner of live triangle `t` at node `u`.
    #[inline]
    fn corner_at(&self, t: u32, u: u32) -> usize {
        let c = self.corner[t as usize];
        debug_assert!(c.contains(&u), "triangle {t} {c:?} is not around {u}");
        (c[1] == u) as usize + 2 * (c[2] == u) as usize
    }

    #[inline]
    fn push_around(&mut self, u: u32, t: u32, k: usize) {
        self.next[t as usize][k] = self.head[u as usize];
        self.head[u as usize] = t;
    }

    /// The active node standing for `leaf`, starting from `from`, an ancestor of it (or itself).
    fn find_active(&self, h: &Hierarchy, from: u32, leaf: u32) -> u32 {
        let mut w = from;
        while self.state[w as usize] == BELOW {
            w = h.parent[w as usize];
        }
        while self.state[w as usize] == SPLIT {
            w = h.child_toward(w, leaf);
        }
        w
    }

    /// The active node standing for `leaf` (seed 001's `g(v)`), walking up from the leaf.
    pub fn representative(&self, h: &Hierarchy, leaf: u32) -> u32 {
        self.find_active(h, leaf, leaf)
    }

    /// `vsplit(u)`: `u` leaves the front for its two children.
    pub fn split(&mut self, h: &Hierarchy, u: u32) {
        debug_assert!(
            self.can_split(h, u),
            "split of {u}, which is not an active internal node"
        );
        let [c0, c1] = h.children(u);
        self.deactivate(u, SPLIT);
        self.activate(c0);
        self.activate(c1);
        let mut group = std::mem::take(&mut self.group);
        group.clear();
        // The triangles around u go to the child holding their input corner.
        let mut t = std::mem::replace(&mut self.head[u as usize], NIL);
        while t != NIL {
            let k = self.corner_at(t, u);
            let next = self.next[t as usize][k];
            let c = h.child_toward(u, h.triangles[t as usize][k]);
            self.corner[t as usize][k] = c;
            self.push_around(c, t, k);
            group.push((key(self.corner[t as usize]), t));
            t = next;
        }
        // The triangles whose corners u kept together appear (corner 2 lies outside u's subtree).
        for t in h.appearing(u) {
            let input = h.triangles[t as usize];
            let outside = self.find_active(h, self.corner[t as usize][2], input[2]);
            let c = [
                h.child_toward(u, input[0]),
                h.child_toward(u, input[1]),
                outside,
            ];
            debug_assert!(c[0] != c[1] && c[1] != c[2] && c[0] != c[2]);
            self.corner[t as usize] = c;
            for (k, &v) in c.iter().enumerate() {
                self.push_around(v, t, k);
            }
            self.slot[t as usize] = HIDDEN;
            group.push((key(c), t));
        }
        self.settle(group);
        self.splits += 1;
    }

    /// `vunify(p)`: the two children of `p` leave the front for `p`.
    pub fn unify(&mut self, h: &Hierarchy, p: u32) {
        debug_assert!(
            self.can_unify(h, p),
            "unify of {p}, whose children are not both active"
        );
        let [c0, c1] = h.children(p);
        self.deactivate(c0, BELOW);
        self.deactivate(c1, BELOW);
        self.activate(p);
        let mut group = std::mem::take(&mut self.group);
        group.clear();
        for (c, other) in [(c0, c1), (c1, c0)] {
            let mut t = std::mem::replace(&mut self.head[c as usize], NIL);
            while t != NIL {
                let k = self.corner_at(t, c);
                let next = self.next[t as usize][k];
                if self.slot[t as usize] == DEAD {
                    // Died on the first child's walk; its links there are still readable.
                } else if self.corner[t as usize].contains(&other) {
                    // Both children were corners: the triangle degenerates. Its corners stay as they
                    // are (ancestors of the input corners) for `find_active` when it reappears.
                    let c3 = self.corner[t as usize];
                    let w = c3[3 - k - self.corner_at(t, other)];
                    self.unlink(w, t);
                    self.release(t);
                    self.slot[t as usize] = DEAD;
                } else {
                    self.corner[t as usize][k] = p;
                    self.push_around(p, t, k);
                    group.push((key(self.corner[t as usize]), t));
                }
                t = next;
            }
        }
        self.settle(group);
        self.unifies += 1;
    }

    /// Removes `t` from the list around `w` (a walk of that list: a few triangles).
    fn unlink(&mut self, w: u32, t: u32) {
        let kt = self.corner_at(t, w);
        let after = self.next[t as usize][kt];
        let mut x = self.head[w as usize];
        if x == t {
            self.head[w as usize] = after;
            return;
        }
        loop {
            let k = self.corner_at(x, w);
            let nx = self.next[x as usize][k];
            if nx == t {
                self.next[x as usize][k] = after;
                return;
            }
            debug_assert!(nx != NIL, "triangle {t} is not in the list of {w}");
            x = nx;
        }
    }

    /// After an operation: `group` holds every live triangle that got new corners, with its sorted
    /// corners. Those are all the triangles around the operation's new nodes, so every triangle
    /// coincident with one of them is in the group too. Of each set with the same corners one is
    /// drawn (the one already drawn, if any, to keep slots still); its indices are rewritten.
    fn settle(&mut self, mut group: Vec<([u32; 3], u32)>) {
        // Coincident triangles are rare: look for any before sorting (a dozen triangles, so a
        // quadratic scan is the cheaper test).
        let coincident = group.len() > SCAN_LIMIT
            || group
                .iter()
                .enumerate()
                .any(|(i, a)| group[..i].iter().any(|b| b.0 == a.0));
        if !coincident {
            for &(_, t) in &group {
                self.draw(t);
            }
            self.group = group;
            return;
        }
        group.sort_unstable();
        let mut i = 0;
        while i < group.len() {
            let key = group[i].0;
            let mut j = i + 1;
            while j < group.len() && group[j].0 == key {
                j += 1;
            }
            let run = &group[i..j];
            let keeper = run
                .iter()
                .find(|&&(_, t)| self.slot[t as usize] < HIDDEN)
                .unwrap_or(&run[0])
                .1;
            for &(_, t) in run {
                if t != keeper {
                    self.release(t);
                    self.slot[t as usize] = HIDDEN;
                }
            }
            self.draw(keeper);
            i = j;
        }
        self.group = group;
    }

    /// Gives live triangle `t` a slot if it has none and writes its corners there.
    fn draw(&mut self, t: u32) {
        let mut s = self.slot[t as usize];
        if s >= HIDDEN {
            s = self.indices.len() as u32;
            self.indices.push([0; 3]);
            self.slot_triangle.push(t);
            self.slot[t as usize] = s;
        }
        self.indices[s as usize] = self.corner[t as usize];
        self.mark(s);
    }

    /// Takes `t` out of the drawn list (if it is there), moving the last drawn triangle into its slot.
    fn release(&mut self, t: u32) {
        let s = self.slot[t as usize];
        if s >= HIDDEN {
            return;
        }
        let last = self.indices.len() as u32 - 1;
        if s != last {
            let moved = self.slot_triangle[last as usize];
            self.indices[s as usize] = self.indices[last as usize];
            self.slot_triangle[s as usize] = moved;
            self.slot[moved as usize] = s;
            self.mark(s);
        }
        self.indices.pop();
        self.slot_triangle.pop();
        self.slot[t as usize] = HIDDEN;
    }

    fn mark(&mut self, slot: u32) {
        let block = (slot / DIRTY_BLOCK) as usize;
        let word = block / 64;
        if word >= self.dirty.len() {
            self.dirty.resize(word + 1, 0);
        }
        self.dirty[word] |= 1 << (block % 64);
    }

    /// Splits until every active node is a leaf: the input mesh.
    pub fn refine_all(&mut self, h: &Hierarchy) {
        let mut stack: Vec<u32> = self.active.clone();
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
            if self.state[p as usize] == SPLIT {
                self.unify(h, p);
            }
        }
    }
}

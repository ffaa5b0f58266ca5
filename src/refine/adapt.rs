//! The per-frame adaptation of the front (seed 001 §3.2, §4): visit active nodes, split where the view
//! asks for more detail, unify where it asks for less, amortised over frames, with geomorphs.

use super::criteria::{Camera, Tests, View};
use super::front::Front;
use super::hierarchy::{Hierarchy, NIL};
use glam::Vec3;
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// What the front aims for.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Mode {
    /// Every visible node's projected error at most τ pixels.
    Tolerance,
    /// The smallest τ that keeps at most this many triangles drawn.
    Budget(u32),
}

#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Settings {
    /// τ: the screen-space error tolerance in pixels (the start value in budget mode). Default 1.
    pub tolerance_px: f32,
    pub mode: Mode,
    pub tests: Tests,
    /// A split node unifies again only once its projected error drops below `τ·(1 − hysteresis)`,
    /// so that a node near τ does not flip every frame. Default 0.1.
    pub hysteresis: f32,
    /// Amortisation: at most this many front nodes visited per frame, the next frame going on where
    /// this one stopped (seed 001 §4). `None`: visit until nothing changes. Default `None`.
    pub visit_limit: Option<usize>,
    /// Amortisation by time: stop visiting after this long. Default `None`.
    pub time_limit: Option<Duration>,
    /// Geomorph length in frames; 0 turns geomorphs off. Default 0.
    pub geomorph_frames: u32,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            tolerance_px: 1.0,
            mode: Mode::Tolerance,
            tests: Tests::default(),
            hysteresis: HYSTERESIS,
            visit_limit: None,
            time_limit: None,
            geomorph_frames: 0,
        }
    }
}

/// A tenth of τ: wide enough that rounding and small camera jitter do not toggle a node, narrow
/// enough that the front stays within 10 % of the tolerance.
const HYSTERESIS: f32 = 0.1;

/// Budget mode moves τ by this factor a frame: fast enough to follow a fly-in (τ halves in ~7
/// frames), slow enough not to overshoot.
const BUDGET_STEP: f32 = 1.1;
/// Budget mode aims between these shares of N; splits that would exceed N are refused outright.
const BUDGET_BAND: (f32, f32) = (0.9, 0.98);

/// The look-ahead's stages, in visits ahead of the cursor (see [`Refiner::look_ahead`]). A visit
/// takes ~40 ns and a load from memory ~150 ns here, so each stage comes a few visits after the one
/// whose loads it needs. First the data of the visit (`VISIT_AHEAD`) and of its parent
/// (`PARENT_AHEAD`, which needs the parent id); then its view tests are decided early
/// (`DECIDE_AHEAD`) and the data of the operation they ask for is asked for
/// ([`Front::prefetch_split`]); then the records around it, one hop along its lists per stage
/// (`RECORDS_AHEAD`, [`Front::prefetch_lists`]): a list is a pointer chase, which no single
/// prefetch can cover. Sixteen stages three visits apart cover lists of up to sixteen records
/// (an operation walks about two dozen, in one or two lists) with a hop's load time between
/// stages; eight stages two visits apart gave 6–8 % fewer operations a second in the loop.
const VISIT_AHEAD: usize = 72;
const PARENT_AHEAD: usize = 62;
const DECIDE_AHEAD: usize = 52;
const RECORDS_AHEAD: [usize; 16] = [49, 46, 43, 40, 37, 34, 31, 28, 25, 22, 19, 16, 13, 10, 7, 4];
/// Decisions made ahead, by list position modulo this (a power of two above `DECIDE_AHEAD`).
const RING: usize = 64;

/// What the view tests ask of an active node: both depend only on the node and the view, so a
/// decision made a few visits early holds when the visit comes (the front's state, which can
/// change meanwhile, is checked then).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Decision {
    node: u32,
    /// Split the node.
    split: bool,
    /// Unify its parent (weighed from the first child only: the second would ask the same);
    /// `None` when not weighed because the parent could not unify then (its second child was not
    /// on the front), which the visit checks again.
    unify_parent: Option<bool>,
}

const UNDECIDED: Decision = Decision {
    node: NIL,
    split: false,
    unify_parent: Some(false),
};

/// A hint for the memory system: what visiting front node `u` reads — its position, view data and
/// parent — or, at the `parent` stage (which needs the first one's load of the parent id), what weighing
/// its parent for a unify reads.
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

/// A clock for the short spans of single operations: the time-stamp counter where there is one
/// (about 10 ns a read here, where `Instant::now` takes about 23 ns, a tenth of an operation),
/// converted to seconds against `Instant` over each frame; nanoseconds elsewhere.
#[inline(always)]
fn ticks() -> u64 {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: reading the time-stamp counter has no preconditions.
    unsafe {
        core::arch::x86_64::_rdtsc()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        static EPOCH: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
        EPOCH.get_or_init(Instant::now).elapsed().as_nanos() as u64
    }
}

/// The start of a timed span: [`ticks`] once everything before has finished, and before anything
/// after starts (Intel's "How to Benchmark Code Execution Times on Intel IA-32 and IA-64", 2010,
/// with `lfence`, which orders the counter read on both makers' processors, for `cpuid`). Read
/// without fences, the counter drifts into the work around it: the fly-in's operations came out
/// 10 % cheaper that way, part of their work overlapping the visits around them. Fenced, an
/// operation is charged all of its own work and none of that overlap: the conservative figure.
#[inline(always)]
fn span_start() -> u64 {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: fences and the time-stamp counter have no preconditions.
    unsafe {
        use core::arch::x86_64::{_mm_lfence, _rdtsc};
        _mm_lfence();
        let t = _rdtsc();
        _mm_lfence();
        t
    }
    #[cfg(not(target_arch = "x86_64"))]
    ticks()
}

/// The end of a timed span: [`ticks`] once everything in it has finished.
#[inline(always)]
fn span_end() -> u64 {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: as for `span_start`.
    unsafe {
        use core::arch::x86_64::{_mm_lfence, _rdtsc};
        _mm_lfence();
        _rdtsc()
    }
    #[cfg(not(target_arch = "x86_64"))]
    ticks()
}

/// What an empty span measures, the least of a few: taken off each operation's span, so that an
/// operation is charged its own work and not the fences' and the counter's (10 ns here at the
/// least, 20 at the median). The least, so that none is charged less than its work.
fn span_overhead() -> u64 {
    (0..16)
        .map(|_| {
            let t0 = span_start();
            span_end().wrapping_sub(t0)
        })
        .min()
        .unwrap_or(0)
}

/// What one frame did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct FrameStats {
    pub active_vertices: u32,
    pub triangles: u32,
    pub splits: u32,
    pub unifies: u32,
    /// Front nodes examined.
    pub visited: u32,
    /// Vertices moving in a geomorph.
    pub morphing: u32,
    /// Time spent adapting, in seconds.
    pub refine_secs: f64,
    /// Of that, time spent inside the splits and unifies themselves: what the operations cost in
    /// the loop, with the look-ahead's prefetching. Each is timed by the time-stamp counter
    /// between fences, less what an empty span measures this frame (see `span_overhead`).
    pub operation_secs: f64,
    /// τ used this frame (varies in budget mode).
    pub tolerance_px: f32,
    /// A whole sweep of the front went by without a change.
    pub converged: bool,
}

#[derive(Clone, Copy, Debug)]
struct Morph {
    from: Vec3,
    to: Vec3,
    frame: u32,
    /// Set on the two children of a node about to unify: the unify happens when they arrive.
    unify_into: u32,
}

/// The runtime: a front, its settings, and the state carried from frame to frame.
pub struct Refiner {
    pub front: Front,
    pub settings: Settings,
    cursor: usize,
    /// Visits since the last change; a whole front's worth means converged.
    quiet_visits: usize,
    morphs: HashMap<u32, Morph>,
    /// (node, position) pairs the renderer must write this frame.
    vertex_updates: Vec<(u32, Vec3)>,
    budget_tau: f32,
    /// The camera and τ of the last frame: a convergence holds only while they stay.
    last_view: Option<(Camera, f32, Settings)>,
    /// Time spent in splits and unifies this frame, in [`ticks`].
    operation_ticks: u64,
    /// What an empty span measures this frame, in [`ticks`].
    span_overhead: u64,
    /// Decisions made ahead of the cursor, by list position modulo `RING`.
    ahead: [Decision; RING],
    /// The list position of the last decision made ahead that asks for an operation: until the
    /// cursor passes it, visits prefetch along its lists.
    operation_ahead: usize,
}

impl Refiner {
    pub fn new(h: &Hierarchy, settings: Settings) -> Refiner {
        Refiner::starting_from(Front::new(h), settings)
    }

    /// A runtime whose first frame adapts `front` (for instance [`Front::at_cut`]) instead of the
    /// root alone.
    pub fn starting_from(front: Front, settings: Settings) -> Refiner {
        Refiner {
            front,
            settings,
            cursor: 0,
            quiet_visits: 0,
            morphs: HashMap::new(),
            vertex_updates: Vec::new(),
            budget_tau: settings.tolerance_px,
            last_view: None,
            ahead: [UNDECIDED; RING],
            operation_ahead: 0,
            operation_ticks: 0,
            span_overhead: 0,
        }
    }

    /// Vertex positions changed this frame by geomorphs (node id, displayed position). Every other
    /// vertex stands at [`Hierarchy::position`].
    pub fn vertex_updates(&self) -> &[(u32, Vec3)] {
        &self.vertex_updates
    }

    /// The front (for its indices and dirty ranges) and this frame's vertex updates, together: what
    /// a renderer uploads.
    pub fn output(&mut self) -> (&mut Front, &[(u32, Vec3)]) {
        (&mut self.front, &self.vertex_updates)
    }

    /// Where node `u` is drawn now.
    pub fn displayed(&self, h: &Hierarchy, u: u32) -> Vec3 {
        match self.morphs.get(&u) {
            Some(m) => m.from.lerp(m.to, self.morph_t(m)),
            None => h.position[u as usize],
        }
    }

    fn morph_t(&self, m: &Morph) -> f32 {
        (m.frame as f32 / self.settings.geomorph_frames.max(1) as f32).min(1.0)
    }

    /// Adapts the front to one frame seen from `camera`.
    pub fn update(&mut self, h: &Hierarchy, camera: &Camera) -> FrameStats {
        let start = Instant::now();
        let start_ticks = ticks();
        self.span_overhead = span_overhead();
        let view = View::new(camera);
        let (splits0, unifies0) = (self.front.splits, self.front.unifies);
        self.vertex_updates.clear();
        self.front.make_room();
        self.advance_morphs(h);

        let tau = match self.settings.mode {
            Mode::Tolerance => self.settings.tolerance_px,
            Mode::Budget(n) => {
                let t = self.front.triangle_count() as f32;
                if t > BUDGET_BAND.1 * n as f32 {
                    self.budget_tau *= BUDGET_STEP;
                } else if t < BUDGET_BAND.0 * n as f32 {
                    self.budget_tau /= BUDGET_STEP;
                }
                self.budget_tau = self.budget_tau.clamp(1e-3, 1e6);
                self.budget_tau
            }
        };
        let this_view = Some((*camera, tau, self.settings));
        if self.last_view != this_view {
            self.quiet_visits = 0;
            self.last_view = this_view;
        }
        let cap = match self.settings.mode {
            Mode::Budget(n) => n as usize,
            Mode::Tolerance => usize::MAX,
        };
        // The front list goes back into memory order between sweeps (see `Front::sort_active`): at
        // the start of each frame when every frame sweeps until nothing changes, at the end of
        // each sweep when amortised (a sort mid-sweep would move nodes past the cursor).
        let amortised = self.settings.visit_limit.is_some() || self.settings.time_limit.is_some();
        if !amortised {
            self.front.sort_active();
            self.cursor = 0;
        }
        // Decisions are for this frame's view only.
        self.ahead = [UNDECIDED; RING];
        self.operation_ahead = 0;
        let limit = self.settings.visit_limit.unwrap_or(usize::MAX);
        let mut visited = 0usize;
        let mut converged = false;
        while visited < limit {
            if self.cursor >= self.front.list().len() {
                // (Unamortised, a frame of many operations, such as the first from the root, leaves
                // many stale entries: the next sweep need not step over them.)
                if amortised || self.front.stale_entries() > self.front.active_count() / 8 {
                    self.front.sort_active();
                }
                self.cursor = 0;
                self.operation_ahead = 0;
            }
            if self.quiet_visits >= self.front.active_count() {
                converged = true;
                break;
            }
            if let Some(t) = self.settings.time_limit
                && visited % 256 == 255
                && start.elapsed() >= t
            {
                break;
            }
            self.look_ahead(h, &view, tau);
            let u = self.front.list()[self.cursor];
            if !self.front.is_active(u) {
                // Left the front since it was listed.
                self.cursor += 1;
                continue;
            }
            visited += 1;
            if self.visit(h, &view, u, tau, cap) {
                // The front changed under the cursor: `u` left the front, and the next turn steps
                // over its entry.
                self.quiet_visits = 0;
            } else {
                self.quiet_visits += 1;
                self.cursor += 1;
            }
        }
        FrameStats {
            active_vertices: self.front.active_count() as u32,
            triangles: self.front.triangle_count() as u32,
            splits: (self.front.splits - splits0) as u32,
            unifies: (self.front.unifies - unifies0) as u32,
            visited: visited as u32,
            morphing: self.morphs.len() as u32,
            refine_secs: start.elapsed().as_secs_f64(),
            operation_secs: {
                // Ticks to seconds at the rate the frame's ticks went against its clock.
                let frame_ticks = ticks().saturating_sub(start_ticks).max(1);
                let ops = std::mem::take(&mut self.operation_ticks);
                ops as f64 * start.elapsed().as_secs_f64() / frame_ticks as f64
            },
            tolerance_px: tau,
            converged,
        }
    }

    /// Works ahead of the cursor, so that the loads of the visits and operations to come overlap
    /// with this one's work instead of queueing after it. The front list is in memory order
    /// (mostly), and a visit or operation only changes it at the cursor and at its end: the
    /// entries ahead stay where they are until the cursor reaches them.
    fn look_ahead(&mut self, h: &Hierarchy, view: &View, tau: f32) {
        let list = self.front.list();
        let at = |i: usize| list.get(self.cursor + i).copied();
        if let Some(v) = at(VISIT_AHEAD) {
            prefetch_visit(h, v, false);
        }
        if let Some(v) = at(PARENT_AHEAD) {
            prefetch_visit(h, v, true);
        }
        if let Some(v) = at(DECIDE_AHEAD) {
            let slot = (self.cursor + DECIDE_AHEAD) % RING;
            // (A node that has left the front gets a decision too: its entry is dropped unused.)
            if self.ahead[slot].node != v {
                let d = self.decide(h, view, v, tau);
                if d.split {
                    self.front.prefetch_split(h, v);
                } else if d.unify_parent == Some(true) {
                    self.front.prefetch_unify(h, h.parent[v as usize]);
                }
                if d.split || d.unify_parent == Some(true) {
                    self.operation_ahead = self.cursor + DECIDE_AHEAD;
                }
                self.ahead[slot] = d;
            }
        }
        if self.operation_ahead <= self.cursor {
            return;
        }
        for (hop, ahead) in RECORDS_AHEAD.into_iter().enumerate() {
            let Some(v) = at(ahead) else { continue };
            let d = self.ahead[(self.cursor + ahead) % RING];
            if d.node == v {
                if hop == RECORDS_AHEAD.len() - 1 && (d.split || d.unify_parent == Some(true)) {
                    self.front.prefetch_scratch(!d.split);
                }
                if d.split {
                    self.front.prefetch_lists(h, &[v], hop, true);
                } else if d.unify_parent == Some(true) {
                    self.front
                        .prefetch_lists(h, &h.children(h.parent[v as usize]), hop, false);
                }
            }
        }
    }

    /// What the view tests ask of active node `u` (see [`Decision`]).
    #[inline(always)]
    fn decide(&self, h: &Hierarchy, view: &View, u: u32, tau: f32) -> Decision {
        let tests = self.settings.tests;
        let split = !h.is_leaf(u) && tests.visible(h, view, u) && tests.error_px(h, view, u) > tau;
        let p = h.parent[u as usize];
        let unify_parent = if split || p == NIL || h.children(p)[0] != u {
            Some(false)
        } else if self.front.can_unify(h, p) {
            Some(self.wants_unify(h, view, p, tau))
        } else {
            None
        };
        Decision {
            node: u,
            split,
            unify_parent,
        }
    }

    /// Decides about active node `u`; returns whether the front changed.
    fn visit(&mut self, h: &Hierarchy, view: &View, u: u32, tau: f32, cap: usize) -> bool {
        let tests = self.settings.tests;
        if !self.morphs.is_empty()
            && let Some(m) = self.morphs.get(&u)
            && m.unify_into != NIL
        {
            // Shrinking towards its parent: carry on unless the parent is wanted after all.
            let p = m.unify_into;
            if self.wants_unify(h, view, p, tau) {
                return false;
            }
            self.cancel_unify(h, p);
            return false;
        }
        let early = self.ahead[self.cursor % RING];
        let d = if early.node == u {
            early
        } else {
            self.decide(h, view, u, tau)
        };
        if d.split {
            return self.split(h, u, cap);
        }
        let p = h.parent[u as usize];
        let unify = match d.unify_parent {
            Some(wanted) => wanted,
            None => self.front.can_unify(h, p) && self.wants_unify(h, view, p, tau),
        };
        if unify && self.front.can_unify(h, p) {
            let instant = self.settings.geomorph_frames == 0 || !tests.visible(h, view, p);
            if instant {
                self.unify(h, p);
                return true;
            }
            self.start_unify(h, p);
        }
        false
    }

    fn wants_unify(&self, h: &Hierarchy, view: &View, p: u32, tau: f32) -> bool {
        let tests = self.settings.tests;
        !tests.visible(h, view, p)
            || (tests.screen_error
                && tests.error_px(h, view, p) < tau * (1.0 - self.settings.hysteresis))
    }

    /// Splits `u` unless that would draw more than `cap` triangles; returns whether it did.
    fn split(&mut self, h: &Hierarchy, u: u32, cap: usize) -> bool {
        // Appearing triangles are an upper bound on the growth, except where the split parts
        // coincident triangles; that rare case is undone below.
        if self.front.triangle_count() + h.appearing(u).len() > cap {
            return false;
        }
        let from = self.displayed(h, u);
        let t0 = span_start();
        self.front.split(h, u);
        let undo = self.front.triangle_count() > cap;
        if undo {
            self.front.unify(h, u);
        }
        self.add_span(t0);
        if undo {
            return false;
        }
        if self.morphs.remove(&u).is_some() {
            self.vertex_updates.push((u, h.position[u as usize]));
        }
        if self.settings.geomorph_frames > 0 {
            for c in h.children(u) {
                self.morphs.insert(
                    c,
                    Morph {
                        from,
                        to: h.position[c as usize],
                        frame: 0,
                        unify_into: NIL,
                    },
                );
                self.vertex_updates.push((c, from));
            }
        }
        true
    }

    fn unify(&mut self, h: &Hierarchy, p: u32) {
        for c in h.children(p) {
            if self.morphs.remove(&c).is_some() {
                self.vertex_updates.push((c, h.position[c as usize]));
            }
        }
        let t0 = span_start();
        self.front.unify(h, p);
        self.add_span(t0);
    }

    /// Counts the span from `t0` (a [`span_start`]) to now as operation time.
    #[inline(always)]
    fn add_span(&mut self, t0: u64) {
        let span = span_end().wrapping_sub(t0);
        self.operation_ticks += span.saturating_sub(self.span_overhead);
    }

    /// The reverse geomorph: both children move to the parent's position, then unify.
    fn start_unify(&mut self, h: &Hierarchy, p: u32) {
        self.morph_children(h, p, true);
    }

    /// The parent is wanted again halfway through a reverse geomorph: the children go back.
    fn cancel_unify(&mut self, h: &Hierarchy, p: u32) {
        self.morph_children(h, p, false);
    }

    /// Starts both children of `p` moving from where they are drawn now towards the parent
    /// (`inwards`, then unify) or back to their own positions.
    fn morph_children(&mut self, h: &Hierarchy, p: u32, inwards: bool) {
        for c in h.children(p) {
            let morph = Morph {
                from: self.displayed(h, c),
                to: h.position[if inwards { p } else { c } as usize],
                frame: 0,
                unify_into: if inwards { p } else { NIL },
            };
            self.morphs.insert(c, morph);
        }
    }

    /// One frame of every geomorph; finished reverse geomorphs unify.
    fn advance_morphs(&mut self, h: &Hierarchy) {
        if self.morphs.is_empty() {
            return;
        }
        let frames = self.settings.geomorph_frames;
        let mut arrived = Vec::new();
        let mut unify = Vec::new();
        for (&u, m) in self.morphs.iter_mut() {
            m.frame += 1;
            if frames == 0 || m.frame >= frames {
                arrived.push(u);
                if m.unify_into != NIL {
                    unify.push(m.unify_into);
                }
            }
        }
        for u in arrived {
            self.morphs.remove(&u);
            self.vertex_updates.push((u, h.position[u as usize]));
        }
        unify.sort_unstable();
        unify.dedup();
        for p in unify {
            if self.front.can_unify(h, p) {
                self.unify(h, p);
            }
        }
        let updates: Vec<(u32, Vec3)> = self
            .morphs
            .iter()
            .map(|(&u, m)| (u, m.from.lerp(m.to, self.morph_t(m))))
            .collect();
        self.vertex_updates.extend(updates);
    }
}

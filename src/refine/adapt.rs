//! The per-frame adaptation of the front (Tao et al. §3.2, §4): visit active nodes, split where the view
//! asks for more detail, unify where it asks for less, amortised over frames, with geomorphs.

use super::criteria::{Camera, NodeView, Tests, View};
use super::front::Front;
use super::hierarchy::{Hierarchy, NIL};
use super::stream::{EXPIRED, Entry, Stream};
use super::trace::OpClock;
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
    /// this one stopped (Tao et al. §4). `None`: visit until nothing changes. Default `None`.
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

/// Above this share of the front weighed in a frame, margins cost more than they save (see
/// [`Refiner::update`]) ...
const PLAIN_ABOVE: f32 = 0.5;
/// ... and this many frames then weigh every entry the plain way.
const PLAIN_FRAMES: u32 = 8;

/// A tenth of τ: wide enough that rounding and small camera jitter do not toggle a node, narrow
/// enough that the front stays within 10 % of the tolerance.
const HYSTERESIS: f32 = 0.1;

/// Budget mode moves τ by this factor a frame: fast enough to follow a fly-in (τ halves in ~7
/// frames), slow enough not to overshoot.
const BUDGET_STEP: f32 = 1.1;
/// Budget mode: at most this many extra steps of τ within one frame whose sweeps refused splits
/// for the budget (growing steps: ten reach 1.1⁵⁵ ≈ 190×), so that a first frame at τ = 1 px
/// reaches the budget's τ at once instead of staying fine on one side and coarse on the other for
/// the half second that steps of 1.1 a frame took.
const BUDGET_RETUNES: i32 = 12;
/// Budget mode aims between these shares of N; splits that would exceed N are refused outright.
const BUDGET_BAND: (f32, f32) = (0.9, 0.98);

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
    /// Of that, time spent inside the splits and unifies themselves (for the benchmarks: 0 unless
    /// built with the `trace` feature, see `refine::trace`).
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
    /// The front in visiting order, with what visits read (see `refine::stream`).
    stream: Stream,
    /// The stream position the next sweep starts from.
    cursor: usize,
    /// Split children waiting to be visited, the next on top.
    children: Vec<Entry>,
    /// The front's operation count when the stream last matched it.
    ops_seen: u64,
    /// Visits since the last change; a whole front's worth means converged.
    quiet_visits: usize,
    morphs: HashMap<u32, Morph>,
    /// (node, position) pairs the renderer must write this frame.
    vertex_updates: Vec<(u32, Vec3)>,
    budget_tau: f32,
    /// The camera and τ of the last frame: a convergence holds only while they stay.
    last_view: Option<(Camera, f32, Settings)>,
    /// Time spent in splits and unifies this frame (benchmarks only, see `refine::trace`).
    clock: OpClock,
    /// Splits refused this frame because they would exceed the budget.
    refused: usize,
    /// How far the camera has travelled, by the measure the entries' margins are in: each frame
    /// adds the eye's move plus its turn times the farthest the model reaches from the eye.
    odometer: f64,
    /// The camera, τ and settings the odometer last measured from.
    travelled_from: Option<(Camera, f32, Settings)>,
    /// Entries are weighed only when their margin runs out (off: every frame weighs every one).
    margins: bool,
    /// The share of the front the last frame weighed.
    weighed_share: f32,
    /// Frames still to weigh every entry without computing margins, which cost more than they
    /// save while the camera turns or moves fast enough to use most of them up every frame.
    plain_frames: u32,
    /// Frames in a row that computed margins.
    margin_frames: u32,
}

impl Refiner {
    pub fn new(h: &Hierarchy, settings: Settings) -> Refiner {
        Refiner::starting_from(h, Front::new(h), settings)
    }

    /// A runtime whose first frame adapts `front` (for instance [`Front::at_cut`]) instead of the
    /// root alone.
    pub fn starting_from(h: &Hierarchy, front: Front, settings: Settings) -> Refiner {
        Refiner {
            stream: Stream::of_front(h, &front, settings.tests),
            ops_seen: front.splits + front.unifies,
            front,
            settings,
            cursor: 0,
            children: Vec::new(),
            quiet_visits: 0,
            morphs: HashMap::new(),
            vertex_updates: Vec::new(),
            budget_tau: settings.tolerance_px,
            last_view: None,
            clock: OpClock::default(),
            refused: 0,
            odometer: 0.0,
            travelled_from: None,
            margins: true,
            weighed_share: 0.0,
            plain_frames: 0,
            margin_frames: 0,
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

    /// Checks, the slow way, that the stream the visits walk is the front: every active node once,
    /// in the order of their leaves, with the view data of the node and its parent under the
    /// current tests. For tests (see [`super::validation::check_refiner`]).
    pub fn check_stream(&self, h: &Hierarchy) -> Result<(), String> {
        let entries = self.stream.entries();
        let mut want = self.front.active();
        want.sort_unstable_by_key(|&u| h.leaf_range(u).0);
        let got: Vec<u32> = entries.iter().map(|e| e.node).collect();
        if got != want {
            return Err(format!(
                "the stream lists {} nodes, the front has {} active: {:?}…",
                got.len(),
                want.len(),
                got.iter().zip(&want).find(|(a, b)| a != b)
            ));
        }
        let tests = self.stream.tests;
        match entries
            .iter()
            .find(|e| **e != Entry::new(h, &tests, e.node))
        {
            Some(e) => Err(format!("node {}'s entry holds stale data", e.node)),
            None => Ok(()),
        }
    }

    /// Heap bytes of the front and of the stream the visits walk.
    pub fn bytes(&self) -> usize {
        self.front.bytes() + self.stream.bytes()
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
        self.clock.start_frame();
        let view = View::new(camera);
        let (splits0, unifies0) = (self.front.splits, self.front.unifies);
        self.vertex_updates.clear();
        self.front.make_room();
        self.follow_front(h);
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
        self.refused = 0;
        let all = self.travel(h, camera, tau);
        // Margins pay while most entries outlast a frame. When a frame with margins from the frame
        // before still weighed most of the front (an orbit turns every entry's frustum margin
        // away), the next few weigh every entry the plain way; then margins are tried again.
        if self.plain_frames > 0 {
            self.plain_frames -= 1;
            self.margin_frames = 0;
        } else if self.margin_frames >= 2 && self.weighed_share > PLAIN_ABOVE {
            self.plain_frames = PLAIN_FRAMES - 1;
            self.margin_frames = 0;
        } else {
            self.margin_frames += 1;
        }
        let mut frame = Frame {
            view,
            tau,
            cap: match self.settings.mode {
                Mode::Budget(n) => n as usize,
                Mode::Tolerance => usize::MAX,
            },
            limit: self.settings.visit_limit.unwrap_or(usize::MAX),
            deadline: self.settings.time_limit.map(|t| start + t),
            now: self.odometer as f32,
            all,
            slack: 1e-5
                * (camera.position.abs().max_element()
                    + h.position[h.root() as usize].abs().max_element()
                    + h.radius(h.root())),
        };
        let mut visited = 0usize;
        let mut converged = false;
        let mut retunes = 0;
        loop {
            if self.quiet_visits >= self.stream.len() {
                if self.refused > 0 && retunes < BUDGET_RETUNES {
                    // Splits refused for the budget: the front stopped wherever the sweep ran out of
                    // room, fine on one side of the model and coarse on the other. Coarser everywhere
                    // makes room where the error is least, and the frame sweeps again; the steps
                    // grow (1.1, 1.1², 1.1³, …) so that a τ far off is reached in a few sweeps, and
                    // the per-frame steps bring back what they overshoot.
                    retunes += 1;
                    self.refused = 0;
                    self.budget_tau = (self.budget_tau * BUDGET_STEP.powi(retunes)).min(1e6);
                    frame.tau = self.budget_tau;
                    self.last_view = Some((*camera, frame.tau, self.settings));
                    self.quiet_visits = 0;
                    continue;
                }
                converged = true;
                break;
            }
            if visited >= frame.limit || frame.deadline.is_some_and(|d| Instant::now() >= d) {
                break;
            }
            let whole = self.cursor == 0;
            visited += self.sweep(h, &frame, frame.limit - visited);
            if self.cursor == self.stream.runs() {
                self.cursor = 0;
                if whole && self.settles_in_one_sweep() {
                    // Nothing a whole sweep left would change in another (see `settles_in_one_sweep`).
                    self.quiet_visits = self.stream.len();
                }
            }
        }
        self.ops_seen = self.front.splits + self.front.unifies;
        FrameStats {
            active_vertices: self.front.active_count() as u32,
            triangles: self.front.triangle_count() as u32,
            splits: (self.front.splits - splits0) as u32,
            unifies: (self.front.unifies - unifies0) as u32,
            visited: visited as u32,
            morphing: self.morphs.len() as u32,
            refine_secs: start.elapsed().as_secs_f64(),
            operation_secs: self.clock.frame_seconds(start.elapsed().as_secs_f64()),
            tolerance_px: frame.tau,
            converged,
        }
    }

    /// Moves the odometer on by how far the camera travelled since the last frame; returns
    /// whether every entry must be weighed this frame instead (the first frame, another τ, field
    /// of view, viewport, clip planes or settings, budget mode, or margins turned off).
    ///
    /// Every test but the frustum's reads only the eye's distance and direction to a sphere, and
    /// moving the eye by `δ` changes those as growing or shrinking the sphere by `δ` does. A frustum
    /// plane's signed distance to a point `x` changes by at most the eye's move plus the turn `θ`
    /// times `|x − eye|`, and every node's centre lies within the root's sphere. So a frame adds
    /// `|Δeye| + θ · (|eye − c_root| + r_root)`, and an entry weighed with margin `m` at odometer
    /// `t` cannot change before the odometer passes `t + m`.
    fn travel(&mut self, h: &Hierarchy, camera: &Camera, tau: f32) -> bool {
        let from = self.travelled_from.replace((*camera, tau, self.settings));
        let same = |a: &Camera| {
            a.fov_y_radians == camera.fov_y_radians
                && a.viewport_px == camera.viewport_px
                && a.near == camera.near
                && a.far == camera.far
        };
        let step = match from {
            Some((a, t, s))
                if self.margins
                    && self.settings.mode == Mode::Tolerance
                    && t == tau
                    && s == self.settings
                    && same(&a) =>
            {
                let (c, r) = (h.position[h.root() as usize], h.radius(h.root()));
                let moved = a.position.as_dvec3().distance(camera.position.as_dvec3());
                let cos = a
                    .orientation
                    .normalize()
                    .dot(camera.orientation.normalize());
                let turn = 2.0 * f64::from(cos.abs()).min(1.0).acos();
                let reach = f64::from(a.position.distance(c).max(camera.position.distance(c)) + r);
                moved + turn * reach * 1.001
            }
            _ => f64::INFINITY,
        };
        // Far past the margins' scale, f32 would round them away: start again from zero.
        if step.is_finite() && self.odometer + step < 1e3 * f64::from(h.diagonal.max(1e-30)) {
            self.odometer += step;
            // Rounded up, so that no margin outlasts the travel it was given.
            let now = self.odometer as f32;
            if f64::from(now) < self.odometer {
                self.odometer = f64::from(now.next_up());
            }
            false
        } else {
            self.odometer = 0.0;
            self.stream.expire();
            true
        }
    }

    /// Turns margins off (every frame weighs every entry) or on; for tests comparing the two.
    #[doc(hidden)]
    pub fn set_margins(&mut self, on: bool) {
        self.margins = on;
    }

    /// Whether one whole sweep leaves the front as the next would: in tolerance mode, without a
    /// cap and with no geomorph under way. Every entry written was weighed for a split after its
    /// own data and for a unify with its left neighbour, and the two tests agree (a node split
    /// because it is visible with an error above τ never wants its children unified, by the same
    /// numbers): nothing changes in a second sweep. Under a cap, a split refused early may fit once
    /// later unifies have made room; a geomorph changes the front between frames.
    fn settles_in_one_sweep(&self) -> bool {
        self.settings.mode == Mode::Tolerance && self.morphs.is_empty()
    }

    /// Keeps the stream in step with the front when something else changed the front (a caller
    /// through [`Refiner::output`] or `front`), or with the tests when the settings changed them.
    fn follow_front(&mut self, h: &Hierarchy) {
        if self.ops_seen != self.front.splits + self.front.unifies {
            self.stream = Stream::of_front(h, &self.front, self.settings.tests);
            self.ops_seen = self.front.splits + self.front.unifies;
            self.cursor = 0;
            self.quiet_visits = 0;
        } else if self.stream.tests != self.settings.tests {
            self.stream.regather(h, self.settings.tests);
        }
    }

    /// Visits entries from the cursor on, at most `limit` of them (and the children of any split
    /// among them), until the end of the stream or the frame's deadline; moves the cursor to the
    /// first entry not visited. Returns the visits made.
    fn sweep(&mut self, h: &Hierarchy, frame: &Frame, limit: usize) -> usize {
        // Which runs may change, found on every core first (not while a geomorph is under way,
        // which a visit moves on whatever its tests say).
        let settings = self.settings;
        let plain = self.margin_frames == 0;
        let changing = self.morphs.is_empty().then(|| {
            let (flags, weighed) = self.stream.changing(frame.now, frame.all, |e, paired| {
                if plain {
                    return (!Refiner::may_change(&settings, h, frame, e, paired)).then_some(0.0);
                }
                let settled = Refiner::settled(&settings, h, frame, e, paired);
                debug_assert_eq!(
                    settled.is_none(),
                    Refiner::may_change(&settings, h, frame, e, paired)
                );
                settled
            });
            self.weighed_share = weighed as f32 / self.stream.len().max(1) as f32;
            let lefts: Vec<u32> = (0..flags.len())
                .map(|k| self.stream.left_of_run(k))
                .collect();
            (flags, lefts)
        });
        let mut run = self.cursor;
        self.stream.begin(self.cursor);
        let mut visits = 0usize;
        // The last visit changed the front: the next entry's left neighbour is new.
        let mut after_change = false;
        let stop = |visits: usize| {
            visits >= limit
                || (visits % 256 == 255 && frame.deadline.is_some_and(|d| Instant::now() >= d))
        };
        'runs: while self.stream.has_run() {
            // A run where nothing would change, after a left neighbour that did not, stays.
            if let Some((flags, lefts)) = &changing
                && !flags[run]
                && self.stream.last().map_or(NIL, |l| l.node) == lefts[run]
            {
                self.quiet_visits += self.stream.pass();
                run += 1;
                continue;
            }
            if stop(visits) {
                break;
            }
            self.stream.take_run();
            run += 1;
            loop {
                if stop(visits) {
                    break 'runs;
                }
                let (e, until) = match self.children.pop() {
                    Some(child) => (child, EXPIRED),
                    None => match self.stream.next() {
                        Some(next) => next,
                        None => break,
                    },
                };
                // Nothing can change an entry before its time, unless its left neighbour is new
                // (it may now pair with its sibling): it is written back unweighed.
                if changing.is_some() && !after_change && until > frame.now {
                    self.stream.push_until(e, until);
                    self.quiet_visits += 1;
                    continue;
                }
                visits += 1;
                after_change = self.visit(h, frame, e);
                if after_change {
                    self.quiet_visits = 0;
                } else {
                    self.quiet_visits += 1;
                }
            }
        }
        // Children not visited before the limit stand where their parent stood, in order, and
        // are visited first in the next sweep.
        let resume = self.stream.written();
        while let Some(e) = self.children.pop() {
            self.stream.push(e);
        }
        self.stream.end();
        self.cursor = resume;
        visits
    }

    /// Whether a visit to entry `e` could change the front: its node would split or, beside its
    /// sibling (`paired`: its left neighbour is), their parent unify (the visit's tests, with a
    /// one-sided model's walk of triangles taken as a yes).
    fn may_change(
        settings: &Settings,
        h: &Hierarchy,
        frame: &Frame,
        e: &Entry,
        paired: bool,
    ) -> bool {
        let (tests, view, tau) = (&settings.tests, &frame.view, frame.tau);
        let split = !h.is_leaf(e.node)
            && tests.projected(view, &e.own) > tau
            && (h.one_sided || tests.sees(view, &e.own));
        let unify = paired
            && ((tests.screen_error
                && tests.projected(view, &e.up) < tau * (1.0 - settings.hysteresis))
                || !tests.sees(view, &e.up));
        split || unify
    }

    /// `None` when a visit to entry `e` could change the front: its node would split or, beside
    /// its sibling (`paired`: its left neighbour is), their parent unify (the visit's tests, with
    /// a one-sided model's walk of triangles taken as a yes). Else how far the camera may travel
    /// (the odometer's measure, see [`Refiner::travel`]) before a visit could: each test answers
    /// the same while the eye moves less than its margin (see [`View::below_margin`] and its
    /// neighbours), so the split stays refused while either of its conditions stays false, and
    /// the unify while both of its stay false. The strict bound reads the view's depth, which
    /// turns with the camera: there every frame weighs every entry, as without margins.
    fn settled(
        settings: &Settings,
        h: &Hierarchy,
        frame: &Frame,
        e: &Entry,
        paired: bool,
    ) -> Option<f32> {
        let (tests, view, tau) = (&settings.tests, &frame.view, frame.tau);
        let mut margin = f32::INFINITY;
        if !h.is_leaf(e.node) {
            let n = &e.own;
            let near = tests.projected(view, n) > tau;
            let (sees, sees_margin) = match h.one_sided {
                true => (true, 0.0),
                false => tests.sees_with_margin(view, n),
            };
            if near && sees {
                return None;
            }
            let mut split = 0f32;
            if !near && !tests.strict {
                split = view.below_margin(n.error, n.center, n.radius, tau);
            }
            if !sees {
                split = split.max(sees_margin);
            }
            margin = split;
        }
        if paired {
            let n = &e.up;
            let px = tau * (1.0 - settings.hysteresis);
            let coarse = tests.screen_error && tests.projected(view, n) < px;
            let (sees, sees_margin) = tests.sees_with_margin(view, n);
            if coarse || !sees {
                return None;
            }
            margin = margin.min(sees_margin);
            if tests.screen_error {
                margin = margin.min(view.above_margin(n.error, n.center, n.radius, px));
            }
        }
        if tests.strict {
            return Some(0.0);
        }
        Some((margin - frame.slack).max(0.0))
    }

    /// Decides about the active node of entry `e`, writing what stands there now to the stream
    /// (or, after a split, queueing the children's entries to be visited next); returns whether
    /// the front changed.
    fn visit(&mut self, h: &Hierarchy, frame: &Frame, e: Entry) -> bool {
        let tests = self.settings.tests;
        let (view, tau) = (&frame.view, frame.tau);
        let u = e.node;
        if !self.morphs.is_empty()
            && let Some(m) = self.morphs.get(&u)
            && m.unify_into != NIL
        {
            // Shrinking towards its parent: carry on unless the parent is wanted after all.
            let p = m.unify_into;
            if !self.wants_unify(h, view, p, &e.up, tau, &h.children(p)) {
                self.cancel_unify(h, p);
            }
            self.stream.push(e);
            return false;
        }
        // (The error first: it settles most nodes and costs less than the visibility tests.)
        if !h.is_leaf(u)
            && tests.projected(view, &e.own) > tau
            && self.shows(h, view, u, &e.own)
            && self.split(h, u, frame.cap)
        {
            let [c0, c1] = h.children(u);
            self.children.push(Entry::under(h, &tests, c1, &e));
            self.children.push(Entry::under(h, &tests, c0, &e));
            return true;
        }
        // Weigh the parent when both its children are on the front: `e` and its left neighbour.
        let mut e = e;
        let mut changed = false;
        while let Some(left) = self.stream.last()
            && e.pairs_with(left)
            && self.wants_unify(h, view, e.parent, &e.up, tau, &[left.node, e.node])
        {
            let p = e.parent;
            if self.settings.geomorph_frames > 0 && tests.sees(view, &e.up) {
                self.start_unify(h, p);
                break;
            }
            self.stream.pop();
            self.unify(h, p);
            e = Entry::new(h, &tests, p);
            changed = true;
        }
        self.stream.push(e);
        changed
    }

    /// Whether active node `u`, of gathered data `n`, may show: inside the view and not wholly
    /// facing away — or, on a one-sided mesh, a triangle it draws reaches into the view facing the
    /// eye all the same. See [`Refiner::would_show`].
    fn shows(&self, h: &Hierarchy, view: &View, u: u32, n: &NodeView) -> bool {
        self.would_show(h, view, u, n, &[u])
    }

    /// Whether node `u`, of gathered data `n`, would show with the triangles of active nodes
    /// `drawn` (`[u]` itself, or the two children a unify would replace by `u`), as `u` would draw
    /// them. The sphere and the cone bound the input `u` stands for, not the triangles it draws
    /// joined to refined neighbours: left coarse, the lit room's front wall, facing away, drew a
    /// folded triangle that faced the camera across the floor (issue 37; 34.5 dB at the worst
    /// frame of its fly-in). On a one-sided mesh, whose back faces are not drawn and which
    /// nothing closes behind them, a culled node refines after all where one of those triangles
    /// reaches into the view facing the eye. A closed two-sided model is left to the tests alone:
    /// there the front side hides what the back side draws, and walking the culled nodes' lists
    /// every frame took the dragon's fly-in from 0.83 to 1.5 ms a frame.
    fn would_show(&self, h: &Hierarchy, view: &View, u: u32, n: &NodeView, drawn: &[u32]) -> bool {
        let tests = self.settings.tests;
        if !tests.outside(view, n) && !tests.faces_away(view, n) {
            return true;
        } else if !h.one_sided {
            return false;
        }
        let at = |v: u32| h.position[if drawn.contains(&v) { u } else { v } as usize];
        drawn.iter().any(|&c| {
            self.front.any_drawn_around(c, |t| {
                let t = t.map(at);
                View::faces_eye(t, view.eye, h.inward) && !view.triangle_outside(t)
            })
        })
    }

    /// Whether split node `p`, of gathered data `up` and active `children`, should unify: it would
    /// not show ([`Refiner::would_show`]), or its error is below τ less the hysteresis.
    fn wants_unify(
        &self,
        h: &Hierarchy,
        view: &View,
        p: u32,
        up: &NodeView,
        tau: f32,
        children: &[u32],
    ) -> bool {
        let (tests, hysteresis) = (self.settings.tests, self.settings.hysteresis);
        (tests.screen_error && tests.projected(view, up) < tau * (1.0 - hysteresis))
            || !self.would_show(h, view, p, up, children)
    }

    /// Splits `u` unless that would draw more than `cap` triangles; returns whether it did.
    fn split(&mut self, h: &Hierarchy, u: u32, cap: usize) -> bool {
        // Appearing triangles are an upper bound on the growth, except where the split parts
        // coincident triangles; that rare case is undone below.
        if self.front.triangle_count() + h.appearing(u).len() > cap {
            self.refused += 1;
            return false;
        }
        let from = self.displayed(h, u);
        let t0 = self.clock.start();
        self.front.split(h, u);
        let undo = self.front.triangle_count() > cap;
        if undo {
            self.front.unify(h, u);
        }
        self.clock.stop(t0);
        if undo {
            self.refused += 1;
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
        let t0 = self.clock.start();
        self.front.unify(h, p);
        self.clock.stop(t0);
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
        unify.retain(|&p| self.front.can_unify(h, p));
        for &p in &unify {
            self.unify(h, p);
        }
        if !unify.is_empty() {
            self.stream.merge(h, &unify);
            self.ops_seen = self.front.splits + self.front.unifies;
        }
        let updates: Vec<(u32, Vec3)> = self
            .morphs
            .iter()
            .map(|(&u, m)| (u, m.from.lerp(m.to, self.morph_t(m))))
            .collect();
        self.vertex_updates.extend(updates);
    }
}

/// One frame's view and limits, as every visit reads them.
struct Frame {
    view: View,
    tau: f32,
    /// Splits that would draw more triangles than this are refused (budget mode).
    cap: usize,
    /// At most this many visits.
    limit: usize,
    deadline: Option<Instant>,
    /// The odometer this frame (see [`Refiner::update`]).
    now: f32,
    /// Every entry is weighed, whatever its margin: the view changed otherwise than by a move.
    all: bool,
    /// Taken off every margin, against the rounding of the tests' own arithmetic.
    slack: f32,
}

//! The default schedule: passes of vertex-disjoint cheapest merges (meshoptimizer's scheme).

use super::Builder;
use super::PROGRESS_EVERY;
use super::finisher::PassResult;
use super::pricing::{PREFETCH_AHEAD, PRICE_CHUNK, PRICE_RUN};
use super::queue::{Entry, NO_EDGE, SLOT, key};
use crate::simplify::metric::Candidate;
use rayon::prelude::*;
use std::time::Instant;

/// Passes schedule: each pass aims to merge this share of the live vertices. Smaller is closer to
/// greedy order and slower (more passes); a sixth matches the greedy schedule's quality on every model
/// of the benchmark within a few per cent.
const PASS_SHARE: f64 = 1.0 / 6.0;
/// The last `TAIL_LIVE` live vertices merge in finer passes, `TAIL_PASS_SHARE` of them each: the
/// coarse levels of a small model and the top of every tree, where one merge is a large share of
/// what is left and a pass's batch of merges priced at its start strays furthest from greedy order.
/// On the benchmark's CAD-like models this brought cessna's mean error at 1 % from 1.13× to 0.92×
/// meshoptimizer's and beetle's max at 10 % from 2.13× to 1.18×, scans unchanged; being a fixed
/// count, it adds about a hundred small passes whatever the model's size.
const TAIL_LIVE: usize = 16_000;
const TAIL_PASS_SHARE: f64 = 1.0 / 15.0;
/// A pass stops at this multiple of the cost of its goal-th candidate (meshoptimizer's `kPassErrorBound`):
/// locked vertices make it skip many candidates, so it must reach somewhat past the goal's cost.
const PASS_COST_BOUND: f32 = 1.5;

/// A pass looks only at its cheapest `PASS_WINDOW × goal` candidates: locking skips about one in
/// three or four of them, and the cost bound stops most passes well before the window ends.
const PASS_WINDOW: usize = 4;

/// A pass may stop at the cost bound only after it has chosen more than `goal / LOCKS_PER_MERGE`
/// merges. On average each merge locks the pairs of about six others (the pairs around its two
/// vertices), so on meshes of odd topology most candidates can be locked; without this floor such a
/// pass would stop after a handful of merges (meshoptimizer's rule, with its reasoning).
const LOCKS_PER_MERGE: usize = 6;

/// A total order on entries (cost, then slots): where an entry stands in the list cannot matter.
fn order(e: &Entry) -> (u64, u32) {
    (((e.cost as u64) << 32) | e.a as u64, e.b)
}

/// The marks of the pass under way: `picked`, the ends of its chosen pairs (so no other pair may
/// use them); `changed`, the slots that merged (or died), whose pairs' prices are stale.
pub(super) struct PassMarks {
    pub(super) picked: SlotSet,
    pub(super) changed: SlotSet,
}

impl Builder<'_> {
    /// Merges until one vertex is left, pass by pass: rank the candidates, choose vertex-disjoint
    /// cheap ones, merge them (their nodes finished alongside), re-price the pairs around them.
    /// Candidates persist across passes; only the pairs around a pass's merges are re-priced.
    pub(super) fn run_passes(
        &mut self,
        mut cands: Vec<Entry>,
        radius: &mut f32,
        per_vertex: usize,
        progress: &mut dyn FnMut(usize, usize),
    ) {
        let total = self.mesh.positions.len() - 1;
        let n = self.mesh.positions.len();
        let mut marks = PassMarks {
            picked: SlotSet::new(n),
            changed: SlotSet::new(n),
        };
        let mut last_report = 0;
        let mut chosen: Vec<usize> = Vec::new();
        while self.collapser.live_count() > self.target_live {
            if cands.is_empty() && self.locked.is_some() {
                // Only pairs with a locked end are left: the cell is done.
                break;
            }
            if cands.is_empty() {
                // Separate parts, each collapsed to a point: pair the survivors.
                let pairs = self.widen(radius, per_vertex);
                cands.extend(pairs.into_iter().map(|(a, b)| Entry {
                    cost: key(self.price(a, b, false).cost),
                    a,
                    b: b | NO_EDGE,
                }));
                continue;
            }
            self.stats.rounds += 1;
            marks.picked.clear();
            marks.changed.clear();
            let clock = Instant::now();
            let live = self.collapser.live_count();
            let share = if live <= TAIL_LIVE {
                TAIL_PASS_SHARE
            } else {
                PASS_SHARE
            };
            let goal = ((live as f64 * share).ceil() as usize).max(1);
            // 1. Rank: the cheapest few goals' worth, sorted.
            let (window, head) = rank(&mut cands, goal);
            // 2. Choose vertex-disjoint pairs, cheapest first, and price them.
            choose(
                &mut cands,
                goal,
                window,
                head,
                &mut marks.picked,
                &mut chosen,
            );
            let priced = self.price_chosen(&cands, &chosen);
            self.stats.phases.pricing += clock.elapsed().as_secs_f64();
            // 3. Merge them, finishing their nodes alongside.
            let clock = Instant::now();
            let pass = self.merge_pass(&mut cands, &chosen, &priced, &mut marks);
            self.stats.phases.merging += clock.elapsed().as_secs_f64();
            // 4. Re-price: drop the stale pairs, price the survivors' pairs anew.
            let clock = Instant::now();
            self.reprice(&mut cands, pass, &marks);
            self.stats.phases.repricing += clock.elapsed().as_secs_f64();
            let done = self.merges() as usize;
            if done - last_report >= PROGRESS_EVERY {
                progress(done, total);
                last_report = done;
            }
        }
    }

    /// The chosen pairs priced in parallel (their quadrics and positions do not change within the
    /// pass).
    fn price_chosen(&self, cands: &[Entry], chosen: &[usize]) -> Vec<Candidate> {
        chosen
            .par_chunks(PRICE_RUN)
            .flat_map_iter(|run| {
                run.iter().enumerate().map(|(i, &index)| {
                    // Scattered pairs: load the ones a few ahead while this one is priced.
                    if let Some(&ahead) = run.get(i + PREFETCH_AHEAD / 2) {
                        let e = cands[ahead];
                        for s in [e.a as usize, (e.b & SLOT) as usize] {
                            super::pricing::prefetch_end(&self.ends, &self.colors, &self.charts, s);
                        }
                    }
                    let e = cands[index];
                    self.price(e.a, e.b & SLOT, e.b & NO_EDGE == 0)
                })
            })
            .collect()
    }

    /// Drops the pairs the pass made stale, adds those its finisher priced already, and prices
    /// the remaining survivors' pairs with partners in a pair of the pass (each pair once: of two
    /// survivors, the smaller slot's).
    fn reprice(&mut self, cands: &mut Vec<Entry>, pass: PassResult, marks: &PassMarks) {
        let PassResult {
            mut early,
            mut survivors,
            priced_early,
        } = pass;
        let PassMarks { picked, changed } = marks;
        par_retain(cands, |e| {
            !changed.contains(e.a) && !changed.contains(e.b & SLOT)
        });
        self.stats.pricings += early.len() as u64;
        cands.append(&mut early);
        let mut k = 0;
        survivors.retain(|_| {
            k += 1;
            !priced_early[k - 1]
        });
        let locked = self.locked.take();
        let fresh = self.price_around(&survivors, |s, other| {
            picked.contains(other)
                && !(changed.contains(other) && other < s)
                && !locked.as_ref().is_some_and(|l| l.contains(other))
        });
        self.locked = locked;
        cands.extend(fresh);
    }
}

/// Partitions `cands` so that its cheapest `window` entries come first, and sorts the first `head`
/// of them (the rest of the window is sorted only if the choice reaches it). Only the cheapest few
/// goals' worth can be reached in a pass; most passes stop in the first half of that.
fn rank(cands: &mut [Entry], goal: usize) -> (usize, usize) {
    let window = (goal * PASS_WINDOW).min(cands.len());
    let head = (goal * PASS_WINDOW / 2).min(window);
    if window < cands.len() {
        cands.select_nth_unstable_by_key(window, order);
    }
    if head < window {
        cands[..window].select_nth_unstable_by_key(head, order);
    }
    cands[..head].par_sort_unstable_by_key(order);
    (window, head)
}

/// Chooses up to `goal` vertex-disjoint pairs from the ranked window, cheapest first, into `chosen`
/// (indices into `cands`), marking their ends in `picked`. Stops past the cost bound.
fn choose(
    cands: &mut [Entry],
    goal: usize,
    window: usize,
    head: usize,
    picked: &mut SlotSet,
    chosen: &mut Vec<usize>,
) {
    // Within the sorted head when it matters (`goal < window`).
    let bound = cands
        .get(goal)
        .map_or(f32::INFINITY, |e| f32::from_bits(e.cost) * PASS_COST_BOUND);
    chosen.clear();
    for index in 0..window {
        if index == head {
            cands[head..window].par_sort_unstable_by_key(order);
        }
        let e = &cands[index];
        if chosen.len() >= goal
            || (chosen.len() > goal / LOCKS_PER_MERGE && f32::from_bits(e.cost) > bound)
        {
            break;
        }
        let (a, b) = (e.a, e.b & SLOT);
        if picked.contains(a) || picked.contains(b) {
            continue;
        }
        picked.insert(a);
        picked.insert(b);
        chosen.push(index);
    }
}

/// A set of slots, one bit each: the pass's marks stay in cache where a word per slot would not.
pub(super) struct SlotSet(Vec<u64>);

impl SlotSet {
    pub(super) fn new(n: usize) -> SlotSet {
        SlotSet(vec![0; n.div_ceil(64)])
    }
    pub(super) fn insert(&mut self, s: u32) {
        self.0[s as usize / 64] |= 1 << (s % 64);
    }
    pub(super) fn contains(&self, s: u32) -> bool {
        self.0[s as usize / 64] & (1 << (s % 64)) != 0
    }
    pub(super) fn clear(&mut self) {
        self.0.fill(0);
    }
}

/// `Vec::retain` on every thread: each chunk keeps its entries in place, then the chunks close up.
/// The order is a sequential `retain`'s.
pub(super) fn par_retain<T: Copy + Send + Sync>(v: &mut Vec<T>, keep: impl Fn(&T) -> bool + Sync) {
    let chunk = v
        .len()
        .div_ceil(rayon::current_num_threads())
        .max(PRICE_CHUNK);
    let kept: Vec<usize> = v
        .par_chunks_mut(chunk)
        .map(|part| {
            let mut n = 0;
            for i in 0..part.len() {
                if keep(&part[i]) {
                    part[n] = part[i];
                    n += 1;
                }
            }
            n
        })
        .collect();
    let mut end = 0;
    for (k, &n) in kept.iter().enumerate() {
        v.copy_within(k * chunk..k * chunk + n, end);
        end += n;
    }
    v.truncate(end);
}

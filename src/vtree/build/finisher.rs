//! The two-thread finisher: while one thread merges a pass's pairs, the other completes their nodes
//! (colour, normal, sphere, cone, error) and prices the survivors' pairs whose prices are final.

use super::node::{FanTriangle, Merged, SAMPLES, Samples, fan_of, finish_node};
use super::passes::{PassMarks, SlotSet};
use super::pricing::{PREFETCH_AHEAD, prefetch_end};
use super::queue::{Entry, NO_EDGE, SLOT, key};
use super::wedges::WedgeState;
use super::{Builder, NONE};
use crate::simplify::attribute_quadric::LocalAttributeQuadric;
use crate::simplify::collapse::gather_neighbors;
use crate::simplify::collapse::{Collapser, Neighbor, Vanish};
use crate::simplify::metric::{Candidate, PairEnd, Pricing};
use crate::vtree::Node;
use glam::Vec3;
use std::collections::VecDeque;
use std::sync::{Condvar, Mutex};

/// Merges handed to [`finish_node`] in one go, with the triangles and other partners around each
/// survivor as they were right after its merge.
#[derive(Default)]
pub(super) struct FinishBatch {
    pub(super) nodes: Vec<(Node, Merged)>,
    /// The fans of `nodes`, one after another; `fan_ends[i]` closes the i-th.
    pub(super) fans: Vec<FanTriangle>,
    pub(super) fan_ends: Vec<u32>,
    /// The survivors' partners by loose edges and proximity pairs, likewise.
    pub(super) extras: Vec<Neighbor>,
    pub(super) extra_ends: Vec<u32>,
    /// With wedges, the triangles that vanished in each merge, likewise (see [`WedgeTurns`]).
    pub(super) vanished: Vec<u32>,
    pub(super) vanished_ends: Vec<u32>,
    /// With wedges, each merge's node, and whether a triangle that vanished in it was degenerate
    /// (see [`WedgeState::merge`]).
    pub(super) ids: Vec<u32>,
    pub(super) joined: Vec<bool>,
    /// This batch's place in the pass's order of batches.
    pub(super) ticket: u64,
}

/// Merges per [`FinishBatch`] handed to the finishing thread (fewer when their fans reach
/// [`FINISH_FANS`] triangles). Passes with fewer than four batches' worth finish on the merging
/// thread, [`FINISH_HERE`] merges at a time, while their fans are still in cache.
pub(super) const FINISH_BATCH: usize = 256;
pub(super) const FINISH_FANS: usize = 2048;
pub(super) const FINISH_HERE: usize = 32;

/// What finishing a pass's nodes reads: none of it changes while the pass merges.
pub(super) struct PassView<'a> {
    /// The nodes of earlier passes.
    pub(super) done: &'a [Node],
    pub(super) leaves: &'a [Vec3],
    /// Every slot's pricing data as the pass began (the survivors' new data go to [`Places::ends`]).
    pub(super) ends: &'a [PairEnd],
    /// Every slot's attribute quadric likewise (empty without colours).
    pub(super) colors: &'a [LocalAttributeQuadric],
    /// With wedges, every slot's principal texture and each texture's scale likewise (empty
    /// without).
    pub(super) charts: &'a [u32],
    pub(super) scales: &'a [f32],
    /// The ends of the pairs chosen in the pass.
    pub(super) picked: &'a SlotSet,
    /// Slots that never merge (see `Builder::locked`): their pairs are never priced.
    pub(super) locked: Option<&'a SlotSet>,
    pub(super) pricing: Pricing,
    /// With wedges, their state, joined batch by batch in merge order.
    pub(super) wedges: Option<&'a WedgeTurns>,
}

/// The wedges of a pass's merges, joined on whichever thread finishes each batch, but one batch
/// at a time in merge order (each waits for its ticket): wedges are numbered exactly as on one
/// thread, and the merging thread, which needs none of this within the pass, never does it.
pub(super) struct WedgeTurns {
    /// The state, and the ticket whose turn it is.
    state: Mutex<(WedgeState, u64)>,
    turn: Condvar,
}

impl WedgeTurns {
    pub(super) fn new(state: WedgeState) -> WedgeTurns {
        WedgeTurns {
            state: Mutex::new((state, 0)),
            turn: Condvar::new(),
        }
    }

    pub(super) fn into_inner(self) -> WedgeState {
        let (state, _) = self
            .state
            .into_inner()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        state
    }

    /// Joins the wedges of `batch`'s merges, once every earlier batch's are, and sets each
    /// merge's principal wedge (`principals`: the slots' as the pass began).
    fn join(&self, batch: &mut FinishBatch, principals: &[LocalAttributeQuadric]) {
        let mut guard = self
            .state
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        while guard.1 != batch.ticket {
            guard = self
                .turn
                .wait(guard)
                .unwrap_or_else(|poisoned| poisoned.into_inner());
        }
        let state = &mut guard.0;
        let mut start = 0;
        for i in 0..batch.nodes.len() {
            for stage in 1..3 {
                if let Some((_, m)) = batch.nodes.get(i + (PREFETCH_AHEAD >> stage)) {
                    state.prefetch_merge(m.slot, m.gone, stage as u32);
                }
            }
            let end = batch.vanished_ends[i] as usize;
            let merged = &mut batch.nodes[i].1;
            let (quadric, texture, slide) = state.merge(
                (merged.slot, merged.gone),
                batch.ids[i],
                merged.position,
                batch.vanished[start..end].iter().copied(),
                batch.joined[i],
                principals,
            );
            merged.principal = Some((quadric, texture));
            merged.slide = slide;
            start = end;
        }
        guard.1 += 1;
        drop(guard);
        self.turn.notify_all();
    }
}

/// Where a batch's results go: its nodes, their kept samples, and whether all their pairs were
/// priced.
pub(super) struct Places<'a> {
    pub(super) nodes: &'a mut [Node],
    pub(super) kept: &'a mut [Samples],
    /// The survivors' pricing data ([`PairEnd::merged`]).
    pub(super) ends: &'a mut [PairEnd],
    /// The survivors' attribute quadrics (empty without colours).
    pub(super) colors: &'a mut [LocalAttributeQuadric],
    /// Every pair of the survivor priced: none waits for the pass to end.
    pub(super) priced: &'a mut [bool],
    /// With wedges, the survivors' principal textures (empty without).
    pub(super) charts: &'a mut [u32],
}

/// The part of a pass's outputs not yet handed to a batch.
impl<'a> Places<'a> {
    /// The next `n` places.
    pub(super) fn take(&mut self, n: usize) -> Places<'a> {
        let (nodes, rest) = std::mem::take(&mut self.nodes).split_at_mut(n);
        self.nodes = rest;
        let (kept, rest) = std::mem::take(&mut self.kept).split_at_mut(n);
        self.kept = rest;
        let (ends, rest) = std::mem::take(&mut self.ends).split_at_mut(n);
        self.ends = rest;
        let colors = std::mem::take(&mut self.colors);
        let (colors, rest) = colors.split_at_mut(n.min(colors.len()));
        self.colors = rest;
        let (priced, rest) = std::mem::take(&mut self.priced).split_at_mut(n);
        self.priced = rest;
        let charts = std::mem::take(&mut self.charts);
        let (charts, rest) = charts.split_at_mut(n.min(charts.len()));
        self.charts = rest;
        Places {
            nodes,
            kept,
            ends,
            colors,
            priced,
            charts,
        }
    }
}

/// A batch and where its results go.
pub(super) type Job<'a> = (FinishBatch, Places<'a>);

/// Batches waiting to be finished, shared by the merging thread and the finisher. The finisher
/// takes them oldest first; the merging thread takes the oldest back when more than
/// [`BACKLOG`] wait, and every one left once its merges are done, so that neither thread idles
/// while the other has work.
#[derive(Default)]
pub(super) struct Backlog<'a> {
    /// The jobs, and whether more will come.
    pub(super) queue: Mutex<(VecDeque<Job<'a>>, bool)>,
    pub(super) ready: Condvar,
}

pub(super) const BACKLOG: usize = 2;

impl<'a> Backlog<'a> {
    pub(super) fn lock(&self) -> std::sync::MutexGuard<'_, (VecDeque<Job<'a>>, bool)> {
        // A panicking thread holds no job: what it left is consistent.
        self.queue
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Queues `job`; returns the oldest job when too many wait.
    pub(super) fn push(&self, job: Job<'a>) -> Option<Job<'a>> {
        let mut q = self.lock();
        q.0.push_back(job);
        let back = (q.0.len() > BACKLOG).then(|| q.0.pop_front()).flatten();
        drop(q);
        self.ready.notify_one();
        back
    }

    /// The oldest job, if any.
    pub(super) fn take(&self) -> Option<Job<'a>> {
        self.lock().0.pop_front()
    }

    /// The oldest job, waiting for one; `None` once closed and empty.
    pub(super) fn wait(&self) -> Option<Job<'a>> {
        let mut q = self.lock();
        loop {
            if let Some(job) = q.0.pop_front() {
                return Some(job);
            }
            if q.1 {
                return None;
            }
            q = self
                .ready
                .wait(q)
                .unwrap_or_else(|poisoned| poisoned.into_inner());
        }
    }

    /// No more jobs will come.
    pub(super) fn close(&self) {
        self.lock().1 = true;
        self.ready.notify_all();
    }

    /// Closes the backlog, finishes here what the finisher has not started yet, then `last`
    /// (in this order: with wedges, each batch waits for the ones before it).
    pub(super) fn finish_last(&self, last: Job, view: &PassView, entries: &mut Vec<Entry>) {
        self.close();
        while let Some((batch, places)) = self.take() {
            batch.finish(view, places, entries);
        }
        let (batch, places) = last;
        batch.finish(view, places, entries);
    }
}

impl FinishBatch {
    pub(super) fn push(&mut self, c: &Collapser, node: Node, merged: Merged) {
        fan_of(c, merged.slot, &mut self.fans);
        self.fan_ends.push(self.fans.len() as u32);
        self.extras.extend(c.extra_neighbors(merged.slot));
        self.extra_ends.push(self.extras.len() as u32);
        self.nodes.push((node, merged));
    }

    /// With wedges, what joining merge `u`'s wedges reads besides its [`Merged`]: the triangles
    /// that vanished in it (see [`WedgeTurns`]).
    pub(super) fn push_vanished(&mut self, u: u32, removed: &[(u32, Vanish)]) {
        let vanished = removed.iter().map(|&(f, _)| f);
        self.joined
            .push(removed.iter().any(|&(_, v)| v == Vanish::Degenerate));
        self.ids.push(u);
        self.vanished.extend(vanished);
        self.vanished_ends.push(self.vanished.len() as u32);
    }

    /// Completes the nodes into `out`, and prices each survivor's pairs with partners in no pair
    /// of the pass into `entries` (see `run_passes`, step 5), marking in `out.priced` the survivors
    /// with no others. Returns the emptied batch for reuse.
    pub(super) fn finish(
        mut self,
        view: &PassView,
        out: Places,
        entries: &mut Vec<Entry>,
    ) -> FinishBatch {
        if let Some(turns) = view.wedges {
            turns.join(&mut self, view.colors);
        }
        let mut around = Vec::new();
        let (mut fan_start, mut extra_start) = (0, 0);
        for (i, &(mut node, merged)) in self.nodes.iter().enumerate() {
            // Children, samples and partners are scattered: start loading the next ones'.
            if let Some((next, m)) = self.nodes.get(i + PREFETCH_AHEAD) {
                for c in next.children {
                    crate::prefetch(&view.done[c as usize]);
                }
                for q in m.pending.into_iter().filter(|&q| q != NONE) {
                    crate::prefetch(&view.leaves[q as usize]);
                }
                prefetch_end(view.ends, view.colors, view.charts, m.slot as usize);
                prefetch_end(view.ends, view.colors, view.charts, m.gone as usize);
            }
            if let Some(&end) = self.fan_ends.get(i + PREFETCH_AHEAD / 2) {
                let start = self.fan_ends[i + PREFETCH_AHEAD / 2 - 1];
                for t in &self.fans[start as usize..end as usize] {
                    for v in t.slots {
                        prefetch_end(view.ends, view.colors, view.charts, v as usize);
                    }
                }
            }
            let (fan_end, extra_end) = (self.fan_ends[i], self.extra_ends[i]);
            let fan = &self.fans[fan_start as usize..fan_end as usize];
            let (s, g) = (merged.slot as usize, merged.gone as usize);
            let color = (!view.colors.is_empty()).then(|| match merged.principal {
                Some((q, _)) => q,
                None => PairEnd::merged_color(
                    (&view.ends[s], &view.colors[s]),
                    (&view.ends[g], &view.colors[g]),
                    merged.position,
                ),
            });
            out.kept[i] = finish_node(
                &mut node,
                view.done,
                &merged,
                fan,
                view.leaves,
                super::wedges::node_color(view.pricing.color_scale, color, merged.principal),
            );
            out.nodes[i] = node;
            if let Some((_, chart)) = merged.principal {
                out.charts[i] = chart;
            }
            let end = PairEnd::merged(&view.ends[s], &view.ends[g], merged.position);
            out.ends[i] = end;
            if let Some(c) = color {
                out.colors[i] = c;
            }

            gather_neighbors(
                merged.slot,
                fan.iter().map(|t| t.slots),
                self.extras[extra_start as usize..extra_end as usize]
                    .iter()
                    .copied(),
                &mut around,
            );
            let mut all = true;
            for n in &around {
                if view.locked.is_some_and(|l| l.contains(n.slot)) {
                    continue;
                }
                if view.picked.contains(n.slot) {
                    all = false;
                    continue;
                }
                let partner = n.slot as usize;
                let cand = match merged.principal {
                    Some((_, chart)) => super::wedges::price(
                        &view.pricing,
                        (&end, color.as_ref(), chart),
                        (
                            &view.ends[partner],
                            view.colors.get(partner),
                            view.charts[partner],
                        ),
                        n.edge,
                        view.scales,
                    ),
                    None => {
                        let colors = color.as_ref().map(|c| [c, &view.colors[partner]]);
                        view.pricing
                            .price(&end, &view.ends[partner], n.edge, colors)
                    }
                };
                entries.push(Entry {
                    cost: key(cand.cost),
                    a: merged.slot,
                    b: n.slot | if n.edge { 0 } else { NO_EDGE },
                });
            }
            out.priced[i] = all;
            (fan_start, extra_start) = (fan_end, extra_end);
        }
        self.nodes.clear();
        self.fans.clear();
        self.fan_ends.clear();
        self.extras.clear();
        self.extra_ends.clear();
        self.vanished.clear();
        self.vanished_ends.clear();
        self.ids.clear();
        self.joined.clear();
        self
    }
}

/// What each merge of a pass leaves its survivor, in merge order: its kept samples and pricing
/// data (attribute quadrics and, with wedges, principal textures: empty when there are none).
struct Survived {
    kept: Vec<Samples>,
    ends: Vec<PairEnd>,
    colors: Vec<LocalAttributeQuadric>,
    charts: Vec<u32>,
}

/// What a pass's merging hands on to its re-pricing.
pub(super) struct PassResult {
    /// Pairs the finisher priced already (their prices are final; see [`Builder::merge_pass`]).
    pub(super) early: Vec<Entry>,
    /// The surviving slot of each merge, in merge order.
    pub(super) survivors: Vec<u32>,
    /// Whether all of a survivor's pairs were priced early.
    pub(super) priced_early: Vec<bool>,
}

impl Builder<'_> {
    /// Merges the chosen pairs in cost order.
    ///
    /// The flip test must see the positions so far (earlier merges of this pass may have moved a
    /// neighbour), so it runs here, as in meshoptimizer. A merge that would flip a triangle goes
    /// back to the list at a penalty, as in the greedy schedule; left in place at its low cost, it
    /// would crowd the front of every later pass.
    ///
    /// Alongside, on a second thread as the merges hand them over: the new nodes' colour, normal,
    /// sphere, cone and error. Each depends only on finished nodes (its children, from earlier
    /// passes) and on the triangles around its slot right after its merge, which the merge copies
    /// out while they are in cache. The merges are sequential and memory-bound, so this work would
    /// otherwise wait for them; when the finisher falls behind, the merging thread finishes a
    /// batch itself.
    ///
    /// Also alongside: a survivor's pairs with partners in no pair of the pass. Such a pair's price
    /// can no longer change in the pass (the survivor has merged, the partner will not, and whether
    /// a triangle joins them changes only when one of them merges), so it is priced with the node.
    /// The pairs with partners in the pass wait for it to end ([`Builder::reprice`]).
    pub(super) fn merge_pass(
        &mut self,
        cands: &mut [Entry],
        chosen: &[usize],
        priced: &[Candidate],
        marks: &mut PassMarks,
    ) -> PassResult {
        let mut nodes = std::mem::take(&mut self.nodes);
        let first_new = nodes.len();
        // Room for every chosen merge; what flip tests defer is cut off below.
        nodes.resize(first_new + chosen.len(), bytemuck::Zeroable::zeroed());
        let mut kept = vec![[NONE; SAMPLES]; chosen.len()];
        let mut priced_early = vec![false; chosen.len()];
        let (done, new) = nodes.split_at_mut(first_new);
        // Read-only while the pass merges; each merge's new data waits in `new_ends`.
        let mut new_ends = vec![PairEnd::default(); chosen.len()];
        let colored = !self.colors.is_empty();
        let mut new_colors =
            vec![LocalAttributeQuadric::default(); if colored { chosen.len() } else { 0 }];
        let ends = std::mem::take(&mut self.ends);
        let colors = std::mem::take(&mut self.colors);
        let (charts, scales) = (
            std::mem::take(&mut self.charts),
            std::mem::take(&mut self.scales),
        );
        let turns = self.wedges.take().map(WedgeTurns::new);
        let mut new_charts = vec![0; if turns.is_some() { chosen.len() } else { 0 }];
        let locked = self.locked.take();
        let PassMarks { picked, changed } = marks;
        let view = PassView {
            done,
            leaves: self.leaf_positions,
            locked: locked.as_ref(),
            ends: &ends,
            colors: &colors,
            charts: &charts,
            scales: &scales,
            picked,
            pricing: self.pricing(),
            wedges: turns.as_ref(),
        };
        let view = &view;
        let mut survivors = Vec::new();
        let backlog = &Backlog::default();
        let early = std::thread::scope(|scope| {
            let threaded = self.finisher && chosen.len() >= 4 * FINISH_BATCH;
            let batch_len = if threaded { FINISH_BATCH } else { FINISH_HERE };
            let finisher = threaded.then(|| {
                scope.spawn(move || {
                    let mut entries = Vec::new();
                    while let Some((batch, places)) = backlog.wait() {
                        batch.finish(view, places, &mut entries);
                    }
                    entries
                })
            });
            // The places of the pass's outputs not handed out yet.
            let mut out = Places {
                nodes: new,
                kept: &mut kept,
                ends: &mut new_ends,
                colors: &mut new_colors,
                priced: &mut priced_early,
                charts: &mut new_charts,
            };
            let mut tickets = 0;
            let mut entries = Vec::new();
            let mut batch = FinishBatch::default();
            for (i, (&index, &cand)) in chosen.iter().zip(priced).enumerate() {
                self.prefetch_ahead(cands, chosen, i);
                let e = &mut cands[index];
                if self.defer_if_flips(e, &cand) {
                    continue;
                }
                let (a, b) = (e.a, e.b & SLOT);
                let pending = self.pending(a, b);
                let u = (first_new + survivors.len()) as u32;
                let (node, merged) = self.merge_topology(a, b, &cand, u, pending);
                if view.wedges.is_some() {
                    batch.push_vanished(u, &self.removed);
                }
                changed.insert(a);
                changed.insert(b);
                survivors.push(merged.slot);
                batch.push(&self.collapser, node, merged);
                if batch.nodes.len() == batch_len || batch.fans.len() >= FINISH_FANS {
                    batch.ticket = tickets;
                    tickets += 1;
                    let places = out.take(batch.nodes.len());
                    let job = (std::mem::take(&mut batch), places);
                    let back = match &finisher {
                        Some(_) => backlog.push(job),
                        None => Some(job),
                    };
                    if let Some((full, places)) = back {
                        batch = full.finish(view, places, &mut entries);
                    }
                }
            }
            batch.ticket = tickets;
            let places = out.take(batch.nodes.len());
            backlog.finish_last((batch, places), view, &mut entries);
            if let Some(finisher) = finisher {
                entries.extend(
                    finisher
                        .join()
                        .unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
                );
            }
            entries
        });
        (self.ends, self.colors) = (ends, colors);
        (self.charts, self.scales) = (charts, scales);
        self.wedges = turns.map(WedgeTurns::into_inner);
        self.locked = locked;
        nodes.truncate(first_new + survivors.len());
        self.nodes = nodes;
        let survived = Survived {
            kept,
            ends: new_ends,
            colors: new_colors,
            charts: new_charts,
        };
        self.store_pass(first_new, &survivors, survived);
        PassResult {
            early,
            survivors,
            priced_early,
        }
    }

    /// Starts loading what the merges a few after the `i`-th chosen one read: they are scattered
    /// over the mesh.
    fn prefetch_ahead(&self, cands: &[Entry], chosen: &[usize], i: usize) {
        for stage in 0..4 {
            if let Some(&next) = chosen.get(i + (PREFETCH_AHEAD >> stage)) {
                let e = cands[next];
                self.prefetch_merge(e.a, e.b & SLOT, stage);
            }
        }
    }

    /// Links a pass's new nodes (from `first_new`) to their children and stores what each merge
    /// left its survivor.
    fn store_pass(&mut self, first_new: usize, survivors: &[u32], survived: Survived) {
        for (k, (&slot, kept)) in survivors.iter().zip(survived.kept).enumerate() {
            let u = (first_new + k) as u32;
            for c in self.nodes[u as usize].children {
                self.nodes[c as usize].parent = u;
            }
            self.samples[slot as usize] = kept;
            self.ends[slot as usize] = survived.ends[k];
            if let Some(&chart) = survived.charts.get(k) {
                self.charts[slot as usize] = chart;
            }
            if let Some(&c) = survived.colors.get(k) {
                self.colors[slot as usize] = c;
            }
        }
    }
}

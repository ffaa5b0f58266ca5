//! The paper's schedule: strictly the cheapest pair each time, from one priority queue.

use super::queue::{Entry, NO_EDGE, Queued, SLOT, key};
use super::{Builder, PROGRESS_EVERY};
use crate::simplify::collapse::Neighbor;
use std::collections::BinaryHeap;
use std::time::Instant;

impl Builder<'_> {
    pub(super) fn run_greedy(
        &mut self,
        initial: Vec<Entry>,
        radius: &mut f32,
        per_vertex: usize,
        progress: &mut dyn FnMut(usize, usize),
    ) {
        let total = self.mesh.positions.len() - 1;
        let clock = Instant::now();
        let mut heap: BinaryHeap<Queued> = initial
            .into_iter()
            .map(|entry| Queued { entry, created: 0 })
            .collect();
        self.stats.phases.pricing += clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        let mut changed_at = vec![0u32; self.mesh.positions.len()];
        let mut neighbors: Vec<Neighbor> = Vec::new();
        loop {
            while let Some(Queued { entry: e, created }) = heap.pop() {
                self.stats.rounds += 1;
                let (a, b) = (e.a, e.b & SLOT);
                let c = &self.collapser;
                if !c.is_live(a)
                    || !c.is_live(b)
                    || changed_at[a as usize] > created
                    || changed_at[b as usize] > created
                {
                    continue; // stale
                }
                let cand = self.price(a, b, e.b & NO_EDGE == 0);
                let mut deferred = e;
                if self.defer_if_flips(&mut deferred, &cand) {
                    heap.push(Queued {
                        entry: deferred,
                        created: self.merges(),
                    });
                    continue;
                }
                let s = self.merge(a, b, &cand);
                let now = self.merges();
                changed_at[s as usize] = now;
                self.collapser.neighbors(s, &mut neighbors);
                self.stats.pricings += neighbors.len() as u64;
                for nb in &neighbors {
                    let cost = key(self.price(s, nb.slot, nb.edge).cost);
                    heap.push(Queued {
                        entry: Entry {
                            cost,
                            a: s,
                            b: nb.slot | if nb.edge { 0 } else { NO_EDGE },
                        },
                        created: now,
                    });
                }
                if (now as usize).is_multiple_of(PROGRESS_EVERY) {
                    progress(now as usize, total);
                }
            }
            if self.collapser.live_count() <= 1 {
                self.stats.phases.merging = clock.elapsed().as_secs_f64();
                break;
            }
            let now = self.merges();
            for (a, b) in self.widen(radius, per_vertex) {
                let cost = key(self.price(a, b, false).cost);
                heap.push(Queued {
                    entry: Entry {
                        cost,
                        a,
                        b: b | NO_EDGE,
                    },
                    created: now,
                });
            }
        }
    }
}

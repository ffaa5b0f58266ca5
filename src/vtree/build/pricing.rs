//! Pricing candidate pairs in parallel.

use super::Builder;
use super::queue::{Entry, NO_EDGE, key};
use crate::simplify::attribute_quadric::LocalAttributeQuadric;
use crate::simplify::collapse::Neighbor;
use crate::simplify::metric::PairEnd;
use rayon::prelude::*;

/// The sequential merge loop prefetches the slots of the merge this many ahead, the triangles
/// around them half as many ahead, those triangles' corners a quarter as many ahead, and the lists
/// the merge unlinks from an eighth as many ahead (see [`Builder::prefetch_merge`]).
pub(super) const PREFETCH_AHEAD: usize = 16;

/// Slots priced one after another by one thread, prefetching ahead within the run.
pub(super) const PRICE_RUN: usize = 256;

/// Slots priced per parallel batch (see [`Builder::price_around`]).
pub(super) const PRICE_CHUNK: usize = 1 << 14;

/// Asks for what pricing a pair reads of slot `s`: its end (one cache line), on a mesh with
/// colours its attribute quadric (124 bytes: the lines it spans), and with wedges its principal
/// texture (`charts`; a miss on it cost the textured dragon's build 4 % of its time). Only a hint.
pub(super) fn prefetch_end(
    ends: &[PairEnd],
    colors: &[LocalAttributeQuadric],
    charts: &[u32],
    s: usize,
) {
    crate::prefetch(&ends[s]);
    if let Some(c) = charts.get(s) {
        crate::prefetch(c);
    }
    if let Some(c) = colors.get(s) {
        let first = c as *const LocalAttributeQuadric as usize;
        let last = first + std::mem::size_of::<LocalAttributeQuadric>() - 1;
        for line in (first & !63..=last).step_by(64) {
            crate::prefetch_address(line);
        }
    }
}

impl Builder<'_> {
    /// `pairs` (`(a, b)` with `a < b`, sorted by `a`), priced in parallel.
    pub(super) fn price_pairs(&mut self, pairs: &[(u32, u32)], edge: bool) -> Vec<Entry> {
        self.stats.pricings += pairs.len() as u64;
        let this = &*self;
        pairs
            .par_chunks(PRICE_RUN)
            .flat_map_iter(|run| {
                run.iter().enumerate().map(move |(i, &(a, b))| {
                    // Sorted by `a`, so the `b` are the scattered ends: load a few ahead.
                    if let Some(&(_, ahead)) = run.get(i + PREFETCH_AHEAD) {
                        prefetch_end(&this.ends, &this.colors, &this.charts, ahead as usize);
                    }
                    Entry {
                        cost: key(this.price(a, b, edge).cost),
                        a,
                        b: b | if edge { 0 } else { NO_EDGE },
                    }
                })
            })
            .collect()
    }

    /// The pairs between each of `slots` and its neighbours for which `keep(slot, neighbour)` holds,
    /// priced in parallel. In chunks, so that rayon's per-thread vectors and their concatenation never
    /// hold the whole list twice (the first call prices every pair of the mesh).
    pub(super) fn price_around(
        &mut self,
        slots: &[u32],
        keep: impl Fn(u32, u32) -> bool + Sync,
    ) -> Vec<Entry> {
        let mut out = Vec::new();
        for chunk in slots.chunks(PRICE_CHUNK) {
            let part = self.price_chunk(chunk, &keep);
            out.extend_from_slice(&part);
        }
        self.stats.pricings += out.len() as u64;
        out
    }

    pub(super) fn price_chunk(
        &self,
        slots: &[u32],
        keep: &(impl Fn(u32, u32) -> bool + Sync),
    ) -> Vec<Entry> {
        slots
            .par_chunks(PRICE_RUN)
            .fold_with(
                (Vec::new(), Vec::new(), Vec::new()),
                |(mut out, mut here, mut next): (Vec<Entry>, Vec<Neighbor>, Vec<Neighbor>), run| {
                    if let Some(&first) = run.first() {
                        self.collapser.neighbors(first, &mut next);
                    }
                    for (i, &a) in run.iter().enumerate() {
                        // Scattered slots: load the next ones' triangles while this one is priced.
                        for stage in 0..3 {
                            if let Some(&ahead) = run.get(i + (PREFETCH_AHEAD >> stage)) {
                                self.collapser.prefetch(ahead, stage as u32);
                            }
                        }
                        // The neighbours of the next slot are known a slot ahead: load what pricing
                        // them reads (quadric, weight, position) while this slot's pairs are priced.
                        std::mem::swap(&mut here, &mut next);
                        if let Some(&ahead) = run.get(i + 1) {
                            self.collapser.neighbors(ahead, &mut next);
                            for nb in &next {
                                prefetch_end(
                                    &self.ends,
                                    &self.colors,
                                    &self.charts,
                                    nb.slot as usize,
                                );
                            }
                        }
                        for nb in here.iter().filter(|nb| keep(a, nb.slot)) {
                            let cost = key(self.price(a, nb.slot, nb.edge).cost);
                            out.push(Entry {
                                cost,
                                a,
                                b: nb.slot | if nb.edge { 0 } else { NO_EDGE },
                            });
                        }
                    }
                    (out, here, next)
                },
            )
            .map(|(out, _, _)| out)
            .reduce(Vec::new, |mut x, mut y| {
                x.append(&mut y);
                x
            })
    }
}

//! Candidate non-edge pairs: vertices closer than a threshold (Garland & Heckbert 1997 §3; Tao et al. §2.3
//! "any two vertices"). Found with a uniform grid, so each query looks at the cells around a point:
//! O(n) for surfaces, never O(n²).
//!
//! The grid is the points sorted by cell, each cell packed into one integer key (x, y, z fields, z
//! lowest): a column of cells (fixed x and y) is one contiguous run ordered by z, so a box of cells
//! around a point is one key range a column. Points are queried in key order, and each range's
//! bounds are the query's key plus a constant, so each column's range is found by a cursor that
//! only moves forward: no hash table and no search from scratch, and the grid is read as nearly
//! sequential streams. (It replaced a hash table of columns, a cache miss per lookup and 9 a point:
//! on the dragon the search went from 0.13 to 0.09 s, on a 14-million-triangle model from 8.5 to
//! 6.6 s.)
//!
//! A point keeps only its few nearest partners, which on a fine mesh lie a few edges away, while
//! the radius (a share of the model's size) may hold hundreds of points: a box as wide as the
//! radius around every point made the search grow with the square of the resolution (a
//! 100-million-triangle city spent 744 s in it). So [`close_pairs_near`] searches a box that
//! covers a shorter distance `near` first, and the whole radius only for the points whose partners
//! that does not settle: when a point has kept its partners among the points within `near`, every
//! point it did not look at is farther than all of them, and the answer is the same.

use glam::Vec3;
use rayon::prelude::*;

/// Bits of each cell coordinate in a key.
const FIELD_BITS: u32 = 21;
/// Cells the near box reaches on each side of a point's own.
const NEAR_CELLS: u32 = 2;
/// Cells the whole radius reaches at most: the cells are never narrower than the radius over
/// this, so that a point the near box does not settle costs at most this squared columns.
const MAX_REACH: u32 = 12;
/// Cells per axis at most: a few of a field's values are kept free, for the neighbours of the first
/// and last cells (coordinates start at `MAX_REACH + 1`, so that the first one's neighbours are
/// never negative).
const MAX_CELLS: f32 = ((1u32 << FIELD_BITS) - 4 - 2 * MAX_REACH) as f32;
/// Points a task sweeps with one set of cursors.
const SWEEP_CHUNK: usize = 8192;
/// How many of a point's close points are put in order at a time: more than a fine mesh's 2-ring
/// holds (which `keep` rejects), so one batch is usually enough.
const NEAREST_FIRST: usize = 32;

/// A point in the grid: its cell's key, its id and position.
#[derive(Clone, Copy)]
struct Gridded {
    key: u64,
    id: u32,
    p: Vec3,
}

/// For each point, up to `max_per_point` nearest others within `radius` for which `keep(i, j)` holds
/// (of equally near ones, the smaller id). Returns each pair once as `(min, max)` of the given ids,
/// sorted.
pub fn close_pairs(
    points: &[(u32, Vec3)],
    radius: f32,
    max_per_point: usize,
    keep: impl Fn(u32, u32) -> bool + Sync,
) -> Vec<(u32, u32)> {
    close_pairs_near(points, radius, radius, max_per_point, keep)
}

/// [`close_pairs`], the same pairs, for points most of which have their partners within `near`
/// (at most `radius`; a mesh's vertices, a few edge lengths): each point searches a box covering
/// `near` first, and the whole radius only when that did not settle its partners.
pub fn close_pairs_near(
    points: &[(u32, Vec3)],
    radius: f32,
    near: f32,
    max_per_point: usize,
    keep: impl Fn(u32, u32) -> bool + Sync,
) -> Vec<(u32, u32)> {
    if points.len() < 2 || radius <= 0.0 || max_per_point == 0 || !radius.is_finite() {
        return Vec::new();
    }
    let near = if near.is_finite() && near > 0.0 {
        near.clamp(radius * NEAR_CELLS as f32 / MAX_REACH as f32, radius)
    } else {
        radius
    };
    let (sorted, cell) = grid(points, near / NEAR_CELLS as f32);
    // What the near box covers for certain (any point this close is in it), and the cells the
    // whole radius reaches.
    let covered = (NEAR_CELLS as f32 * cell).min(radius);
    let c2 = covered * covered;
    let reach = ((radius / cell).ceil() as i64).clamp(1, MAX_REACH as i64 + 1);
    let field = |d: i64| d << FIELD_BITS;
    let column = |dx: i64, dy: i64, dz: i64| (field(field(dx)) + field(dy) + dz) as u64;
    let n = NEAR_CELLS as i64;
    // The near box's columns, as offsets from a cell's key to the key of the column's lowest cell.
    let columns: Vec<u64> = (-n..=n)
        .flat_map(|dx| (-n..=n).map(move |dy| column(dx, dy, -n)))
        .collect();
    let height = 2 * NEAR_CELLS as u64;
    let order = |a: &(f32, u32), b: &(f32, u32)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
    // Nearest first, and `keep` asked only until enough are kept: most close points of a fine mesh
    // are its own neighbours, which `keep` rejects. Only the nearest few are put in order, then the
    // rest if those were not enough. Returns how many were kept.
    let choose = |g: &Gridded, near: &mut Vec<(f32, u32)>, out: &mut Vec<(u32, u32)>| {
        let mut kept = 0;
        let mut from = 0;
        while kept < max_per_point && from < near.len() {
            let rest = &mut near[from..];
            let take = NEAREST_FIRST.min(rest.len());
            if take < rest.len() {
                rest.select_nth_unstable_by(take - 1, order);
            }
            rest[..take].sort_unstable_by(order);
            for &(_, other) in &rest[..take] {
                if kept < max_per_point && keep(g.id, other) {
                    out.push((g.id.min(other), g.id.max(other)));
                    kept += 1;
                }
            }
            from += take;
        }
        kept
    };
    let mut pairs: Vec<(u32, u32)> = sorted
        .par_chunks(SWEEP_CHUNK)
        .flat_map_iter(|part| {
            let first = part[0].key;
            let mut cursors: Vec<usize> = columns
                .iter()
                .map(|&offset| {
                    let low = first.wrapping_add(offset);
                    sorted.partition_point(|g| g.key < low)
                })
                .collect();
            let mut near: Vec<(f32, u32)> = Vec::new();
            let mut out = Vec::new();
            for g in part {
                near.clear();
                for (cursor, &offset) in cursors.iter_mut().zip(&columns) {
                    let low = g.key.wrapping_add(offset);
                    *cursor = seek(&sorted, *cursor, low);
                    for h in sorted[*cursor..]
                        .iter()
                        .take_while(|h| h.key <= low + height)
                    {
                        let d2 = g.p.distance_squared(h.p);
                        if h.id != g.id && d2 <= c2 {
                            near.push((d2, h.id));
                        }
                    }
                }
                let settled = out.len();
                if choose(g, &mut near, &mut out) == max_per_point || covered >= radius {
                    continue;
                }
                // Too few kept within `covered`: a box twice as wide, and so on to the whole
                // radius, a column at a time (few points get here: on a 100 M-triangle city, 6 %
                // at four edge lengths, 0.03 % at eight).
                let mut k = (2 * n).min(reach);
                loop {
                    out.truncate(settled);
                    near.clear();
                    let reached = (k as f32 * cell).min(radius);
                    let k2 = reached * reached;
                    for dx in -k..=k {
                        for dy in -k..=k {
                            let low = g.key.wrapping_add(column(dx, dy, -k));
                            let high = low + 2 * k as u64;
                            let start = sorted.partition_point(|h| h.key < low);
                            for h in sorted[start..].iter().take_while(|h| h.key <= high) {
                                let d2 = g.p.distance_squared(h.p);
                                if h.id != g.id && d2 <= k2 {
                                    near.push((d2, h.id));
                                }
                            }
                        }
                    }
                    if choose(g, &mut near, &mut out) == max_per_point || reached >= radius {
                        break;
                    }
                    k = (2 * k).min(reach);
                }
            }
            out
        })
        .collect();
    pairs.par_sort_unstable();
    pairs.dedup();
    pairs
}

/// The points sorted by cell key, and the cell's width: at least `cell` (a little more, so that
/// two points exactly a cell apart are never two cells apart by rounding), and wider where the
/// points span more cells than a key's fields hold.
fn grid(points: &[(u32, Vec3)], cell: f32) -> (Vec<Gridded>, f32) {
    let (low, high) = points.par_iter().map(|&(_, p)| (p, p)).reduce(
        || (Vec3::INFINITY, Vec3::NEG_INFINITY),
        |a, b| (a.0.min(b.0), a.1.max(b.1)),
    );
    let cell = (cell * 1.001).max((high - low).max_element() / MAX_CELLS);
    let mut sorted: Vec<Gridded> = points
        .par_iter()
        .map(|&(id, p)| {
            // Every cell within the reach has non-negative coordinates.
            let [x, y, z] = ((p - low) / cell)
                .floor()
                .to_array()
                .map(|c| c as u64 + MAX_REACH as u64 + 1);
            Gridded {
                key: (((x << FIELD_BITS) | y) << FIELD_BITS) | z,
                id,
                p,
            }
        })
        .collect();
    sorted.par_sort_unstable_by_key(|g| (g.key, g.id));
    (sorted, cell)
}

/// The first index at or after `from` whose key is at least `key`: a galloping search, since the
/// cursor usually moves by a few places.
fn seek(sorted: &[Gridded], from: usize, key: u64) -> usize {
    let mut step = 1;
    let mut low = from;
    while low < sorted.len() && sorted[low].key < key {
        low += step;
        step *= 2;
    }
    let start = low.saturating_sub(step / 2).max(from);
    let end = low.min(sorted.len());
    start + sorted[start..end].partition_point(|g| g.key < key)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_exactly_the_close_pairs() {
        // 0 and 1 are 0.5 apart, 2 is 0.9 from 1 and 1.4 from 0, 3 is far away.
        let pts = [
            (0, Vec3::ZERO),
            (1, Vec3::X * 0.5),
            (2, Vec3::X * 1.4),
            (3, Vec3::splat(10.0)),
        ];
        assert_eq!(close_pairs(&pts, 1.0, 8, |_, _| true), vec![(0, 1), (1, 2)]);
        assert_eq!(close_pairs(&pts, 1.0, 8, |i, j| i + j != 1), vec![(1, 2)]);
        assert_eq!(close_pairs(&pts, 0.4, 8, |_, _| true), vec![]);
    }

    #[test]
    fn matches_brute_force_on_random_points() {
        let mut rnd = crate::simplify::test_random(12345);
        let pts: Vec<(u32, Vec3)> = (0..400)
            .map(|i| (i, Vec3::new(rnd(), rnd(), rnd()) * 3.0 - 1.0))
            .collect();
        let got = close_pairs(&pts, 0.3, usize::MAX, |_, _| true);
        let mut want = Vec::new();
        for a in &pts {
            for b in &pts {
                if a.0 < b.0 && a.1.distance(b.1) <= 0.3 {
                    want.push((a.0, b.0));
                }
            }
        }
        assert_eq!(got, want);
    }

    /// The brute-force answer: for each point, its `max` nearest others within `radius` that `keep`
    /// accepts (ties to the smaller id), each pair once.
    fn brute_force(
        pts: &[(u32, Vec3)],
        radius: f32,
        max: usize,
        keep: impl Fn(u32, u32) -> bool,
    ) -> Vec<(u32, u32)> {
        let mut want = Vec::new();
        for a in pts {
            let mut near: Vec<(f32, u32)> = pts
                .iter()
                .filter(|b| b.0 != a.0 && a.1.distance_squared(b.1) <= radius * radius)
                .filter(|b| keep(a.0, b.0))
                .map(|b| (a.1.distance_squared(b.1), b.0))
                .collect();
            near.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            want.extend(
                near.iter()
                    .take(max)
                    .map(|&(_, b)| (a.0.min(b), a.0.max(b))),
            );
        }
        want.sort_unstable();
        want.dedup();
        want
    }

    #[test]
    fn nearest_kept_partners_match_brute_force_over_many_random_clouds() {
        for seed in 0..40u64 {
            let mut rnd = crate::simplify::test_random(seed);
            let n = 50 + (rnd() * 600.0) as u32;
            // Clustered on a few planes and lines, as a mesh's vertices are, with duplicates.
            let pts: Vec<(u32, Vec3)> = (0..n)
                .map(|i| {
                    let p = match i % 4 {
                        0 => Vec3::new(rnd(), rnd(), 0.0),
                        1 => Vec3::new(rnd(), 0.5, rnd()),
                        2 => Vec3::splat(rnd()),
                        _ => Vec3::new((rnd() * 8.0).floor() / 8.0, rnd(), 0.25),
                    };
                    (i * 3 + 7, p * 2.0 - 1.0)
                })
                .collect();
            let radius = 0.02 + rnd() * 0.2;
            let max = 1 + (rnd() * 4.0) as usize;
            let keep = |i: u32, j: u32| !(i ^ j).is_multiple_of(5);
            assert_eq!(
                close_pairs(&pts, radius, max, keep),
                brute_force(&pts, radius, max, keep),
                "seed {seed}"
            );
        }
    }

    /// A dense cloud (hundreds of points within the radius of each) and a `keep` that rejects
    /// all but about one in forty: the kept partners lie past several batches of
    /// `NEAREST_FIRST`, and are still the nearest kept ones, ties to the smaller id.
    #[test]
    fn kept_partners_beyond_the_first_nearest_batch_match_brute_force() {
        for seed in 0..6u64 {
            let mut rnd = crate::simplify::test_random(100 + seed);
            // A quarter of the points on a coarse lattice, so that many are equally near.
            let pts: Vec<(u32, Vec3)> = (0..1500u32)
                .map(|i| {
                    let p = Vec3::new(rnd(), rnd(), rnd() * 0.1);
                    let p = if i % 4 == 0 {
                        (p * 8.0).floor() / 8.0
                    } else {
                        p
                    };
                    (i, p)
                })
                .collect();
            let keep = |i: u32, j: u32| (i + j).is_multiple_of(41);
            for max in [1, 3] {
                let got = close_pairs(&pts, 0.3, max, keep);
                assert!(got.len() > 500, "seed {seed}: {} pairs", got.len());
                assert_eq!(got, brute_force(&pts, 0.3, max, keep), "seed {seed}");
            }
        }
    }

    /// Searching a shorter distance first changes nothing: for any `near`, from a twentieth of
    /// the radius (most points then settled in the near box, the rest by the whole radius) to
    /// all of it, the pairs are the brute force's, on clustered clouds and on a dense one whose
    /// `keep` rejects most points.
    #[test]
    fn searching_near_first_finds_the_same_pairs() {
        for seed in 0..30u64 {
            let mut rnd = crate::simplify::test_random(500 + seed);
            let n = 50 + (rnd() * 900.0) as u32;
            let pts: Vec<(u32, Vec3)> = (0..n)
                .map(|i| {
                    let p = match i % 3 {
                        0 => Vec3::new(rnd(), rnd(), 0.0),
                        1 => Vec3::new(rnd(), rnd() * 0.05, rnd()),
                        _ => Vec3::new((rnd() * 16.0).floor() / 16.0, rnd(), 0.5),
                    };
                    (i, p)
                })
                .collect();
            let radius = 0.05 + rnd() * 0.3;
            let max = 1 + (rnd() * 3.0) as usize;
            let keep = |i: u32, j: u32| !(i + 2 * j).is_multiple_of(3 + (seed as u32 % 5));
            let want = brute_force(&pts, radius, max, keep);
            for near in [
                radius / 20.0,
                radius / 7.0,
                radius / 3.0,
                radius,
                0.0,
                f32::NAN,
            ] {
                assert_eq!(
                    close_pairs_near(&pts, radius, near, max, keep),
                    want,
                    "seed {seed}, near {near}"
                );
            }
        }
    }

    /// Points 1e7 apart with a radius of 1e-3 would need 1e10 cells per axis; the grid uses fewer,
    /// wider cells and still finds exactly the close pairs.
    #[test]
    fn a_radius_tiny_next_to_the_extent_still_finds_the_pairs() {
        let pts = [
            (0, Vec3::ZERO),
            (1, Vec3::new(0.0, 0.0, 5e-4)),
            (2, Vec3::splat(1e7)),
            (3, Vec3::splat(1e7) + Vec3::X * 1.0),
            (4, Vec3::new(5e6, 0.0, 0.0)),
        ];
        assert_eq!(close_pairs(&pts, 1e-3, 4, |_, _| true), vec![(0, 1)]);
        assert_eq!(close_pairs(&pts, 2.0, 4, |_, _| true), vec![(0, 1), (2, 3)]);
    }
}

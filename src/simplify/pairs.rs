//! Candidate non-edge pairs: vertices closer than a threshold (Garland & Heckbert 1997 §3; Tao et al. §2.3
//! "any two vertices"). Found with a uniform grid of cell size = the threshold, so each query looks at
//! the 27 cells around a point (as 9 columns): O(n) for surfaces, never O(n²).

use glam::Vec3;
use rayon::prelude::*;

/// For each point, up to `max_per_point` nearest others within `radius` for which `keep(i, j)` holds.
/// Returns each pair once as `(min, max)` of the given ids, sorted.
pub fn close_pairs(
    points: &[(u32, Vec3)],
    radius: f32,
    max_per_point: usize,
    keep: impl Fn(u32, u32) -> bool + Sync,
) -> Vec<(u32, u32)> {
    if points.len() < 2 || radius <= 0.0 || max_per_point == 0 || !radius.is_finite() {
        return Vec::new();
    }
    let cell_of = |p: Vec3| -> [i64; 3] { (p / radius).floor().to_array().map(|x| x as i64) };
    // Points sorted by cell: a column of cells (fixed x and y) is one contiguous run, ordered by z,
    // so the 27 cells around a point are 9 column runs, each cut to 3 cells by binary search.
    let mut sorted: Vec<([i64; 3], u32, Vec3)> =
        points.iter().map(|&(id, p)| (cell_of(p), id, p)).collect();
    sorted.par_sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.cmp(&b.1)));
    // Column → its run in `sorted`: 9 hash lookups a point instead of 27.
    let mut columns: std::collections::HashMap<[i64; 2], (usize, usize), CellHash> =
        std::collections::HashMap::with_capacity_and_hasher(sorted.len() / 2 + 1, CellHash);
    let mut i = 0;
    while i < sorted.len() {
        let column = [sorted[i].0[0], sorted[i].0[1]];
        let mut j = i + 1;
        while j < sorted.len() && sorted[j].0[..2] == column {
            j += 1;
        }
        columns.insert(column, (i, j));
        i = j;
    }
    let r2 = radius * radius;
    let mut pairs: Vec<(u32, u32)> = sorted
        .par_iter()
        .flat_map_iter(|&(cell, id, p)| {
            let mut near: Vec<(f32, u32)> = Vec::new();
            for dx in -1..=1 {
                for dy in -1..=1 {
                    let Some(&(start, end)) =
                        columns.get(&[cell[0].saturating_add(dx), cell[1].saturating_add(dy)])
                    else {
                        continue;
                    };
                    let run = &sorted[start..end];
                    let from = run.partition_point(|q| q.0[2] < cell[2].saturating_sub(1));
                    for &(c, other, q) in &run[from..] {
                        if c[2] > cell[2].saturating_add(1) {
                            break;
                        }
                        let d2 = p.distance_squared(q);
                        if other != id && d2 <= r2 && keep(id, other) {
                            near.push((d2, other));
                        }
                    }
                }
            }
            near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            near.truncate(max_per_point);
            near.into_iter()
                .map(move |(_, other)| (id.min(other), id.max(other)))
        })
        .collect();
    pairs.par_sort_unstable();
    pairs.dedup();
    pairs
}

/// A multiplicative hash for grid cells: the default SipHash costs more than the whole distance test.
#[derive(Clone, Copy, Default)]
struct CellHash;

impl std::hash::BuildHasher for CellHash {
    type Hasher = CellHasher;
    fn build_hasher(&self) -> CellHasher {
        CellHasher(0)
    }
}

struct CellHasher(u64);

impl std::hash::Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_i64(&mut self, x: i64) {
        self.write_u64(x as u64);
    }
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
}

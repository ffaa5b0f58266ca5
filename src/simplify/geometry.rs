//! Small geometric queries shared by the builder and the measurement.

use glam::Vec3;

/// Points per [`nearest_squared`] call: 12 lanes (three SSE vectors), so that the loops over them
/// vectorise; the builder measures ten.
pub const LANES: usize = 12;

/// For each of up to [`LANES`] points (`xs`, `ys`, `zs`, one coordinate per array), the squared
/// distance to the nearest of `triangles`, lowered into `best`. The same distance as
/// [`closest_point_on_triangle`] up to rounding, without branches: inside the triangle's prism the
/// plane distance, else the nearest of the three edges. Each triangle is set up once for all points.
pub fn nearest_squared(
    xs: &[f32; LANES],
    ys: &[f32; LANES],
    zs: &[f32; LANES],
    triangles: impl Iterator<Item = [Vec3; 3]>,
    best: &mut [f32; LANES],
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, checked just above.
        return unsafe { nearest_squared_avx2(xs, ys, zs, triangles, best) };
    }
    nearest_squared_in(xs, ys, zs, triangles, best);
}

/// [`nearest_squared`] in 8-lane vectors. The same operations in the same order as without AVX2
/// (Rust fuses no multiply-add on its own), so the results are bit for bit the same.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn nearest_squared_avx2(
    xs: &[f32; LANES],
    ys: &[f32; LANES],
    zs: &[f32; LANES],
    triangles: impl Iterator<Item = [Vec3; 3]>,
    best: &mut [f32; LANES],
) {
    nearest_squared_in(xs, ys, zs, triangles, best);
}

#[inline(always)]
fn nearest_squared_in(
    xs: &[f32; LANES],
    ys: &[f32; LANES],
    zs: &[f32; LANES],
    triangles: impl Iterator<Item = [Vec3; 3]>,
    best: &mut [f32; LANES],
) {
    for [a, b, c] in triangles {
        let (ab, ac, bc) = (b - a, c - a, c - b);
        let (ab2, ac2, bc2, abac) = (ab.dot(ab), ac.dot(ac), bc.dot(bc), ab.dot(ac));
        let n = ab.cross(ac);
        let n2 = n.dot(n);
        let inv = |x: f32| if x > 0.0 { 1.0 / x } else { 0.0 };
        let (inv_ab, inv_ac, inv_bc, inv_n) = (inv(ab2), inv(ac2), inv(bc2), inv(n2));
        // A sliver (sin² of its angle at `a` below 1e-8) has no usable plane: its edges only, which
        // are within its width of every point of it.
        let flat = n2 > 1e-8 * ab2 * ac2;
        for i in 0..LANES {
            let (px, py, pz) = (xs[i] - a.x, ys[i] - a.y, zs[i] - a.z);
            let ap2 = px * px + py * py + pz * pz;
            let d1 = ab.x * px + ab.y * py + ab.z * pz;
            let d2 = ac.x * px + ac.y * py + ac.z * pz;
            let np = n.x * px + n.y * py + n.z * pz;
            // Ericson's d3..d6 from d1 and d2.
            let (d3, d4) = (d1 - ab2, d2 - abac);
            let (d5, d6) = (d1 - abac, d2 - ac2);
            let vc = d1 * d4 - d3 * d2;
            let vb = d5 * d2 - d1 * d6;
            let va = d3 * d6 - d5 * d4;
            let inside = flat & (va >= 0.0) & (vb >= 0.0) & (vc >= 0.0);
            let plane = np * np * inv_n;
            let t = (d1 * inv_ab).clamp(0.0, 1.0);
            let e_ab = ap2 - 2.0 * t * d1 + t * t * ab2;
            let t = (d2 * inv_ac).clamp(0.0, 1.0);
            let e_ac = ap2 - 2.0 * t * d2 + t * t * ac2;
            // From b: |bp|² = |ap|² − 2 d1 + |ab|², bp·bc = d4 − d3.
            let (bp2, dbc) = (ap2 - 2.0 * d1 + ab2, d4 - d3);
            let t = (dbc * inv_bc).clamp(0.0, 1.0);
            let e_bc = bp2 - 2.0 * t * dbc + t * t * bc2;
            let d = if inside {
                plane
            } else {
                e_ab.min(e_ac).min(e_bc)
            };
            best[i] = best[i].min(d.max(0.0));
        }
    }
}

/// Closest point on triangle `abc` to `p` (Ericson, Real-Time Collision Detection §5.1.5).
pub fn closest_point_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.abs() <= f32::MIN_POSITIVE {
        // Degenerate (zero-area) triangle: the best of its three edges.
        let candidates = [
            a + ab * (ap.dot(ab) / ab.length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0),
            a + ac * (ap.dot(ac) / ac.length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0),
            b + (c - b)
                * (bp.dot(c - b) / (c - b).length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0),
        ];
        return candidates
            .into_iter()
            .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
            .unwrap_or(a);
    }
    let v = vb / denom;
    let w = vc / denom;
    a + ab * v + ac * w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_squared_matches_the_closest_point() {
        let mut random = crate::simplify::test_random(7);
        let mut rnd = || random() * 2.0 - 1.0;
        for round in 0..500 {
            let mut v = || Vec3::new(rnd(), rnd(), rnd());
            let mut tris: Vec<[Vec3; 3]> = (0..1 + round % 9).map(|_| [v(), v(), v()]).collect();
            // Degenerate ones too: a sliver, a segment, a point.
            if round % 5 == 0 {
                let (p, q) = (v(), v());
                tris.push([p, q, p + (q - p) * 0.25]);
                tris.push([p, p, p]);
            }
            let points: Vec<Vec3> = (0..LANES).map(|_| v() * 1.5).collect();
            let xs = std::array::from_fn(|i| points[i].x);
            let ys = std::array::from_fn(|i| points[i].y);
            let zs = std::array::from_fn(|i| points[i].z);
            let mut best = [f32::INFINITY; LANES];
            nearest_squared(&xs, &ys, &zs, tris.iter().copied(), &mut best);
            // Vectors of any width give the same bits.
            let mut portable = [f32::INFINITY; LANES];
            nearest_squared_in(&xs, &ys, &zs, tris.iter().copied(), &mut portable);
            assert_eq!(best.map(f32::to_bits), portable.map(f32::to_bits));
            for (p, got) in points.iter().zip(best) {
                let want = tris
                    .iter()
                    .map(|&[a, b, c]| closest_point_on_triangle(*p, a, b, c).distance(*p))
                    .fold(f32::INFINITY, f32::min);
                assert!(
                    (got.sqrt() - want).abs() <= 1e-4 * (1.0 + want),
                    "{got} vs {want}²"
                );
            }
        }
    }
}

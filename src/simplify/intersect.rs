//! Exact triangle–triangle intersection, the test every envelope method rests on.
//!
//! Two closed triangles meet exactly when an edge of one meets the other: where two non-coplanar
//! triangles meet, their intersection is a segment whose ends lie on the triangles' edges, and where
//! coplanar ones meet, their common polygon has a corner on an edge of one of them. So the test is six
//! segment–triangle tests, each made only of signs of Shewchuk's adaptive-precision `orient3d` and
//! `orient2d` (the `robust` crate): no tolerance anywhere, and touching counts as meeting — the
//! conservative answer for an envelope, which must refuse anything that reaches its surface.

use glam::DVec3;
use robust::{Coord, Coord3D, orient2d, orient3d};

/// Sign of the volume of `abcd`: which side of the plane `abc` the point `d` is on (0: on it).
fn side(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> i8 {
    let c3 = |p: DVec3| Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    };
    sign(orient3d(c3(a), c3(b), c3(c), c3(d)))
}

fn sign(x: f64) -> i8 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

/// Whether the closed triangles `a` and `b` have a point in common.
pub fn triangles_intersect(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    let (alo, ahi) = (a[0].min(a[1]).min(a[2]), a[0].max(a[1]).max(a[2]));
    let (blo, bhi) = (b[0].min(b[1]).min(b[2]), b[0].max(b[1]).max(b[2]));
    if alo.cmpgt(bhi).any() || blo.cmpgt(ahi).any() {
        return false;
    }
    // Sides of each triangle's corners with respect to the other's plane: all on one side, no contact.
    let sb = b.map(|p| side(a[0], a[1], a[2], p));
    if one_side(sb) {
        return false;
    }
    let sa = a.map(|p| side(b[0], b[1], b[2], p));
    if one_side(sa) {
        return false;
    }
    if sb == [0; 3] && sa == [0; 3] {
        return coplanar_intersect(a, b);
    }
    (0..3).any(|k| segment_meets(a[k], a[(k + 1) % 3], [sa[k], sa[(k + 1) % 3]], b))
        || (0..3).any(|k| segment_meets(b[k], b[(k + 1) % 3], [sb[k], sb[(k + 1) % 3]], a))
}

fn one_side(s: [i8; 3]) -> bool {
    (s[0] > 0 && s[1] > 0 && s[2] > 0) || (s[0] < 0 && s[1] < 0 && s[2] < 0)
}

/// Whether the closed segment `pq` meets the closed triangle `t`; `s` are the sides of `p` and `q`
/// with respect to `t`'s plane.
fn segment_meets(p: DVec3, q: DVec3, s: [i8; 2], t: &[DVec3; 3]) -> bool {
    if s[0] * s[1] > 0 {
        return false;
    }
    if s == [0, 0] {
        // The segment lies in the triangle's plane (or the triangle is degenerate).
        return coplanar_intersect(&[p, q, q], t);
    }
    // The line pq crosses the plane at one point of the segment; it lies in the closed triangle
    // when the line passes on the same side of (or through) all three edges.
    let e = [
        side(p, q, t[0], t[1]),
        side(p, q, t[1], t[2]),
        side(p, q, t[2], t[0]),
    ];
    e.iter().all(|&x| x >= 0) || e.iter().all(|&x| x <= 0)
}

/// Whether two coplanar closed triangles (either may be degenerate: a segment or a point) meet, in
/// the plane that drops the axis their normal points along most.
fn coplanar_intersect(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    let normal = {
        let na = (a[1] - a[0]).cross(a[2] - a[0]);
        let nb = (b[1] - b[0]).cross(b[2] - b[0]);
        if na.length_squared() >= nb.length_squared() {
            na
        } else {
            nb
        }
    };
    if normal == DVec3::ZERO {
        // Both degenerate: a rare corner case, answered conservatively.
        return true;
    }
    let n = normal.abs();
    let drop = if n.x >= n.y && n.x >= n.z {
        0
    } else if n.y >= n.z {
        1
    } else {
        2
    };
    let flat = |p: DVec3| match drop {
        0 => Coord { x: p.y, y: p.z },
        1 => Coord { x: p.z, y: p.x },
        _ => Coord { x: p.x, y: p.y },
    };
    let (a2, b2) = (a.map(flat), b.map(flat));
    let edges_cross = (0..3)
        .any(|i| (0..3).any(|j| segments_meet_2d(a2[i], a2[(i + 1) % 3], b2[j], b2[(j + 1) % 3])));
    edges_cross || inside_2d(a2[0], &b2) || inside_2d(b2[0], &a2)
}

fn o2(a: Coord<f64>, b: Coord<f64>, c: Coord<f64>) -> i8 {
    sign(orient2d(a, b, c))
}

fn segments_meet_2d(a: Coord<f64>, b: Coord<f64>, c: Coord<f64>, d: Coord<f64>) -> bool {
    let (d1, d2) = (o2(c, d, a), o2(c, d, b));
    let (d3, d4) = (o2(a, b, c), o2(a, b, d));
    if d1 * d2 < 0 && d3 * d4 < 0 {
        return true;
    }
    let within = |p: Coord<f64>, q: Coord<f64>, r: Coord<f64>| {
        r.x >= p.x.min(q.x) && r.x <= p.x.max(q.x) && r.y >= p.y.min(q.y) && r.y <= p.y.max(q.y)
    };
    (d1 == 0 && within(c, d, a))
        || (d2 == 0 && within(c, d, b))
        || (d3 == 0 && within(a, b, c))
        || (d4 == 0 && within(a, b, d))
}

/// Whether `p` is in the closed triangle `t` (a degenerate `t` holds only points on its edges,
/// which the edge test finds).
fn inside_2d(p: Coord<f64>, t: &[Coord<f64>; 3]) -> bool {
    let s = [o2(t[0], t[1], p), o2(t[1], t[2], p), o2(t[2], t[0], p)];
    if s == [0; 3] {
        return false;
    }
    s.iter().all(|&x| x >= 0) || s.iter().all(|&x| x <= 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(p: [[f64; 3]; 3]) -> [DVec3; 3] {
        p.map(DVec3::from)
    }

    // A unit right triangle in z = 0:
    //
    //   y
    //   1 +
    //     | \
    //     |   \
    //   0 +-----+ x
    //     0     1
    const FLOOR: [[f64; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    #[test]
    fn piercing_and_missing() {
        let floor = t(FLOOR);
        // A vertical triangle through the floor's inside.
        let pierce = t([[0.2, 0.2, -1.0], [0.3, 0.2, 1.0], [0.2, 0.3, 1.0]]);
        assert!(triangles_intersect(&floor, &pierce));
        assert!(triangles_intersect(&pierce, &floor));
        // The same, moved beyond the hypotenuse.
        let beside = t([[0.8, 0.8, -1.0], [0.9, 0.8, 1.0], [0.8, 0.9, 1.0]]);
        assert!(!triangles_intersect(&floor, &beside));
        // Parallel, above.
        let above = t(FLOOR.map(|[x, y, _]| [x, y, 1e-12]));
        assert!(!triangles_intersect(&floor, &above));
    }

    #[test]
    fn touching_counts() {
        let floor = t(FLOOR);
        // A triangle standing on the floor with one corner exactly on the hypotenuse.
        let standing = t([[0.5, 0.5, 0.0], [0.5, 0.5, 1.0], [1.0, 1.0, 1.0]]);
        assert!(triangles_intersect(&floor, &standing));
        // Sharing only a corner.
        let corner = t([[1.0, 0.0, 0.0], [2.0, 0.0, 1.0], [2.0, 1.0, 0.0]]);
        assert!(triangles_intersect(&floor, &corner));
    }

    #[test]
    fn coplanar() {
        let floor = t(FLOOR);
        // Overlapping in the plane.
        let shifted = t(FLOOR.map(|[x, y, z]| [x + 0.3, y + 0.3, z]));
        assert!(triangles_intersect(&floor, &shifted));
        // One inside the other.
        let small = t([[0.1, 0.1, 0.0], [0.2, 0.1, 0.0], [0.1, 0.2, 0.0]]);
        assert!(triangles_intersect(&floor, &small));
        assert!(triangles_intersect(&small, &floor));
        // Disjoint in the plane.
        let far = t(FLOOR.map(|[x, y, z]| [x + 0.6, y + 0.6, z]));
        assert!(!triangles_intersect(&floor, &far));
    }

    /// Plain floating-point segment–triangle crossings, `None` when a case is too close to call.
    fn naive(a: &[DVec3; 3], b: &[DVec3; 3]) -> Option<bool> {
        let mut hit = false;
        for (s, t) in [(a, b), (b, a)] {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            for k in 0..3 {
                let (p, q) = (s[k], s[(k + 1) % 3]);
                let (dp, dq) = (n.dot(p - t[0]), n.dot(q - t[0]));
                if dp.abs() < 1e-9 || dq.abs() < 1e-9 {
                    return None;
                }
                if dp * dq > 0.0 {
                    continue;
                }
                let x = p + (q - p) * (dp / (dp - dq));
                let w = [0, 1, 2].map(|i| n.dot((t[(i + 1) % 3] - t[i]).cross(x - t[i])));
                if w.iter().any(|v| v.abs() < 1e-9) {
                    return None;
                }
                hit |= w.iter().all(|&v| v > 0.0) || w.iter().all(|&v| v < 0.0);
            }
        }
        Some(hit)
    }

    #[test]
    fn random_pairs_agree_with_floating_point() {
        let mut next = crate::simplify::test_random(7);
        let mut r = || next() as f64;
        let (mut met, mut checked) = (0, 0);
        for _ in 0..5000 {
            let a = [0; 3].map(|_| DVec3::new(r(), r(), r()));
            let b = [0; 3].map(|_| DVec3::new(r(), r(), r()));
            let meet = triangles_intersect(&a, &b);
            assert_eq!(meet, triangles_intersect(&b, &a));
            assert_eq!(meet, triangles_intersect(&[a[1], a[2], a[0]], &b));
            if let Some(expected) = naive(&a, &b) {
                assert_eq!(meet, expected, "{a:?} {b:?}");
                checked += 1;
                met += meet as usize;
            }
        }
        // Both answers are well represented.
        assert!(
            checked > 4000 && met > 500 && checked - met > 500,
            "{checked} {met}"
        );
    }
}

//! Triangulating a superface Liu and Wu's way (§3 of their paper): holes are bridged to the outer
//! ring, in `TOP` order, through the best outer edge; the one simple polygon that makes is ear-clipped,
//! always at the convex corner whose ear has the largest weight `cos A + cos B + cos C − 1` (0 for
//! reflex corners), never at an ear holding another corner, updating the two neighbours' weights.
//!
//! The weight is largest (1/2) for an equilateral ear and 0 for a degenerate one, so the clipping
//! cuts well-shaped triangles first and leaves slivers for last, when nothing else is left.

use glam::DVec2;
use std::collections::HashMap;

/// `TOP(P)`: the ring's highest corner, `(x, y) > (u, v)` iff `y > v`, or `y = v` and `x > u`.
fn top(ring: &[DVec2]) -> usize {
    (0..ring.len())
        .max_by(|&a, &b| {
            let (p, q) = (ring[a], ring[b]);
            p.y.total_cmp(&q.y).then(p.x.total_cmp(&q.x))
        })
        .unwrap_or(0)
}

/// Twice the signed area of `oab`, positive when counter-clockwise, with an exact sign (Shewchuk's
/// adaptive `orient2d`): superface boundaries carry long runs of nearly collinear corners, where a
/// rounded sign calls a reflex corner convex and the ear it cuts overlaps its neighbours.
fn cross(o: DVec2, a: DVec2, b: DVec2) -> f64 {
    let c = |p: DVec2| robust::Coord { x: p.x, y: p.y };
    robust::orient2d(c(o), c(a), c(b))
}

/// Whether the open segments `ab` and `cd` cross (touching at an end does not count).
fn segments_cross(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let (d1, d2) = (cross(c, d, a), cross(c, d, b));
    let (d3, d4) = (cross(a, b, c), cross(a, b, d));
    ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
}

/// Distance from `v` to the segment `ab`: the paper's `D(l, v)`.
fn distance_to_segment(v: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 {
        ((v - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    v.distance(a + ab * t)
}

/// One simple polygon (corner ids into `points`) from an outer ring (counter-clockwise) and holes
/// (clockwise), each hole joined to the outer ring by a bridge there and back.
pub fn bridge(points: &[DVec2], outer: &[u32], holes: &[Vec<u32>]) -> Vec<u32> {
    let mut polygon: Vec<u32> = outer.to_vec();
    // A hole touching the outer ring or another hole at a corner (a superface that grew round a
    // region and closed at one vertex) is joined there, a bridge of no length.
    let mut holes: Vec<Vec<u32>> = holes.iter().filter(|h| h.len() >= 3).cloned().collect();
    'splice: loop {
        for i in 0..holes.len() {
            if let Some(spliced) = splice(&polygon, &holes[i]) {
                polygon = spliced;
                holes.remove(i);
                continue 'splice;
            }
            for j in i + 1..holes.len() {
                if let Some(spliced) = splice(&holes[i], &holes[j]) {
                    holes[i] = spliced;
                    holes.remove(j);
                    continue 'splice;
                }
            }
        }
        break;
    }
    let mut order: Vec<&Vec<u32>> = holes.iter().collect();
    // Highest TOP first, as the paper orders them.
    order.sort_by(|a, b| {
        let (p, q) = (top_point(points, a), top_point(points, b));
        q.y.total_cmp(&p.y).then(q.x.total_cmp(&p.x))
    });
    for (k, hole) in order.iter().enumerate() {
        let ring: Vec<DVec2> = hole.iter().map(|&i| points[i as usize]).collect();
        let start = top(&ring);
        let v = ring[start];
        // Outer edges by D(l, v), nearest first; the bridge goes to the nearer end of the first
        // edge whose bridge crosses no edge of the polygon or of a hole still to come.
        let n = polygon.len();
        let mut edges: Vec<(f64, usize)> = (0..n)
            .map(|i| {
                let (a, b) = (
                    points[polygon[i] as usize],
                    points[polygon[(i + 1) % n] as usize],
                );
                (distance_to_segment(v, a, b), i)
            })
            .collect();
        edges.sort_by(|a, b| a.0.total_cmp(&b.0));
        let others: Vec<&Vec<u32>> = order[k + 1..].to_vec();
        let crosses = |w: DVec2| {
            let ring_cross = |r: &[u32]| {
                (0..r.len()).any(|i| {
                    let (a, b) = (points[r[i] as usize], points[r[(i + 1) % r.len()] as usize]);
                    segments_cross(v, w, a, b)
                })
            };
            ring_cross(&polygon) || ring_cross(hole) || others.iter().any(|h| ring_cross(h))
        };
        let mut chosen = None;
        'search: for &(_, i) in &edges {
            let (a, b) = (polygon[i], polygon[(i + 1) % n]);
            let (pa, pb) = (points[a as usize], points[b as usize]);
            let ends = if pa.distance(v) <= pb.distance(v) {
                [(i, pa), ((i + 1) % n, pb)]
            } else {
                [((i + 1) % n, pb), (i, pa)]
            };
            for (at, w) in ends {
                if !crosses(w) {
                    chosen = Some(at);
                    break 'search;
                }
            }
        }
        let at = chosen.unwrap_or(edges[0].1);
        // polygon[..=at], the hole from its top all the way round and back to its top, then
        // polygon[at..].
        let mut next = polygon[..=at].to_vec();
        next.extend((0..=hole.len()).map(|j| hole[(start + j) % hole.len()]));
        next.extend(&polygon[at..]);
        polygon = next;
    }
    polygon
}

/// `ring` joined into `into` at a corner they share: `into` up to that corner, round `ring` from it
/// back to it, then the rest of `into`; `None` when they share no corner.
fn splice(into: &[u32], ring: &[u32]) -> Option<Vec<u32>> {
    let (k, j) = into
        .iter()
        .enumerate()
        .find_map(|(k, v)| ring.iter().position(|w| w == v).map(|j| (k, j)))?;
    let mut out = into[..=k].to_vec();
    out.extend((1..=ring.len()).map(|s| ring[(j + s) % ring.len()]));
    out.extend(&into[k + 1..]);
    Some(out)
}

fn top_point(points: &[DVec2], ring: &[u32]) -> DVec2 {
    let r: Vec<DVec2> = ring.iter().map(|&i| points[i as usize]).collect();
    r[top(&r)]
}

/// The paper's ear weight: `cos A + cos B + cos C − 1` of the triangle `abc` when `b` is convex
/// (at least 0, and 0 only for a degenerate ear), else [`NOT_AN_EAR`] — the paper's 0 for reflex
/// corners, kept apart here so that a convex sliver, whose weight rounds to 0, can still be cut
/// when nothing better is left.
fn weight(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    let turn = cross(a, b, c);
    if turn <= 0.0 {
        return NOT_AN_EAR;
    }
    // Straight but for rounding (a vertex a superface kept on a straight chain, its coordinates
    // rounded to f32): cut only when nothing else is left, since its ear has no area and leaves
    // the corner inside the long edge that replaces it.
    if turn <= STRAIGHT_SINE * (b - a).length() * (c - b).length() {
        return STRAIGHT;
    }
    let cos = |o: DVec2, p: DVec2, q: DVec2| {
        let (u, v) = (p - o, q - o);
        let l = u.length() * v.length();
        if l > 0.0 { u.dot(v) / l } else { 1.0 }
    };
    (cos(a, b, c) + cos(b, c, a) + cos(c, a, b) - 1.0).max(0.0)
}

/// The weight of a reflex corner.
const NOT_AN_EAR: f64 = -1.0;
/// The weight of a corner turning by less than [`STRAIGHT_SINE`].
const STRAIGHT: f64 = -0.5;
/// Corners turning less than this (its sine; about 0.006°) count as straight: f32 coordinates a
/// few hundred units from the origin round a straight corner on edges a few units long to ~4e-6.
const STRAIGHT_SINE: f64 = 1e-4;

/// Whether `p` lies inside the closed triangle `abc` (counter-clockwise).
fn inside(p: DVec2, a: DVec2, b: DVec2, c: DVec2) -> bool {
    cross(a, b, p) >= 0.0 && cross(b, c, p) >= 0.0 && cross(c, a, p) >= 0.0
}

/// Ear-clips a simple counter-clockwise polygon (ids into `points`, bridges allowed: an id may
/// appear twice); returns triangles of ids.
pub fn ear_clip(points: &[DVec2], polygon: &[u32]) -> Vec<[u32; 3]> {
    let mut ring: Vec<u32> = polygon.to_vec();
    let mut out = Vec::with_capacity(ring.len().saturating_sub(2));
    let p = |i: u32| points[i as usize];
    let ear_weight = |ring: &[u32], k: usize| {
        let n = ring.len();
        let (a, b, c) = (ring[(k + n - 1) % n], ring[k], ring[(k + 1) % n]);
        weight(p(a), p(b), p(c))
    };
    let mut weights: Vec<f64> = (0..ring.len()).map(|k| ear_weight(&ring, k)).collect();
    while ring.len() > 3 {
        let n = ring.len();
        // Best valid ear: the largest weight whose triangle holds no other corner.
        let mut candidates: Vec<usize> = (0..n).filter(|&k| weights[k] >= STRAIGHT).collect();
        // Ears beside a straight corner first: cutting one joins that corner to a third vertex.
        // Left for last, a straight corner is cut as an ear of no area, its neighbours joined by an
        // edge it lies on (a T-junction in all but name).
        let beside_straight = |k: usize| {
            weights[k] >= 0.0
                && (weights[(k + n - 1) % n] == STRAIGHT || weights[(k + 1) % n] == STRAIGHT)
        };
        candidates.sort_by(|&x, &y| {
            beside_straight(y)
                .cmp(&beside_straight(x))
                .then(weights[y].total_cmp(&weights[x]))
        });
        let valid = |k: usize| {
            let (a, b, c) = (ring[(k + n - 1) % n], ring[k], ring[(k + 1) % n]);
            let corners = [(a, c, b), (b, a, c), (c, b, a)];
            (0..n).all(|i| {
                let q = ring[i];
                if i == k || i == (k + n - 1) % n || i == (k + 1) % n {
                    return true;
                }
                // A corner the ring passes twice (a bridge's end, or where a hole touches): the
                // ear must stay out of the other visit's wedge, so neither of that visit's edges
                // may leave the corner into the ear.
                if let Some(&(o, u, w)) = corners.iter().find(|c| p(c.0) == p(q)) {
                    let into = |d: DVec2| cross(p(o), p(u), d) < 0.0 && cross(p(o), p(w), d) > 0.0;
                    return !into(p(ring[(i + n - 1) % n])) && !into(p(ring[(i + 1) % n]));
                }
                !inside(p(q), p(a), p(b), p(c))
            })
        };
        // With no valid convex ear (only possible for a polygon that is not simple, e.g. a bad
        // bridge), cut the first corner so the loop ends.
        let k = candidates.into_iter().find(|&k| valid(k)).unwrap_or(0);
        out.push([ring[(k + n - 1) % n], ring[k], ring[(k + 1) % n]]);
        ring.remove(k);
        weights.remove(k);
        let n = ring.len();
        let (before, after) = ((k + n - 1) % n, k % n);
        weights[before] = ear_weight(&ring, before);
        weights[after] = ear_weight(&ring, after);
    }
    out.push([ring[0], ring[1], ring[2]]);
    flip_slivers(points, &mut out);
    out
}

/// Ears of no area: a straight corner `v` cut between `a` and `b`, so that the long edge `a–b` runs
/// through `v` (it happens when a ring is down to the last corners of a straight run). Each is
/// flipped with the triangle across `a–b`, `(a, b, x)`: into `(a, v, x)` and `(v, b, x)`, which
/// cover the same area with `v` a corner of both. A flip is made only when both new triangles are
/// counter-clockwise (exactly) and the worse of the pair gets better, so a run of straight corners
/// (the far side `x` on the same line) is worked through over several passes and the loop ends.
fn flip_slivers(points: &[DVec2], out: &mut [[u32; 3]]) {
    let p = |i: u32| points[i as usize];
    // How far from degenerate: twice the area over the longest edge squared (0 for no area).
    let shape = |t: [u32; 3]| {
        let [a, b, c] = t.map(p);
        let longest = (b - a)
            .length_squared()
            .max((c - b).length_squared())
            .max((a - c).length_squared());
        if longest > 0.0 {
            cross(a, b, c) / longest
        } else {
            0.0
        }
    };
    let straight_corner = |t: [u32; 3]| {
        (0..3).find_map(|r| {
            let [a, v, b] = [0, 1, 2].map(|k| t[(r + k) % 3]);
            let (va, vb) = (p(v) - p(a), p(b) - p(v));
            (cross(p(a), p(v), p(b)).abs() <= STRAIGHT_SINE * va.length() * vb.length()
                && va.dot(vb) > 0.0)
                .then_some([a, v, b])
        })
    };
    let mut across: HashMap<(u32, u32), usize> = HashMap::new();
    for (t, tri) in out.iter().enumerate() {
        for k in 0..3 {
            across.insert((tri[k], tri[(k + 1) % 3]), t);
        }
    }
    for _pass in 0..out.len() {
        let mut flipped = false;
        for t in 0..out.len() {
            let Some([a, v, b]) = straight_corner(out[t]) else {
                continue;
            };
            // The neighbour runs the shared edge the other way, `a → b → x`.
            let Some(&u) = across.get(&(a, b)) else {
                continue;
            };
            let k = (0..3).find(|&k| out[u][k] == a).unwrap_or(0);
            let x = out[u][(k + 2) % 3];
            let (first, second) = ([a, v, x], [v, b, x]);
            let better = shape(first).min(shape(second)) > shape(out[t]).min(shape(out[u]));
            if !(better && cross(p(a), p(v), p(x)) > 0.0 && cross(p(v), p(b), p(x)) > 0.0) {
                continue;
            }
            for tri in [out[t], out[u]] {
                for k in 0..3 {
                    across.remove(&(tri[k], tri[(k + 1) % 3]));
                }
            }
            out[t] = first;
            out[u] = second;
            for (i, tri) in [(t, first), (u, second)] {
                for k in 0..3 {
                    across.insert((tri[k], tri[(k + 1) % 3]), i);
                }
            }
            flipped = true;
        }
        if !flipped {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(points: &[DVec2], tris: &[[u32; 3]]) -> f64 {
        tris.iter()
            .map(|t| {
                0.5 * cross(
                    points[t[0] as usize],
                    points[t[1] as usize],
                    points[t[2] as usize],
                )
            })
            .sum()
    }

    /// A unit square: two triangles, both counter-clockwise, area 1.
    /// ```text
    ///   3───2
    ///   │   │
    ///   0───1
    /// ```
    #[test]
    fn a_square() {
        let pts = [(0., 0.), (1., 0.), (1., 1.), (0., 1.)]
            .map(DVec2::from)
            .to_vec();
        let tris = ear_clip(&pts, &[0, 1, 2, 3]);
        assert_eq!(tris.len(), 2);
        assert!((area(&pts, &tris) - 1.0).abs() < 1e-12);
        assert!(tris.iter().all(|t| cross(
            pts[t[0] as usize],
            pts[t[1] as usize],
            pts[t[2] as usize]
        ) > 0.0));
    }

    /// An L (six corners, one reflex at 4): four triangles, none across the notch; the reflex
    /// corner is never cut.
    /// ```text
    ///   5───4
    ///   │   │
    ///   │   3───2
    ///   │       │
    ///   0───────1
    /// ```
    #[test]
    fn an_l_shape() {
        let pts = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)]
            .map(DVec2::from)
            .to_vec();
        let tris = ear_clip(&pts, &[0, 1, 2, 3, 4, 5]);
        assert_eq!(tris.len(), 4);
        assert!((area(&pts, &tris) - 3.0).abs() < 1e-12);
        for t in &tris {
            let c = (pts[t[0] as usize] + pts[t[1] as usize] + pts[t[2] as usize]) / 3.0;
            assert!(
                !(c.x > 1.0 && c.y > 1.0),
                "a triangle across the notch: {t:?}"
            );
        }
    }

    /// A hole touching the outer ring at a corner (`1`, where a superface closed round it) is
    /// joined there with no bridge: one ring of 8 corners (`1` twice), 6 triangles, area 16 − 2,
    /// none over the hole, and none reaching from one visit of `1` into the other's wedge.
    /// ```text
    ///   4───────────3
    ///   │           │
    ///   │   6───5   │
    ///   │    ╲ ╱    │
    ///   0─────1─────2
    /// ```
    #[test]
    fn a_hole_touching_the_outer_ring() {
        let pts = [
            (0., 0.),
            (2., 0.),
            (4., 0.),
            (4., 4.),
            (0., 4.),
            (3., 2.),
            (1., 2.),
        ]
        .map(DVec2::from)
        .to_vec();
        // The hole clockwise: 1, 6, 5.
        let polygon = bridge(&pts, &[0, 1, 2, 3, 4], &[vec![1, 6, 5]]);
        assert_eq!(polygon, [0, 1, 6, 5, 1, 2, 3, 4]);
        let tris = ear_clip(&pts, &polygon);
        assert_eq!(tris.len(), 6);
        assert!((area(&pts, &tris) - 14.0).abs() < 1e-12);
        for t in &tris {
            let [a, b, c] = t.map(|i| pts[i as usize]);
            assert!(cross(a, b, c) > 0.0, "{t:?} is not counter-clockwise");
            let centre = (a + b + c) / 3.0;
            assert!(
                !inside(centre, pts[1], pts[5], pts[6]),
                "{t:?} covers the hole"
            );
        }
    }

    /// A straight corner cut as an ear, `(a, v, b)` with `v` on `a–b`, is flipped with the
    /// triangle across `a–b` into two with area, `v` a corner of both.
    /// ```text
    ///         x                 x
    ///        ╱ ╲               ╱│╲
    ///       ╱   ╲      →      ╱ │ ╲
    ///      a──v──b           a──v──b
    /// ```
    #[test]
    fn a_straight_ear_is_flipped() {
        let pts = [(0., 0.), (1., 0.), (2., 0.), (1., 1.)]
            .map(DVec2::from)
            .to_vec();
        let (a, v, b, x) = (0, 1, 2, 3);
        let mut tris = [[a, v, b], [a, b, x]];
        flip_slivers(&pts, &mut tris);
        assert_eq!(tris, [[a, v, x], [v, b, x]]);
        assert!((area(&pts, &tris) - 1.0).abs() < 1e-12);
    }

    /// A square with a square hole: bridged from the hole's top to the outer ring (10 corners:
    /// 4 + 4, and the bridge's two ends twice), then 8 triangles covering area 16 − 4.
    /// ```text
    ///   3───────────2
    ///   │   7───6   │
    ///   │   │   │   │
    ///   │   4───5   │
    ///   0───────────1
    /// ```
    #[test]
    fn a_square_with_a_hole() {
        let pts = [
            (0., 0.),
            (4., 0.),
            (4., 4.),
            (0., 4.),
            (1., 1.),
            (3., 1.),
            (3., 3.),
            (1., 3.),
        ]
        .map(DVec2::from)
        .to_vec();
        // The hole clockwise.
        let polygon = bridge(&pts, &[0, 1, 2, 3], &[vec![4, 7, 6, 5]]);
        assert_eq!(polygon.len(), 10);
        let tris = ear_clip(&pts, &polygon);
        assert_eq!(tris.len(), 8);
        assert!(
            (area(&pts, &tris) - 12.0).abs() < 1e-12,
            "{}",
            area(&pts, &tris)
        );
        // No triangle covers the hole.
        for t in &tris {
            let c = (pts[t[0] as usize] + pts[t[1] as usize] + pts[t[2] as usize]) / 3.0;
            assert!(
                !(c.x > 1.0 && c.x < 3.0 && c.y > 1.0 && c.y < 3.0),
                "{t:?} covers the hole"
            );
        }
    }
}

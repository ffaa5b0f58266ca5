//! An upper bound on `max over a piece of d(p, B)` that does not need the piece to be small: the
//! piece is cut along the prisms of nearby triangles of B, and each part is bounded against the
//! triangle whose prism it lies in.
//!
//! # Why
//! The branch and bound's own bound takes one triangle t of B for the whole piece: `d(·, t)` is convex,
//! so its largest value over the piece is at a corner. Where B's nearest triangle changes inside the
//! piece, no single t is near all of it, and the piece has to be split until each part sees one
//! triangle. On a flat region that never ends: a large triangle lying on a grid of small ones is at
//! distance 0 from it everywhere, but each of its parts straddles grid edges until the parts are
//! smaller than ε — thousands of splits for one check.
//!
//! # How
//! The prism of a triangle t (the points whose projection along t's normal falls inside t) is the
//! intersection of three half-spaces, one through each edge, parallel to the normal. Inside it,
//! `d(p, t)` is the distance to t's plane. The piece, a convex polygon, is cut by each candidate's
//! prism in turn (nearest candidate first): the part inside is bounded by `max over its corners of
//! d(c, t)`, and the parts outside (up to three convex polygons, one per side crossed) go on to the
//! next candidate. What no prism claims (across a convex crease, where the nearest point of B is on
//! an edge) is bounded by the best single candidate over its corners, as before.
//!
//! # Why it is sound
//! Every part is a convex polygon and every bound is `max over its corners of d(c, t)` for some
//! triangle t — valid for any convex region and any t, whatever the prisms. The prisms only choose a
//! partition that makes those bounds tight. The parts cover the piece up to `f64` rounding at the
//! cuts (a cut point is computed once and shared by both sides); `d` is 1-Lipschitz, so a point
//! missed by rounding is within [`slack`] of a covered one, and callers add it.
//!
//! With a flat piece on coplanar triangles the prisms tile the piece and the bound is the exact 0;
//! on a curved surface it is exact where the nearest points are inside B's faces.

use glam::DVec3;

/// Corners a part may have; a cut adds at most one, and a part that would need more is bounded as
/// it is (against the best single candidate) instead of being cut again.
const MAX_CORNERS: usize = 12;

/// A convex polygon, planar up to rounding.
#[derive(Clone, Copy)]
struct Polygon {
    len: usize,
    corners: [DVec3; MAX_CORNERS],
}

impl Polygon {
    fn triangle(t: &[DVec3; 3]) -> Polygon {
        let mut corners = [DVec3::ZERO; MAX_CORNERS];
        corners[..3].copy_from_slice(t);
        Polygon { len: 3, corners }
    }

    fn corners(&self) -> &[DVec3] {
        &self.corners[..self.len]
    }

    fn push(&mut self, p: DVec3) {
        self.corners[self.len] = p;
        self.len += 1;
    }

    /// Twice the area (the length of the summed cross products of a fan).
    fn double_area(&self) -> f64 {
        let c = self.corners();
        let mut sum = DVec3::ZERO;
        for i in 1..c.len().saturating_sub(1) {
            sum += (c[i] - c[0]).cross(c[i + 1] - c[0]);
        }
        sum.length()
    }

    /// `max over the corners of d(c, t)`: a bound on `d(·, t)` over the whole polygon.
    fn bound(&self, t: &[DVec3; 3]) -> f64 {
        self.corners()
            .iter()
            .map(|&c| super::closest_point_on_triangle64(c, t[0], t[1], t[2]).distance(c))
            .fold(0.0, f64::max)
    }

    /// The parts on the positive side (`n · p ≥ d`) and the negative side of a plane; a cut point is
    /// computed once and given to both. `None` for an empty side; `Err` when a part would need more
    /// corners than a polygon holds.
    #[allow(clippy::type_complexity)]
    fn split(&self, n: DVec3, d: f64) -> Result<(Option<Polygon>, Option<Polygon>), ()> {
        let c = self.corners();
        let s: [f64; MAX_CORNERS] =
            std::array::from_fn(|i| if i < c.len() { n.dot(c[i]) - d } else { 0.0 });
        let s = &s[..c.len()];
        if s.iter().all(|&x| x >= 0.0) {
            return Ok((Some(*self), None));
        }
        if s.iter().all(|&x| x <= 0.0) {
            return Ok((None, Some(*self)));
        }
        let empty = Polygon {
            len: 0,
            corners: [DVec3::ZERO; MAX_CORNERS],
        };
        let (mut inside, mut outside) = (empty, empty);
        for i in 0..c.len() {
            let j = (i + 1) % c.len();
            let (p, q, sp, sq) = (c[i], c[j], s[i], s[j]);
            if inside.len >= MAX_CORNERS - 1 || outside.len >= MAX_CORNERS - 1 {
                return Err(());
            }
            if sp >= 0.0 {
                inside.push(p);
            }
            if sp <= 0.0 {
                outside.push(p);
            }
            if (sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0) {
                let cut = p + (q - p) * (sp / (sp - sq));
                inside.push(cut);
                outside.push(cut);
            }
        }
        let part = |p: Polygon| (p.len >= 3).then_some(p);
        Ok((part(inside), part(outside)))
    }
}

/// The absolute rounding allowance of [`upper_bound`] for a piece: points of the piece that the cut
/// parts miss by rounding are at most this far from a part.
pub fn slack(piece: &[DVec3; 3]) -> f64 {
    let scale = piece
        .iter()
        .map(|c| c.abs().max_element())
        .fold(0.0, f64::max);
    1e-12 * scale
}

/// A candidate as a claimer: the half-spaces of its prism, capped by the slab within `reach` of its
/// plane, and the box of that capped prism.
struct Claimer {
    sides: [(DVec3, f64); 5],
    count: usize,
    lo: DVec3,
    hi: DVec3,
}

impl Claimer {
    /// `None` for a triangle without area.
    fn new(t: &[DVec3; 3], reach: f64) -> Option<Claimer> {
        let normal = (t[1] - t[0]).cross(t[2] - t[0]);
        if normal.length_squared() == 0.0 || !normal.is_finite() {
            return None;
        }
        let mut sides = [(DVec3::ZERO, 0.0); 5];
        for (k, side) in sides.iter_mut().take(3).enumerate() {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let inward = normal.cross(b - a);
            *side = (inward, inward.dot(a));
        }
        let (mut lo, mut hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        let mut count = 3;
        if reach.is_finite() {
            let n = normal.normalize();
            let h = n.dot(t[0]);
            sides[3] = (n, h - reach);
            sides[4] = (-n, -(h + reach));
            count = 5;
            let grow = n.abs() * reach;
            (lo, hi) = (lo - grow, hi + grow);
        } else {
            (lo, hi) = (DVec3::NEG_INFINITY, DVec3::INFINITY);
        }
        Some(Claimer {
            sides,
            count,
            lo,
            hi,
        })
    }

    fn may_meet(&self, (lo, hi): (DVec3, DVec3)) -> bool {
        !(self.lo.cmpgt(hi).any() || lo.cmpgt(self.hi).any())
    }
}

impl Polygon {
    fn bbox(&self) -> (DVec3, DVec3) {
        let c = self.corners();
        c[1..]
            .iter()
            .fold((c[0], c[0]), |(lo, hi), &p| (lo.min(p), hi.max(p)))
    }
}

/// An upper bound on `max over the piece of min over candidates of d(p, t)`, cutting the piece along
/// the candidates' prisms, each capped at `reach` from its plane (`f64::INFINITY`: not capped), in
/// the order given (nearest first works best); `None` when the piece would need more than
/// `max_parts` parts at once. Stops early, with a bound above `stop`, once one part is known to be
/// farther than `stop`. Add [`slack`] for rounding. The candidates the bound rests on (every part
/// was bounded against one of them) are added to `used`, by index.
pub fn upper_bound(
    piece: &[DVec3; 3],
    candidates: &[[DVec3; 3]],
    reach: f64,
    stop: f64,
    max_parts: usize,
    used: &mut Vec<usize>,
) -> Option<f64> {
    if candidates.is_empty() {
        return None;
    }
    // A part this small (by area) is bounded at once against the triangle that cut it off, rather
    // than carried on: rounding along shared prism walls leaves such slivers.
    let sliver = 1e-10 * Polygon::triangle(piece).double_area();
    let whole = Polygon::triangle(piece);
    let mut pending = vec![(whole, whole.bbox())];
    let mut worst = 0.0f64;
    // The parts no prism claimed, and those too complex to cut again.
    let mut left = Vec::new();
    let claimers: Vec<Option<Claimer>> =
        candidates.iter().map(|t| Claimer::new(t, reach)).collect();
    for (index, (t, claimer)) in candidates.iter().zip(&claimers).enumerate() {
        let Some(claimer) = claimer else { continue };
        let mut claimed = false;
        // Downwards, so that a part taken out is replaced by one already seen, and the parts this
        // candidate cuts off (pushed at the end) are not seen again.
        'parts: for i in (0..pending.len()).rev() {
            if !claimer.may_meet(pending[i].1) {
                continue;
            }
            let mut rest = pending.swap_remove(i).0;
            for &(n, d) in &claimer.sides[..claimer.count] {
                let Ok((inside, outside)) = rest.split(n, d) else {
                    left.push(rest);
                    continue 'parts;
                };
                if let Some(out) = outside {
                    if out.double_area() <= sliver {
                        worst = worst.max(out.bound(t));
                        claimed = true;
                    } else {
                        pending.push((out, out.bbox()));
                    }
                }
                match inside {
                    Some(inside) => rest = inside,
                    None => continue 'parts,
                }
            }
            worst = worst.max(rest.bound(t));
            claimed = true;
            if worst > stop {
                return Some(worst);
            }
        }
        if claimed {
            used.push(index);
        }
        if pending.len() + left.len() > max_parts {
            return None;
        }
        if pending.is_empty() && left.is_empty() {
            return Some(worst);
        }
    }
    // What is left: each part against the candidates that may come near it (and the first, so that
    // there is always one).
    for part in pending.into_iter().map(|(p, _)| p).chain(left) {
        let bbox = part.bbox();
        let (best, index) = candidates
            .iter()
            .zip(&claimers)
            .enumerate()
            .filter(|(i, (_, c))| *i == 0 || c.as_ref().is_some_and(|c| c.may_meet(bbox)))
            .map(|(i, (t, _))| (part.bound(t), i))
            .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a });
        used.push(index);
        worst = worst.max(best);
        if worst > stop {
            break;
        }
    }
    Some(worst)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    /// A unit grid of `n × n` cells, two triangles each, at height z.
    fn grid(n: usize, z: f64) -> Vec<[DVec3; 3]> {
        let mut out = Vec::new();
        for y in 0..n {
            for x in 0..n {
                let (x, y) = (x as f64, y as f64);
                out.push([v(x, y, z), v(x + 1.0, y, z), v(x + 1.0, y + 1.0, z)]);
                out.push([v(x, y, z), v(x + 1.0, y + 1.0, z), v(x, y + 1.0, z)]);
            }
        }
        out
    }

    /// A large triangle over a 4 × 4 grid of 32 small ones, 0.25 above it:
    /// ```text
    ///   (0,4) +--+--+--+--+
    ///         |\ |  |  |  |      the piece: (0,0) (4,0) (0,4), at z = 0.25
    ///         | \|  |  |  |      every point of it is 0.25 above the grid
    ///         +--\--+--+--+
    ///         |   \ ...
    ///   (0,0) +----\--------+ (4,0)
    /// ```
    /// No single small triangle is near the whole piece, but the prisms tile it: the bound is exact.
    #[test]
    fn a_piece_over_a_grid_is_bounded_exactly() {
        let piece = [v(0.0, 0.0, 0.25), v(4.0, 0.0, 0.25), v(0.0, 4.0, 0.25)];
        let b = upper_bound(
            &piece,
            &grid(4, 0.0),
            f64::INFINITY,
            f64::INFINITY,
            1000,
            &mut Vec::new(),
        )
        .unwrap();
        assert!((b - 0.25).abs() <= 1e-12, "{b}");
        // The best single triangle's corner bound is far above it.
        let single = grid(4, 0.0)
            .iter()
            .map(|t| Polygon::triangle(&piece).bound(t))
            .fold(f64::INFINITY, f64::min);
        assert!(single > 2.0, "{single}");
    }

    /// Two faces of a roof meeting at a ridge along x = 1, each sloping down at 45°, and a flat piece
    /// just above the ridge. The piece's points beyond both prisms (above the ridge, where the
    /// nearest point is on the ridge edge) are bounded by the best single face over their corners.
    /// ```text
    ///        piece at z = 1.1, x in [0.5, 1.5]
    ///     ----------------
    ///           /\          ridge at (1, ·, 1)
    ///          /  \
    /// ```
    #[test]
    fn across_a_ridge_the_bound_is_above_the_true_distance_and_sound() {
        let roof = vec![
            [v(0.0, 0.0, 0.0), v(1.0, 0.0, 1.0), v(1.0, 1.0, 1.0)],
            [v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), v(0.0, 1.0, 0.0)],
            [v(1.0, 0.0, 1.0), v(2.0, 0.0, 0.0), v(2.0, 1.0, 0.0)],
            [v(1.0, 0.0, 1.0), v(2.0, 1.0, 0.0), v(1.0, 1.0, 1.0)],
        ];
        let piece = [v(0.5, 0.2, 1.1), v(1.5, 0.2, 1.1), v(1.0, 0.8, 1.1)];
        let b = upper_bound(
            &piece,
            &roof,
            f64::INFINITY,
            f64::INFINITY,
            1000,
            &mut Vec::new(),
        )
        .unwrap();
        // The true maximum, sampled densely: every sample is at most the bound.
        let mut sampled = 0.0f64;
        for i in 0..=60 {
            for j in 0..=(60 - i) {
                let (s, t) = (i as f64 / 60.0, j as f64 / 60.0);
                let p = piece[0] + (piece[1] - piece[0]) * s + (piece[2] - piece[0]) * t;
                let d = roof
                    .iter()
                    .map(|r| {
                        super::super::closest_point_on_triangle64(p, r[0], r[1], r[2]).distance(p)
                    })
                    .fold(f64::INFINITY, f64::min);
                sampled = sampled.max(d);
            }
        }
        assert!(sampled <= b + 1e-12, "{sampled} > {b}");
        // The piece's far corners are 0.6 / √2 + … from the faces; the bound stays near the truth.
        assert!(b < sampled * 1.5, "{b} vs {sampled}");
    }

    /// Early exit: once a part is known to be farther than `stop`, the bound says so.
    #[test]
    fn a_part_beyond_stop_ends_the_search() {
        let piece = [v(0.0, 0.0, 1.0), v(4.0, 0.0, 1.0), v(0.0, 4.0, 1.0)];
        let b = upper_bound(&piece, &grid(4, 0.0), 0.5, 0.5, 1000, &mut Vec::new()).unwrap();
        assert!(b > 0.5);
    }
}

//! The quadric error metric of Michael Garland and Paul S. Heckbert, *Surface simplification using
//! quadric error metrics*, SIGGRAPH 97 (as compared with edge length and midpoint placement in Chen
//! Jianfei's lab report for *Fundamentals of Computer Graphics*, Tsinghua University).
//!
//! `Q = Σ w_i p_i p_iᵀ` over planes `p_i = (n, d)` with `n·x + d = 0`; the cost of a position `v` is
//! `vᵀ Q v` in homogeneous coordinates. Kept in `f64`: optimal placement solves a 3×3 system whose
//! matrix is a sum of outer products and loses precision fast in `f32` far from the origin.

use glam::{DVec3, Vec3};
use std::ops::{Add, AddAssign};

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Quadric {
    // Symmetric 3×3 part A, linear part b, constant c: Q(v) = vᵀAv + 2 bᵀv + c.
    a00: f64,
    a01: f64,
    a02: f64,
    a11: f64,
    a12: f64,
    a22: f64,
    b: [f64; 3],
    c: f64,
    /// Sum of the plane weights, to turn a cost into a mean squared distance.
    pub weight: f64,
}

/// Below this, `|det A| / scale³` is treated as singular: the planes do not pin down a point (a flat or
/// cylindrical region), and the solution would run off along the free direction. The builder keeps A
/// in `f32` ([`LocalQuadric`]), whose rounding leaves up to about 1e-7 in a singular matrix: at 1e-7
/// and below, one cylindrical merge on cessna's wing ran off and its max error at 10 % went 0.28 → 0.93
/// (% of the diagonal); at 1e-6 every model keeps its quality (BENCHMARKS.md).
const SINGULAR_DET: f64 = 1e-6;

impl Quadric {
    /// The quadric of the plane with unit normal `n` through `point`, with weight `w`.
    pub fn from_plane(n: DVec3, point: DVec3, w: f64) -> Quadric {
        Quadric::from_linear(n, -n.dot(point), w)
    }

    /// The quadric of `w · (g·x + d)²`, any `g` (a plane's when `g` is a unit normal; a colour
    /// channel's linear function in [`super::attribute_quadric`]).
    pub fn from_linear(g: DVec3, d: f64, w: f64) -> Quadric {
        Quadric {
            a00: w * g.x * g.x,
            a01: w * g.x * g.y,
            a02: w * g.x * g.z,
            a11: w * g.y * g.y,
            a12: w * g.y * g.z,
            a22: w * g.z * g.z,
            b: [w * g.x * d, w * g.y * d, w * g.z * d],
            c: w * d * d,
            weight: w,
        }
    }

    /// A constraint plane (Garland & Heckbert §6.2): it pulls like a plane of weight `w` but adds nothing
    /// to [`Quadric::weight`], so it does not dilute the mean squared distance to the surface's own planes.
    pub fn constraint(n: DVec3, point: DVec3, w: f64) -> Quadric {
        Quadric {
            weight: 0.0,
            ..Quadric::from_plane(n, point, w)
        }
    }

    /// Area-weighted quadric of a triangle's plane; zero for a degenerate triangle.
    pub fn from_triangle(p0: Vec3, p1: Vec3, p2: Vec3) -> Quadric {
        let (p0, p1, p2) = (p0.as_dvec3(), p1.as_dvec3(), p2.as_dvec3());
        let cross = (p1 - p0).cross(p2 - p0);
        let len = cross.length();
        if len <= 0.0 || !len.is_finite() {
            return Quadric::default();
        }
        Quadric::from_plane(cross / len, p0, 0.5 * len)
    }

    /// `A v`.
    fn times(&self, v: DVec3) -> DVec3 {
        DVec3::new(
            self.a00 * v.x + self.a01 * v.y + self.a02 * v.z,
            self.a01 * v.x + self.a11 * v.y + self.a12 * v.z,
            self.a02 * v.x + self.a12 * v.y + self.a22 * v.z,
        )
    }

    /// Whether every term is finite.
    pub fn is_finite(&self) -> bool {
        [
            self.a00,
            self.a01,
            self.a02,
            self.a11,
            self.a12,
            self.a22,
            self.c,
            self.weight,
        ]
        .into_iter()
        .chain(self.b)
        .all(f64::is_finite)
    }

    /// `vᵀ Q v`, clamped at zero (rounding can make it slightly negative).
    pub fn eval(&self, v: DVec3) -> f64 {
        let av = self.times(v);
        let b = DVec3::from_array(self.b);
        (v.dot(av) + 2.0 * b.dot(v) + self.c).max(0.0)
    }

    /// Mean squared distance to the planes: `vᵀQv / Σw`. This is what queues are ordered by, so a
    /// region's size does not by itself make its merges expensive.
    pub fn error(&self, v: DVec3) -> f64 {
        if self.weight > 0.0 {
            self.eval(v) / self.weight
        } else {
            0.0
        }
    }

    /// The same quadric about the origin moved by `t`: with `u = v − t`,
    /// `Q = uᵀAu + 2 (b + At)ᵀu + Q(t)`.
    pub fn shifted(&self, t: DVec3) -> Quadric {
        let at = self.times(t);
        let b = DVec3::from_array(self.b);
        Quadric {
            b: (b + at).to_array(),
            c: self.c + 2.0 * b.dot(t) + t.dot(at),
            ..*self
        }
    }

    /// The position minimising `vᵀQv`: solves `A v = −b` (Garland and Heckbert's 4×4 system with its last row
    /// `[0 0 0 1]`). `None` when A is ill-conditioned.
    pub fn optimum(&self) -> Option<DVec3> {
        let (a, b, c, d, e, f) = (self.a00, self.a01, self.a02, self.a11, self.a12, self.a22);
        // Cofactors of the symmetric matrix [[a b c] [b d e] [c e f]].
        let c00 = d * f - e * e;
        let c01 = c * e - b * f;
        let c02 = b * e - c * d;
        let det = a * c00 + b * c01 + c * c02;
        let scale = a.abs() + d.abs() + f.abs();
        if scale <= 0.0 || det.abs() <= SINGULAR_DET * scale * scale * scale {
            return None;
        }
        let c11 = a * f - c * c;
        let c12 = b * c - a * e;
        let c22 = a * d - b * b;
        let r = DVec3::from_array(self.b).map(|x| -x);
        let v = DVec3::new(
            c00 * r.x + c01 * r.y + c02 * r.z,
            c01 * r.x + c11 * r.y + c12 * r.z,
            c02 * r.x + c12 * r.y + c22 * r.z,
        ) / det;
        v.is_finite().then_some(v)
    }
}

/// A [`Quadric`] kept in `f32` about its own vertex: 44 bytes instead of 88, so that what pricing
/// reads of a vertex fits one cache line ([`crate::simplify::metric::PairEnd`]). About the vertex, the
/// linear and constant parts are as small as the vertex's distances to its planes, so `f32` keeps their
/// relative precision; about the world's origin they would be large terms that cancel.
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct LocalQuadric {
    a: [f32; 6],
    b: [f32; 3],
    c: f32,
    weight: f32,
}

impl LocalQuadric {
    /// `q`, already expressed about the vertex, rounded to `f32`.
    pub fn new(q: &Quadric) -> LocalQuadric {
        LocalQuadric {
            a: [q.a00, q.a01, q.a02, q.a11, q.a12, q.a22].map(|x| x as f32),
            b: q.b.map(|x| x as f32),
            c: q.c as f32,
            weight: q.weight as f32,
        }
    }

    /// Sum of the plane weights (the area the quadric stands for).
    pub fn weight(&self) -> f32 {
        self.weight
    }

    /// Back in `f64`, still about the vertex.
    pub fn get(&self) -> Quadric {
        let [a00, a01, a02, a11, a12, a22] = self.a.map(f64::from);
        Quadric {
            a00,
            a01,
            a02,
            a11,
            a12,
            a22,
            b: self.b.map(f64::from),
            c: self.c as f64,
            weight: self.weight as f64,
        }
    }
}

impl Add for Quadric {
    type Output = Quadric;
    fn add(mut self, o: Quadric) -> Quadric {
        self += o;
        self
    }
}

impl AddAssign for Quadric {
    fn add_assign(&mut self, o: Quadric) {
        self.a00 += o.a00;
        self.a01 += o.a01;
        self.a02 += o.a02;
        self.a11 += o.a11;
        self.a12 += o.a12;
        self.a22 += o.a22;
        for k in 0..3 {
            self.b[k] += o.b[k];
        }
        self.c += o.c;
        self.weight += o.weight;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_planes_meet_at_a_corner() {
        // The planes x = 1, y = 2, z = 3 meet at (1, 2, 3) with zero cost there.
        let q = Quadric::from_plane(DVec3::X, DVec3::new(1.0, 0.0, 0.0), 1.0)
            + Quadric::from_plane(DVec3::Y, DVec3::new(0.0, 2.0, 0.0), 1.0)
            + Quadric::from_plane(DVec3::Z, DVec3::new(0.0, 0.0, 3.0), 1.0);
        let v = q.optimum().unwrap();
        assert!((v - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
        assert!(q.eval(v) < 1e-12);
        // One unit off each plane costs 1 per plane.
        assert!((q.eval(DVec3::new(2.0, 3.0, 4.0)) - 3.0).abs() < 1e-12);
        assert!((q.error(DVec3::new(2.0, 3.0, 4.0)) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_shifted_quadric_prices_every_point_alike() {
        let q = Quadric::from_triangle(Vec3::ZERO, Vec3::X, Vec3::Y)
            + Quadric::from_triangle(Vec3::ZERO, Vec3::Z, Vec3::X)
            + Quadric::constraint(DVec3::new(0.6, 0.0, 0.8), DVec3::ONE, 2.0);
        let t = DVec3::new(0.5, -2.0, 3.0);
        let moved = q.shifted(t);
        for v in [DVec3::ZERO, DVec3::ONE, DVec3::new(-1.0, 4.0, 0.25)] {
            assert!((q.eval(v) - moved.eval(v - t)).abs() < 1e-9 * (1.0 + q.eval(v)));
        }
        assert_eq!(moved.weight, q.weight);
        // About a point, the stored constant is the cost there.
        assert!((moved.c - q.eval(t)).abs() < 1e-12);
        // In f32 about a vertex on the planes, costs near it keep their relative precision.
        let local = LocalQuadric::new(&q.shifted(DVec3::ZERO)).get();
        let near = DVec3::new(1e-4, 2e-4, -1e-4);
        assert!((local.eval(near) - q.eval(near)).abs() < 1e-6 * q.eval(near));
    }

    #[test]
    fn a_single_plane_is_singular() {
        let q = Quadric::from_triangle(Vec3::ZERO, Vec3::X, Vec3::Y);
        assert!(q.optimum().is_none());
        assert!((q.weight - 0.5).abs() < 1e-12);
        assert!((q.eval(DVec3::new(0.3, 0.3, 2.0)) - 0.5 * 4.0).abs() < 1e-12);
    }
}

//! Appearance in a merge's price: Michael Garland and Paul S. Heckbert's attribute quadrics
//! (*Simplifying surfaces with color and texture using quadric error metrics*, IEEE Visualization
//! 98), in the compact form of Hugues Hoppe (*New quadric metric for simplifying meshes with
//! appearance attributes*, IEEE Visualization 99), over five channels: colour (three) and texture
//! coordinates (two).
//!
//! Every channel is given in units of length, so that one residual weighs them all against the
//! shape's squared distances: a colour channel times the length a full channel's difference counts
//! as (`--color-weight` × the diagonal), a texture coordinate times its texture's length per unit
//! of texture space (the square root of the surface's area over its charts' area), so that its
//! residual is how far the texture would slide over the surface.
//!
//! Over each triangle, each channel is the linear function `g·x + d` that takes the corners'
//! values at the corners (`g` in the triangle's plane). A vertex's quadric sums
//! `area · (s − g·x − d)²` over its triangles and the channels: how far a value `s` drawn at `x`
//! strays from what the input has there. For a position `x` the best `s` is the area-weighted mean
//! of the triangles' functions at `x`, and what is left is [`AttributeQuadric::residual`]: zero where
//! one linear gradient spans all the triangles (a smooth shading ramp, or a chart whose texture
//! coordinates are a linear map of the surface, merges for free), and Ward's `Σ area · |c − mean|²`
//! where each triangle is one flat colour.

use super::quadric::{LocalQuadric, Quadric};
use glam::{DVec3, DVec4, Vec3};
use std::ops::Add;

/// Channels: colour (red, green, blue), then texture coordinates (u, v).
pub const CHANNELS: usize = 5;

/// The share of a residual's sums under which it is rounding (see
/// [`LocalAttributeQuadric::pair_mean_residual`]).
const CANCELLATION: f64 = 1e-6;

/// The attribute quadric about some origin, in `f64`, as pricing works with it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AttributeQuadric {
    /// `Σ area · (g·x + d)²` over the triangles and channels, as a quadric in `x`; its weight is
    /// `Σ area` (counted once, not per channel).
    spatial: Quadric,
    /// Per channel, `(Σ area · g, Σ area · d)`.
    linear: [DVec4; CHANNELS],
}

impl AttributeQuadric {
    /// The quadric of one triangle with corner values `c` (each channel in units of length, see
    /// the module's text), weighted by its area; zero for a degenerate triangle.
    pub fn from_triangle(p: [Vec3; 3], c: [[f64; CHANNELS]; 3]) -> AttributeQuadric {
        let [p0, p1, p2] = p.map(|x| x.as_dvec3());
        let (e1, e2) = (p1 - p0, p2 - p0);
        let (a, b, cc) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        // det = |e1 × e2|² = (2 area)².
        let det = a * cc - b * b;
        let area = 0.5 * det.max(0.0).sqrt();
        if !(area > 0.0 && det.is_finite()) {
            return AttributeQuadric::default();
        }
        let mut out = AttributeQuadric::default();
        for k in 0..CHANNELS {
            let [c0, c1, c2] = c.map(|x| x[k]);
            // g = α e1 + β e2 with g·e1 = c1 − c0 and g·e2 = c2 − c0.
            let (d1, d2) = (c1 - c0, c2 - c0);
            let alpha = (cc * d1 - b * d2) / det;
            let beta = (a * d2 - b * d1) / det;
            let g = alpha * e1 + beta * e2;
            let d = c0 - g.dot(p0);
            out.spatial += Quadric::from_linear(g, d, area);
            out.linear[k] = area * g.extend(d);
        }
        out.spatial.weight = area;
        // A sliver with corner colours far apart has a steep gradient; beyond `f64` it counts for
        // nothing rather than poison every sum it joins.
        let finite = out.spatial.is_finite() && out.linear.iter().all(|l| l.is_finite());
        if finite {
            out
        } else {
            AttributeQuadric::default()
        }
    }

    /// The area the quadric stands for.
    pub fn weight(&self) -> f64 {
        self.spatial.weight
    }

    /// The same quadric about the origin moved by `t`.
    pub fn shifted(&self, t: DVec3) -> AttributeQuadric {
        AttributeQuadric {
            spatial: self.spatial.shifted(t),
            linear: self
                .linear
                .map(|l| l.truncate().extend(l.w + l.truncate().dot(t))),
        }
    }

    /// The best colour to draw at `x`: the area-weighted mean of the triangles' colour functions
    /// there, divided by the `scale` the colour channels were given in and clamped to `[0, 1]`;
    /// `None` for a quadric of no area.
    pub fn best_color(&self, x: DVec3, scale: f64) -> Option<Vec3> {
        let w = self.spatial.weight * scale;
        (w > 0.0).then(|| {
            Vec3::from_array(std::array::from_fn(|k| {
                let l = self.linear[k];
                ((l.truncate().dot(x) + l.w) / w).clamp(0.0, 1.0) as f32
            }))
        })
    }

    /// `Σ area · |s − value|²` at `x` for the best values `s` there (see the module's text), in
    /// squared length times area; never negative.
    pub fn residual(&self, x: DVec3) -> f64 {
        let w = self.spatial.weight;
        if w <= 0.0 {
            return 0.0;
        }
        let fitted: f64 = self
            .linear
            .iter()
            .map(|l| {
                let s = l.truncate().dot(x) + l.w;
                s * s
            })
            .sum();
        (self.spatial.eval(x) - fitted / w).max(0.0)
    }
}

impl AttributeQuadric {
    /// [`AttributeQuadric::residual`] per unit of area: the mean squared attribute error at `x`.
    pub fn mean_residual(&self, x: DVec3) -> f64 {
        let w = self.spatial.weight;
        if w > 0.0 { self.residual(x) / w } else { 0.0 }
    }
}

impl Add for AttributeQuadric {
    type Output = AttributeQuadric;
    fn add(self, o: AttributeQuadric) -> AttributeQuadric {
        AttributeQuadric {
            spatial: self.spatial + o.spatial,
            linear: std::array::from_fn(|k| self.linear[k] + o.linear[k]),
        }
    }
}

impl std::ops::AddAssign for AttributeQuadric {
    fn add_assign(&mut self, o: AttributeQuadric) {
        *self = *self + o;
    }
}

/// An [`AttributeQuadric`] kept in `f32` about its own vertex, beside the vertex's
/// [`PairEnd`](super::metric::PairEnd) (124 bytes; only meshes with colours have them). About the
/// vertex the linear parts are the values there, so `f32` keeps their precision.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LocalAttributeQuadric {
    spatial: LocalQuadric,
    linear: [[f32; 4]; CHANNELS],
}

impl LocalAttributeQuadric {
    /// The best colour to draw at the vertex (see [`AttributeQuadric::best_color`]).
    pub fn best_color(&self, scale: f64) -> Option<Vec3> {
        let w = self.spatial.weight() as f64 * scale;
        (w > 0.0).then(|| {
            Vec3::from_array(std::array::from_fn(|k| {
                (self.linear[k][3] as f64 / w).clamp(0.0, 1.0) as f32
            }))
        })
    }

    /// The best texture coordinates at the vertex, in the channels' units of length (the
    /// texture's scale times the coordinates); `None` for a quadric of no area.
    pub fn best_texture(&self) -> Option<glam::Vec2> {
        let w = self.spatial.weight();
        (w > 0.0).then(|| glam::Vec2::new(self.linear[3][3], self.linear[4][3]) / w)
    }

    /// `q`, already expressed about the vertex, rounded to `f32`.
    pub fn new(q: &AttributeQuadric) -> LocalAttributeQuadric {
        LocalAttributeQuadric {
            spatial: LocalQuadric::new(&q.spatial),
            linear: q.linear.map(|l| l.as_vec4().to_array()),
        }
    }

    /// The mean squared colour residual of `a` and `b` summed (see [`AttributeQuadric::mean_residual`])
    /// at one point, given as `xa` from `a`'s vertex and `xb` from `b`'s: what pricing a merge
    /// needs, evaluated where each quadric is, without moving either to a common origin.
    pub fn pair_mean_residual(
        a: &LocalAttributeQuadric,
        xa: DVec3,
        b: &LocalAttributeQuadric,
        xb: DVec3,
    ) -> f64 {
        let w = a.spatial.weight() as f64 + b.spatial.weight() as f64;
        if w <= 0.0 {
            return 0.0;
        }
        let spatial = a.spatial.get().eval(xa) + b.spatial.get().eval(xb);
        let linear =
            |l: &[f32; 4], x: DVec3| glam::Vec4::from_array(*l).as_dvec4().dot(x.extend(1.0));
        let fitted: f64 = (0..CHANNELS)
            .map(|k| {
                let s = linear(&a.linear[k], xa) + linear(&b.linear[k], xb);
                s * s
            })
            .sum();
        // What is left is a difference of two near-equal sums where the attributes are linear:
        // below a millionth of the sums it is the rounding of the `f32` quadrics, not a colour or
        // a slide, and counts as none (so that a linear ramp merges exactly as shape alone does).
        let left = spatial - fitted / w;
        if left > CANCELLATION * spatial {
            left / w
        } else {
            0.0
        }
    }

    /// `Σ area · |s − value|²` at `x` (relative to the quadric's origin) for the best values `s`
    /// there, what is left below a millionth of its sums counting as none (as in
    /// [`LocalAttributeQuadric::pair_mean_residual`]).
    pub fn residual_at(&self, x: DVec3) -> f64 {
        let w = self.spatial.weight() as f64;
        if w <= 0.0 {
            return 0.0;
        }
        let spatial = self.spatial.get().eval(x);
        let fitted: f64 = self
            .linear
            .iter()
            .map(|l| {
                let s = glam::Vec4::from_array(*l).as_dvec4().dot(x.extend(1.0));
                s * s
            })
            .sum();
        let left = spatial - fitted / w;
        if left > CANCELLATION * spatial {
            left
        } else {
            0.0
        }
    }

    /// The best texture coordinates at `x` (relative to the quadric's origin), in the channels'
    /// units of length; `None` for a quadric of no area.
    pub fn texture_at(&self, x: DVec3) -> Option<glam::DVec2> {
        let w = self.spatial.weight() as f64;
        let at = |l: &[f32; 4]| glam::Vec4::from_array(*l).as_dvec4().dot(x.extend(1.0)) / w;
        (w > 0.0).then(|| glam::DVec2::new(at(&self.linear[3]), at(&self.linear[4])))
    }

    /// The area the quadric stands for.
    pub fn weight(&self) -> f64 {
        self.spatial.weight() as f64
    }

    /// Back in `f64`, about the vertex at `at`, then moved to be about `origin`.
    pub fn about(&self, at: Vec3, origin: DVec3) -> AttributeQuadric {
        AttributeQuadric {
            spatial: self.spatial.get(),
            linear: self.linear.map(|l| glam::Vec4::from_array(l).as_dvec4()),
        }
        .shifted(origin - at.as_dvec3())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A colour as the five channels, with no texture coordinates.
    fn rgb(c: Vec3) -> [f64; CHANNELS] {
        [c.x as f64, c.y as f64, c.z as f64, 0.0, 0.0]
    }

    /// Texture coordinates that are a linear map of the square cost nothing; a map folded along
    /// the diagonal (one triangle's texture stretched to twice the other's) costs, and is
    /// measured in the units the channels were given in: the texture's slide over the surface.
    #[test]
    fn texture_stretch_costs_and_a_linear_map_does_not() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let uv = |u: f32, v: f32| [0.0, 0.0, 0.0, u as f64, v as f64];
        // The square's two triangles with corner values `c`.
        let square = |c: [[f64; CHANNELS]; 4]| {
            AttributeQuadric::from_triangle([p[0], p[1], p[2]], [c[0], c[1], c[2]])
                + AttributeQuadric::from_triangle([p[0], p[2], p[3]], [c[0], c[2], c[3]])
        };
        let linear = p.map(|x| uv(0.5 * x.x + 0.1, 0.5 * x.y));
        assert!(square(linear).residual(DVec3::new(0.3, 0.6, 0.0)) < 1e-12);
        // The lower-right triangle maps (1, 0) to u = 1 instead of 0.5.
        let mut folded = linear;
        folded[1] = uv(1.0, 0.0);
        let q = square(folded);
        // Both triangles agree along the diagonal they share; at (1, 0) the lower one says
        // u = 1 and the upper one (extended) 0.6: each is 0.2 from the mean, so 0.2² per area.
        assert!(q.residual(DVec3::new(0.5, 0.5, 0.0)) < 1e-12);
        let r = q.mean_residual(DVec3::new(1.0, 0.0, 0.0));
        assert!((r - 0.04).abs() < 1e-6, "{r}");
        // Best colour is none of it: the colour channels are zero.
        assert_eq!(q.best_color(DVec3::ZERO, 1.0), Some(Vec3::ZERO));
    }

    /// Two triangles of the unit square, coloured by one linear ramp (red = x) or split flat.
    ///
    /// ```text
    ///   (0,1) ┌──┐ (1,1)
    ///         │ ╱│
    ///   (0,0) └──┘ (1,0)
    /// ```
    fn square(colour: impl Fn(Vec3) -> Vec3) -> AttributeQuadric {
        let p = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let c = p.map(|x| rgb(colour(x)));
        AttributeQuadric::from_triangle([p[0], p[1], p[2]], [c[0], c[1], c[2]])
            + AttributeQuadric::from_triangle([p[0], p[2], p[3]], [c[0], c[2], c[3]])
    }

    #[test]
    fn a_linear_ramp_costs_nothing_anywhere() {
        let q = square(|p| Vec3::new(p.x, 0.5, 1.0 - p.y));
        assert!((q.weight() - 1.0).abs() < 1e-12);
        for x in [
            DVec3::ZERO,
            DVec3::new(0.3, 0.8, 0.0),
            DVec3::new(2.0, -1.0, 0.5),
        ] {
            assert!(q.residual(x) < 1e-12, "{x}: {}", q.residual(x));
        }
    }

    #[test]
    fn flat_colours_cost_their_variance() {
        // Lower-right triangle black, upper-left white, each flat: at any point the best colour
        // is the mean grey, and Σ area · |c − mean|² = 2 · ½ · 3 · ½² = 0.75.
        let p = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let q = AttributeQuadric::from_triangle([p[0], p[1], p[2]], [rgb(Vec3::ZERO); 3])
            + AttributeQuadric::from_triangle([p[0], p[2], p[3]], [rgb(Vec3::ONE); 3]);
        for x in [
            DVec3::ZERO,
            DVec3::new(0.5, 0.5, 0.0),
            DVec3::new(0.0, 0.0, 3.0),
        ] {
            assert!((q.residual(x) - 0.75).abs() < 1e-12, "{}", q.residual(x));
        }
    }

    #[test]
    fn shifting_and_rounding_keep_the_residual() {
        let q = square(|p| Vec3::new(p.x * p.y, p.x, 0.2));
        let at = Vec3::new(1.0, 1.0, 0.0);
        let local = LocalAttributeQuadric::new(&q.shifted(at.as_dvec3()));
        let origin = DVec3::new(0.25, 0.5, 0.0);
        let back = local.about(at, origin);
        for x in [
            DVec3::ZERO,
            DVec3::new(0.5, 0.5, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
        ] {
            let (want, got) = (q.residual(x), back.residual(x - origin));
            assert!((want - got).abs() < 1e-6, "{x}: {want} vs {got}");
        }
        // Two such quadrics at different vertices, evaluated in place, as pricing sums them.
        let (at2, origin2) = (Vec3::new(0.0, 1.0, 0.0), DVec3::new(0.5, 0.25, 0.0));
        let local2 = LocalAttributeQuadric::new(&q.shifted(at2.as_dvec3()));
        let sum = local.about(at, origin2) + local2.about(at2, origin2);
        for x in [
            DVec3::ZERO,
            DVec3::new(0.5, 0.5, 0.0),
            DVec3::new(1.0, 0.2, 0.3),
        ] {
            let want = sum.mean_residual(x - origin2);
            let got = LocalAttributeQuadric::pair_mean_residual(
                &local,
                x - at.as_dvec3(),
                &local2,
                x - at2.as_dvec3(),
            );
            assert!((want - got).abs() < 1e-6, "{x}: {want} vs {got}");
        }
        // x·y is y on the lower triangle and x on the upper: they disagree off the diagonal.
        assert!(
            q.residual(DVec3::new(1.0, 0.0, 0.0)) > 0.1,
            "x·y is not linear"
        );
    }
}

//! Bounding spheres and normal cones of vertex-tree subtrees (the runtime's frustum and back-face tests;
//! see SPEC §1.4 and Hoppe 1997 §4).

use glam::Vec3;

/// A sphere, `radius ≥ 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
}

impl Sphere {
    pub fn point(p: Vec3) -> Sphere {
        Sphere {
            center: p,
            radius: 0.0,
        }
    }

    pub fn contains(&self, p: Vec3, slack: f32) -> bool {
        self.center.distance(p) <= self.radius + slack
    }

    /// The smallest sphere enclosing both spheres.
    pub fn union(self, o: Sphere) -> Sphere {
        let d = o.center - self.center;
        let dist = d.length();
        if dist + o.radius <= self.radius {
            return self;
        }
        if dist + self.radius <= o.radius {
            return o;
        }
        let radius = 0.5 * (dist + self.radius + o.radius);
        // dist > 0 here: equal centres fall into one of the cases above.
        let center = self.center + d * ((radius - self.radius) / dist);
        // Round outwards so float error never leaves a child poking out.
        Sphere {
            center,
            radius: radius * (1.0 + f32::EPSILON * 4.0),
        }
    }

    pub fn union_point(self, p: Vec3) -> Sphere {
        self.union(Sphere::point(p))
    }
}

/// A cone of directions: every normal `n` in it has `angle(n, axis) ≤ acos(cos_angle)`. A cone with
/// `cos_angle == -1` holds every direction ("full": never back-face culled).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalCone {
    pub axis: Vec3,
    pub cos_angle: f32,
}

impl NormalCone {
    pub const EMPTY: NormalCone = NormalCone {
        axis: Vec3::ZERO,
        cos_angle: 1.0,
    };
    pub const FULL: NormalCone = NormalCone {
        axis: Vec3::Z,
        cos_angle: -1.0,
    };

    pub fn is_empty(&self) -> bool {
        self.axis == Vec3::ZERO
    }

    pub fn is_full(&self) -> bool {
        self.cos_angle <= -1.0
    }

    fn angle(&self) -> f32 {
        self.cos_angle.clamp(-1.0, 1.0).acos()
    }

    /// Does the cone hold direction `n` (unit), within `slack` radians?
    pub fn contains(&self, n: Vec3, slack: f32) -> bool {
        self.is_full()
            || (!self.is_empty()
                && self.axis.dot(n).clamp(-1.0, 1.0).acos() <= self.angle() + slack)
    }

    /// The smallest cone holding both cones.
    pub fn union(self, o: NormalCone) -> NormalCone {
        if self.is_empty() {
            return o;
        }
        if o.is_empty() {
            return self;
        }
        if self.is_full() || o.is_full() {
            return NormalCone::FULL;
        }
        let (t1, t2) = (self.angle(), o.angle());
        let phi = self.axis.dot(o.axis).clamp(-1.0, 1.0).acos();
        if phi + t2 <= t1 {
            return self;
        }
        if phi + t1 <= t2 {
            return o;
        }
        let t = 0.5 * (t1 + phi + t2);
        if t >= std::f32::consts::PI || phi >= std::f32::consts::PI - 1e-4 {
            return NormalCone::FULL;
        }
        // Rotate self.axis towards o.axis by (t − t1) in their common plane.
        let ortho = (o.axis - self.axis * self.axis.dot(o.axis)).normalize_or_zero();
        let r = t - t1;
        let axis = (self.axis * r.cos() + ortho * r.sin()).normalize_or_zero();
        if axis == Vec3::ZERO {
            return NormalCone::FULL;
        }
        // Pad by a few ulps of angle so rounding never excludes a member.
        NormalCone {
            axis,
            cos_angle: (t + 1e-5).cos(),
        }
    }

    pub fn union_normal(self, n: Vec3) -> NormalCone {
        // Most normals added to a cone are already inside it: one dot product, no trigonometry.
        if n == Vec3::ZERO
            || self.is_full()
            || (!self.is_empty() && self.axis.dot(n) >= self.cos_angle)
        {
            self
        } else {
            self.union(NormalCone {
                axis: n,
                cos_angle: 1.0,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_union_contains_both() {
        let a = Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        };
        let b = Sphere {
            center: Vec3::new(4.0, 0.0, 0.0),
            radius: 1.0,
        };
        let u = a.union(b);
        assert!((u.center - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-6);
        assert!((u.radius - 3.0).abs() < 1e-5);
        assert_eq!(
            a.union(Sphere {
                center: Vec3::X * 0.5,
                radius: 0.1
            }),
            a
        );
    }

    #[test]
    fn cone_union() {
        let up = NormalCone::EMPTY.union_normal(Vec3::Z);
        let c = up.union_normal(Vec3::X);
        assert!((c.cos_angle - (std::f32::consts::FRAC_PI_4 + 1e-5).cos()).abs() < 1e-5);
        assert!(c.contains(Vec3::Z, 1e-5) && c.contains(Vec3::X, 1e-5));
        assert!(!c.contains(Vec3::NEG_Z, 0.0));
        assert!(
            c.union_normal(Vec3::NEG_X)
                .union_normal(Vec3::NEG_Z)
                .is_full()
        );
    }
}

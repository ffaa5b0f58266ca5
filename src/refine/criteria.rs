//! The camera and the three view tests of Tao et al. §3.2–3.3 as every view-dependent LOD system has them
//! (SPEC §1.4): the frustum test on a node's bounding sphere, the normal test on its normal cone, and the
//! screen-space error test in pixels.

use super::hierarchy::{Hierarchy, decode_normal};
use glam::{Mat4, Quat, Vec3, Vec4};

/// A perspective camera. The camera looks down its local −Z with +Y up; `orientation` turns local
/// into world directions.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Camera {
    pub position: Vec3,
    pub orientation: Quat,
    /// Vertical field of view.
    pub fov_y_radians: f32,
    /// Width and height of the image in pixels.
    pub viewport_px: [u32; 2],
    pub near: f32,
    pub far: f32,
}

impl Camera {
    /// A camera at `position` looking at `target`, `up` roughly up.
    pub fn looking_at(
        position: Vec3,
        target: Vec3,
        up: Vec3,
        fov_y_radians: f32,
        viewport_px: [u32; 2],
        near: f32,
        far: f32,
    ) -> Camera {
        Camera {
            position,
            orientation: look_rotation(target - position, up),
            fov_y_radians,
            viewport_px,
            near,
            far,
        }
    }

    pub fn forward(&self) -> Vec3 {
        self.orientation * Vec3::NEG_Z
    }

    pub fn aspect(&self) -> f32 {
        self.viewport_px[0].max(1) as f32 / self.viewport_px[1].max(1) as f32
    }

    pub fn view_from_world(&self) -> Mat4 {
        Mat4::from_rotation_translation(self.orientation, self.position).inverse()
    }

    /// Depth in `[0, 1]`, Y up: wgpu's clip space.
    pub fn clip_from_view(&self) -> Mat4 {
        glam::camera::rh::proj::directx::perspective(
            self.fov_y_radians,
            self.aspect(),
            self.near,
            self.far,
        )
    }

    pub fn clip_from_world(&self) -> Mat4 {
        self.clip_from_view() * self.view_from_world()
    }
}

/// The rotation turning −Z towards `forward` with +Y as close to `up` as it can be.
pub fn look_rotation(forward: Vec3, up: Vec3) -> Quat {
    let f = forward.normalize_or(Vec3::NEG_Z);
    let mut right = f.cross(up);
    if right.length_squared() < 1e-12 {
        // Looking straight along `up`: any right will do.
        right = f.any_orthonormal_vector();
    }
    let right = right.normalize();
    let true_up = right.cross(f);
    Quat::from_mat3(&glam::Mat3::from_cols(right, true_up, -f)).normalize()
}

/// One frame's view, prepared once and asked about many nodes.
#[derive(Clone, Copy, Debug)]
pub struct View {
    pub eye: Vec3,
    /// The direction the camera looks: view depth is `forward · (p − eye)`.
    forward: Vec3,
    /// Inward-facing planes `(n, d)`, `|n| = 1`: left, right, bottom, top, near, far.
    planes: [Vec4; 6],
    /// Pixels covered by one unit of length, facing the camera at distance 1:
    /// `height / (2 tan(fov / 2))`.
    px_per_unit: f32,
    near: f32,
}

impl View {
    pub fn new(camera: &Camera) -> View {
        let m = camera.clip_from_world();
        let [r0, r1, r2, r3] = [m.row(0), m.row(1), m.row(2), m.row(3)];
        // Gribb & Hartmann: with depth in [0, 1] the near plane is row 2 alone.
        let planes = [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2].map(|p| {
            let len = p.truncate().length();
            if len > 0.0 { p / len } else { p }
        });
        View {
            eye: camera.position,
            forward: camera.forward(),
            planes,
            px_per_unit: camera.viewport_px[1] as f32 / (2.0 * (camera.fov_y_radians * 0.5).tan()),
            near: camera.near,
        }
    }

    /// Pixels covered by one unit of length facing the camera at distance 1.
    pub fn px_per_unit(&self) -> f32 {
        self.px_per_unit
    }

    /// Frustum test: is the sphere wholly outside one plane?
    #[inline]
    pub fn outside(&self, center: Vec3, radius: f32) -> bool {
        self.planes
            .iter()
            .any(|p| p.truncate().dot(center) + p.w < -radius)
    }

    /// Normal test (Shirman & Abi-Ezzi's cone test): does every face in the sphere with a normal in
    /// the cone `(axis, sin θ)` face away from the eye? Directions from the eye into the sphere stay
    /// within α of the centre's, `sin α = r / d`; all faces face away when the axis is within
    /// `90° − θ − α` of that direction.
    #[inline]
    pub fn back_facing(&self, center: Vec3, radius: f32, axis: Vec3, sin_t: f32) -> bool {
        if sin_t >= 1.0 {
            return false;
        }
        let v = center - self.eye;
        let d = v.length();
        if d <= radius {
            return false;
        }
        let sin_a = radius / d;
        let (cos_t, cos_a) = ((1.0 - sin_t * sin_t).sqrt(), (1.0 - sin_a * sin_a).sqrt());
        // cos(θ + α) ≥ 0 and axis·v̂ ≥ sin(θ + α).
        cos_t * cos_a - sin_t * sin_a >= 0.0 && axis.dot(v) >= d * (sin_t * cos_a + cos_t * sin_a)
    }

    /// Screen-space error: an object-space error seen at the nearest distance of the sphere (never
    /// nearer than the near plane, where geometry is clipped anyway), in pixels.
    #[inline]
    pub fn projected_px(&self, error: f32, center: Vec3, radius: f32) -> f32 {
        let d = (center.distance(self.eye) - radius).max(self.near);
        error * self.px_per_unit / d
    }

    /// [`View::outside`], and how far the eye may move before it can give another answer: each
    /// plane's signed distance to the centre changes by at most the eye's move (and by the turn
    /// times the distance, see `Refiner`'s odometer). Inside every plane, the least room to any of
    /// them; outside one, the most room back over any plane it is outside of.
    #[inline]
    pub fn outside_with_margin(&self, center: Vec3, radius: f32) -> (bool, f32) {
        let (mut inside, mut outside) = (f32::INFINITY, 0f32);
        let mut out = false;
        for p in &self.planes {
            // `x + r < 0` exactly when `x < −r`, as `outside` asks: the sum's sign never rounds.
            let room = p.truncate().dot(center) + p.w + radius;
            if room < 0.0 {
                out = true;
                outside = outside.max(-room);
            } else {
                inside = inside.min(room);
            }
        }
        (out, if out { outside } else { inside })
    }

    /// How far the eye may move before [`View::back_facing`] of this sphere and cone can give
    /// another answer. With `β` the angle between the cone's axis and the direction to the centre
    /// (distance `d`), the test holds exactly when `r / d ≤ cos(θ + β)`. Moving the eye by `δ`
    /// only ever sees directions into the same sphere grown by `δ` (and always all those into it
    /// shrunk by `δ`), so a facing-away sphere stays so while `r + δ ≤ d cos(θ + β)`, and one that
    /// is not while `r − δ > d cos(θ + β)`.
    #[inline]
    pub fn facing_margin(&self, center: Vec3, radius: f32, axis: Vec3, sin_t: f32) -> f32 {
        if sin_t >= 1.0 {
            return f32::INFINITY;
        }
        let v = center - self.eye;
        let d = v.length();
        if d == 0.0 {
            return radius;
        }
        let cos_b = (axis.dot(v) / d).clamp(-1.0, 1.0);
        let sin_b = (1.0 - cos_b * cos_b).max(0.0).sqrt();
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        let edge = d * (cos_t * cos_b - sin_t * sin_b).max(0.0);
        (edge - radius).abs()
    }

    /// How far the eye may move before [`View::projected_px`] of this node can pass `px`, while it
    /// is at most `px`: the sphere's nearest point must come within `error · f / px` of the eye.
    #[inline]
    pub fn below_margin(&self, error: f32, center: Vec3, radius: f32, px: f32) -> f32 {
        let reach = error * self.px_per_unit / px;
        if reach < self.near {
            // Even at the near plane, where the distance stops shrinking, it stays below.
            return f32::INFINITY;
        }
        (center.distance(self.eye) - radius - reach).max(0.0)
    }

    /// How far the eye may move before [`View::projected_px`] of this node can drop below `px`,
    /// while it is at least `px`: the sphere's nearest point must move past `error · f / px`.
    #[inline]
    pub fn above_margin(&self, error: f32, center: Vec3, radius: f32, px: f32) -> f32 {
        (error * self.px_per_unit / px - (center.distance(self.eye) - radius)).max(0.0)
    }

    /// Whether triangle `[a, b, c]` lies wholly outside the view: all three corners outside one
    /// plane (conservative: a triangle across a frustum corner may be called inside).
    pub fn triangle_outside(&self, corners: [Vec3; 3]) -> bool {
        self.planes
            .iter()
            .any(|p| corners.iter().all(|c| p.truncate().dot(*c) + p.w < 0.0))
    }

    /// Whether triangle `[a, b, c]`, wound counter-clockwise seen from its front, faces the eye
    /// (`inward`: the model is wound the other way).
    pub fn faces_eye([a, b, c]: [Vec3; 3], eye: Vec3, inward: bool) -> bool {
        let toward = (b - a).cross(c - a).dot(eye - a);
        if inward { toward < 0.0 } else { toward > 0.0 }
    }

    /// A bound, in pixels, on how far any point of the sphere moves on screen when it moves by
    /// `error` in any direction. A point at view depth `z` and distance `d` from the eye moves at most
    /// `error · px_per_unit · d / z²` pixels (the largest singular value of the perspective map's
    /// Jacobian, `f / (z cos θ)` with `cos θ = z / d`): off the axis the image stretches, up to
    /// 1.9× in the corners of a 60° view, which [`View::projected_px`]'s `1 / d` leaves out. The
    /// point moves along a segment of length `error` from anywhere in the sphere, so along it
    /// `d ≤ |c − eye| + r + error` and `z ≥ z_c − r − error` (never nearer than the near plane).
    #[inline]
    pub fn projected_bound_px(&self, error: f32, center: Vec3, radius: f32) -> f32 {
        let v = center - self.eye;
        let reach = radius + error;
        let z = (self.forward.dot(v) - reach).max(self.near);
        let d = v.length() + reach;
        error * self.px_per_unit * d / (z * z)
    }
}

/// Which view tests refinement applies; each can be switched off alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct Tests {
    pub frustum: bool,
    pub normal: bool,
    pub screen_error: bool,
    /// The screen-space test also weighs how far shading may stray ([`Bounds::shading`](super::hierarchy::Bounds::shading)
    /// × [`SHADING_WEIGHT`]), not only geometry.
    pub shading: bool,
    /// The screen-space test projects the strict deviation bound ([`Bounds::bound`](super::hierarchy::Bounds::bound))
    /// instead of the measured error: then no point of the input surface is drawn more than τ
    /// pixels from where it belongs, at the price of many more triangles (the bound counts sliding
    /// along the surface as deviation, and the back-face test is left out). Off by default.
    pub strict: bool,
}

/// Shading deviation counts at this share of its length: the node radius times the sine of its
/// normals' turn overstates the visible change of a smooth curved patch (whose interpolated normals
/// follow the curve) about twice; BENCHMARKS.md has the effect on image error and triangle counts.
pub const SHADING_WEIGHT: f32 = 0.5;

impl Default for Tests {
    fn default() -> Self {
        Tests {
            frustum: true,
            normal: true,
            screen_error: true,
            shading: true,
            strict: false,
        }
    }
}

/// What the view tests read of one internal node, gathered in one place (28 bytes): the runtime
/// keeps a copy beside each node on its front so that a frame's visit reads them in order instead
/// of from the hierarchy's arrays (see `refine::stream`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct NodeView {
    /// The node's position: the centre of its bounding sphere.
    pub center: Vec3,
    pub radius: f32,
    /// The object-space error the screen-space test projects under these [`Tests`]: the measured
    /// error or the strict bound, widened by the shading term when that is on.
    pub error: f32,
    /// The normal cone: axis octahedral-encoded, sine of the half-angle (see [`Bounds`](super::hierarchy::Bounds)).
    pub cone_axis: [i16; 2],
    pub cone_sin: f32,
}

impl Tests {
    /// What these tests read of internal node `u`.
    #[inline]
    pub fn node_view(&self, h: &Hierarchy, u: u32) -> NodeView {
        self.view_of(
            &h.internal_bounds[(u - h.leaf_count) as usize],
            h.position[u as usize],
        )
    }

    /// What these tests read of a node with bounds `b` standing at `center`.
    #[inline]
    pub fn view_of(&self, b: &super::hierarchy::Bounds, center: Vec3) -> NodeView {
        let mut error = if self.strict { b.bound } else { b.error };
        if self.shading {
            error = error.max(SHADING_WEIGHT * b.shading);
        }
        NodeView {
            center,
            radius: b.radius,
            error,
            cone_axis: b.cone_axis,
            cone_sin: b.cone_sin,
        }
    }

    /// Can the node be seen at all: not wholly outside the frustum, not wholly facing away?
    #[inline]
    pub fn visible(&self, h: &Hierarchy, view: &View, u: u32) -> bool {
        self.sees(view, &self.node_view(h, u))
    }

    /// [`Tests::visible`] of a node's gathered data.
    #[inline]
    pub fn sees(&self, view: &View, n: &NodeView) -> bool {
        !self.outside(view, n) && !self.faces_away(view, n)
    }

    /// The frustum test: the node's sphere lies wholly outside the view.
    #[inline]
    pub fn outside(&self, view: &View, n: &NodeView) -> bool {
        self.frustum && view.outside(n.center, n.radius)
    }

    /// [`Tests::sees`], and how far the eye may move before it can give another answer (see
    /// [`View::outside_with_margin`] and [`View::facing_margin`]): a node seen stays so while
    /// neither culling test comes to hold, a culled one while one that holds still does.
    #[inline]
    pub fn sees_with_margin(&self, view: &View, n: &NodeView) -> (bool, f32) {
        let (outside, outside_margin) = match self.frustum {
            true => view.outside_with_margin(n.center, n.radius),
            false => (false, f32::INFINITY),
        };
        let (away, away_margin) = if self.normal && !self.strict {
            let axis = decode_normal(n.cone_axis);
            (
                view.back_facing(n.center, n.radius, axis, n.cone_sin),
                view.facing_margin(n.center, n.radius, axis, n.cone_sin),
            )
        } else {
            (false, f32::INFINITY)
        };
        match (outside, away) {
            (false, false) => (true, outside_margin.min(away_margin)),
            (true, false) => (false, outside_margin),
            (false, true) => (false, away_margin),
            (true, true) => (false, outside_margin.max(away_margin)),
        }
    }

    /// The normal test: every normal of the node's cone faces away from the eye. Under the
    /// strict bound it is left out: a node it culls stays coarse whatever its bound (issue 37 §1,
    /// docs/RUNTIME.md).
    #[inline]
    pub fn faces_away(&self, view: &View, n: &NodeView) -> bool {
        self.normal
            && !self.strict
            && view.back_facing(n.center, n.radius, decode_normal(n.cone_axis), n.cone_sin)
    }

    /// The node's error on screen, in pixels (infinite with the screen-space test off, so that every
    /// visible node refines).
    #[inline]
    pub fn error_px(&self, h: &Hierarchy, view: &View, u: u32) -> f32 {
        self.projected(view, &self.node_view(h, u))
    }

    /// [`Tests::error_px`] of a node's gathered data.
    #[inline]
    pub fn projected(&self, view: &View, n: &NodeView) -> f32 {
        if !self.screen_error {
            return f32::INFINITY;
        } else if self.strict {
            return view.projected_bound_px(n.error, n.center, n.radius);
        }
        view.projected_px(n.error, n.center, n.radius)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera::looking_at(
            Vec3::new(0.0, 0.0, 10.0),
            Vec3::ZERO,
            Vec3::Y,
            60f32.to_radians(),
            [800, 600],
            0.1,
            100.0,
        )
    }

    #[test]
    fn frustum_test() {
        let v = View::new(&camera());
        assert!(!v.outside(Vec3::ZERO, 0.1));
        assert!(v.outside(Vec3::new(0.0, 0.0, 20.0), 1.0), "behind the eye");
        assert!(v.outside(Vec3::new(0.0, 0.0, -200.0), 1.0), "beyond far");
        // tan(30°)·10 ≈ 5.77 is the top edge at the origin's depth.
        assert!(v.outside(Vec3::new(0.0, 7.0, 0.0), 1.0));
        assert!(
            !v.outside(Vec3::new(0.0, 6.5, 0.0), 1.0),
            "straddles the top plane"
        );
    }

    /// The strict bound's promise needs every node it weighs: under `strict` the back-face test
    /// culls nothing (a node it culled stayed coarse, and a triangle joining it to refined
    /// neighbours drew a sliver across the Cornell box's ceiling at any τ), while the frustum
    /// test still culls what lies outside the view.
    #[test]
    fn strict_leaves_out_the_back_face_test() {
        let v = View::new(&camera());
        let facing_away = NodeView {
            center: Vec3::ZERO,
            radius: 0.5,
            error: 0.1,
            cone_axis: super::super::hierarchy::encode_normal(Vec3::NEG_Z),
            cone_sin: 0.1,
        };
        let default = Tests::default();
        let strict = Tests {
            strict: true,
            ..Tests::default()
        };
        assert!(!default.sees(&v, &facing_away));
        assert!(strict.sees(&v, &facing_away));
        let outside = NodeView {
            center: Vec3::new(0.0, 50.0, 0.0),
            ..facing_away
        };
        assert!(!strict.sees(&v, &outside));
    }

    /// The per-triangle tests the refiner weighs culled nodes' triangles with (one-sided meshes):
    /// a triangle wound counter-clockwise towards the eye faces it, and one is outside the view
    /// only when all its corners are beyond one plane, even if it spans the view from outside.
    #[test]
    fn triangle_tests() {
        let v = View::new(&camera());
        let eye = camera().position;
        let toward = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let away = [Vec3::ZERO, Vec3::Y, Vec3::X];
        assert!(View::faces_eye(toward, eye, false));
        assert!(!View::faces_eye(away, eye, false));
        assert!(View::faces_eye(away, eye, true), "inward-wound");
        assert!(!v.triangle_outside(toward));
        let far_left = [-20.0, -21.0, -20.0].map(|x| Vec3::new(x, 0.0, 0.0));
        assert!(v.triangle_outside(far_left));
        // From far left to far right across the view: no plane has all three corners beyond it.
        let across = [
            Vec3::new(-20.0, 0.0, 0.0),
            Vec3::new(20.0, 0.0, 0.0),
            Vec3::new(20.0, 0.1, 0.0),
        ];
        assert!(!v.triangle_outside(across));
    }

    #[test]
    fn normal_test() {
        let v = View::new(&camera());
        let (away, toward) = (Vec3::NEG_Z, Vec3::Z);
        assert!(v.back_facing(Vec3::ZERO, 0.5, away, 0.1));
        assert!(!v.back_facing(Vec3::ZERO, 0.5, toward, 0.1));
        // Side-on faces may be seen: a 90° cone is never wholly back-facing.
        assert!(!v.back_facing(Vec3::ZERO, 0.5, away, 1.0));
        // A big sphere close by: its directions spread 64° about −Z, so a 5.7° cone of normals still
        // faces away everywhere, but a 30° cone (64° + 30° > 90°) grazes the eye somewhere.
        assert!(v.back_facing(Vec3::ZERO, 9.0, away, 0.1));
        assert!(!v.back_facing(Vec3::ZERO, 9.0, away, 0.5));
    }

    #[test]
    fn projected_error_in_pixels() {
        let v = View::new(&camera());
        // 600 px / (2 tan 30°) ≈ 519.6 px per unit at distance 1; error 0.1 at distance 10 → 5.2 px.
        let px = v.projected_px(0.1, Vec3::ZERO, 0.0);
        assert!((px - 5.196).abs() < 1e-2, "{px}");
        // Nearest point of the sphere counts: radius 5 → distance 5 → twice the pixels.
        assert!((v.projected_px(0.1, Vec3::ZERO, 5.0) - 2.0 * px).abs() < 1e-2);
    }

    /// The strict bound holds where `1 / d` does not: a point near the corner of the view, moved by
    /// `error` in every direction we try, never moves further on screen than the bound says, while
    /// the plain estimate falls short there; on the axis both agree.
    #[test]
    fn strict_bound_covers_off_axis_stretch() {
        let c = camera();
        let v = View::new(&c);
        // On the axis, only the move's own reach towards the eye (10.1 / 9.9²) sets them apart.
        let on_axis = v.projected_bound_px(0.1, Vec3::ZERO, 0.0);
        let plain = v.projected_px(0.1, Vec3::ZERO, 0.0);
        assert!((on_axis / plain - 10.1 * 10.0 / (9.9 * 9.9)).abs() < 1e-3);

        let to_px = |p: Vec3| {
            let h = c.clip_from_world() * p.extend(1.0);
            glam::Vec2::new(h.x / h.w * 400.0, h.y / h.w * 300.0)
        };
        // Near the top-right corner at depth 10 (the view spans ±7.7 × ±5.8 there).
        let corner = Vec3::new(7.0, 5.0, 0.0);
        let (error, bound) = (0.05, v.projected_bound_px(0.05, corner, 0.0));
        let mut worst: f32 = 0.0;
        for i in 0..500 {
            let (a, b) = (i as f32 * 0.7331, i as f32 * 1.917);
            let dir = Vec3::new(a.sin() * b.cos(), a.sin() * b.sin(), a.cos());
            worst = worst.max(to_px(corner + error * dir).distance(to_px(corner)));
        }
        assert!(worst <= bound * 1.001, "moved {worst} px, bound {bound}");
        assert!(
            worst > v.projected_px(error, corner, 0.0) * 1.2,
            "the plain estimate is short off the axis: {worst} vs {}",
            v.projected_px(error, corner, 0.0)
        );
    }

    #[test]
    fn octahedral_normals_round_trip() {
        let mut worst: f32 = 0.0;
        for i in 0..2000 {
            let (a, b) = (i as f32 * 0.7331, i as f32 * 1.917);
            let n = Vec3::new(a.sin() * b.cos(), a.sin() * b.sin(), a.cos()).normalize();
            let back = decode_normal(crate::refine::hierarchy::encode_normal(n));
            let err = n.dot(back).clamp(-1.0, 1.0).acos();
            assert!(err < 0.01, "{n} -> {back}");
            worst = worst.max(err);
        }
        assert!(
            worst < crate::refine::hierarchy::OCT_ERROR_RADIANS,
            "{worst}"
        );
        assert_eq!(
            decode_normal(crate::refine::hierarchy::NO_NORMAL),
            Vec3::ZERO
        );
        assert_eq!(
            decode_normal(crate::refine::hierarchy::encode_normal(Vec3::ZERO)),
            Vec3::ZERO
        );
    }

    #[test]
    fn look_rotation_looks() {
        let c = camera();
        assert!((c.forward() - Vec3::NEG_Z).length() < 1e-6);
        let p = c.clip_from_world() * Vec4::new(0.0, 1.0, 0.0, 1.0);
        assert!(p.y > 0.0, "up is up in clip space");
    }
}

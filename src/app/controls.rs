//! Camera navigation: a fly camera (WASD + Q/E, mouse look with the right button, wheel for speed,
//! Shift for fast) and an orbit mode around the model; `F` frames the model.

use glam::{Quat, Vec3};
use std::collections::HashSet;
use winit::keyboard::KeyCode;

/// Radians of turn per pixel of mouse motion.
const LOOK_SPEED: f32 = 0.004;
/// Shift multiplies the flying speed by this.
const FAST: f32 = 5.0;
/// One wheel notch changes the speed by this factor.
const WHEEL_STEP: f32 = 1.2;

pub struct Controls {
    pub position: Vec3,
    /// Yaw about +Y and pitch, radians; the camera looks down −Z at yaw = pitch = 0.
    pub yaw: f32,
    pub pitch: f32,
    /// Flying speed in model units per second.
    pub speed: f32,
    pub orbit: bool,
    /// Orbit centre and distance.
    pub target: Vec3,
    pub distance: f32,
    pub keys: HashSet<KeyCode>,
    pub looking: bool,
}

impl Controls {
    /// Looking at the model's bounding sphere `(center, radius)` from the front, whole in view.
    pub fn framing(center: Vec3, radius: f32) -> Controls {
        let mut c = Controls {
            position: Vec3::ZERO,
            yaw: 0.0,
            pitch: 0.0,
            speed: radius.max(1e-6) * 0.5,
            orbit: false,
            target: center,
            distance: radius * 2.5,
            keys: HashSet::new(),
            looking: false,
        };
        c.frame(center, radius);
        c
    }

    /// `F`: back off until the sphere fills the view, looking at its centre.
    pub fn frame(&mut self, center: Vec3, radius: f32) {
        let dir = Vec3::new(0.35, 0.3, 1.0).normalize();
        self.target = center;
        self.distance = radius.max(1e-6) * 2.5;
        self.position = center + dir * self.distance;
        self.look_at(center);
        self.speed = radius.max(1e-6) * 0.5;
    }

    pub fn look_at(&mut self, target: Vec3) {
        let d = (target - self.position).normalize_or(Vec3::NEG_Z);
        self.pitch = d.y.clamp(-1.0, 1.0).asin();
        self.yaw = (-d.x).atan2(-d.z);
    }

    pub fn orientation(&self) -> Quat {
        Quat::from_rotation_y(self.yaw) * Quat::from_rotation_x(self.pitch)
    }

    pub fn set_pose(&mut self, position: Vec3, orientation: Quat) {
        self.position = position;
        let f = orientation * Vec3::NEG_Z;
        self.pitch = f.y.clamp(-1.0, 1.0).asin();
        self.yaw = (-f.x).atan2(-f.z);
    }

    pub fn mouse_moved(&mut self, dx: f32, dy: f32) {
        if !self.looking {
            return;
        }
        self.yaw -= dx * LOOK_SPEED;
        self.pitch = (self.pitch - dy * LOOK_SPEED).clamp(-1.55, 1.55);
        if self.orbit {
            self.position = self.target - self.orientation() * Vec3::NEG_Z * self.distance;
        }
    }

    pub fn wheel(&mut self, notches: f32) {
        if self.orbit {
            self.distance *= WHEEL_STEP.powf(-notches);
            self.position = self.target - self.orientation() * Vec3::NEG_Z * self.distance;
        } else {
            self.speed *= WHEEL_STEP.powf(notches);
        }
    }

    /// Moves by the keys held, over `dt` seconds.
    pub fn update(&mut self, dt: f32) {
        let k = |c| self.keys.contains(&c);
        let q = self.orientation();
        let mut v = Vec3::ZERO;
        if k(KeyCode::KeyW) {
            v += q * Vec3::NEG_Z;
        }
        if k(KeyCode::KeyS) {
            v -= q * Vec3::NEG_Z;
        }
        if k(KeyCode::KeyD) {
            v += q * Vec3::X;
        }
        if k(KeyCode::KeyA) {
            v -= q * Vec3::X;
        }
        if k(KeyCode::KeyE) {
            v += Vec3::Y;
        }
        if k(KeyCode::KeyQ) {
            v -= Vec3::Y;
        }
        if v == Vec3::ZERO {
            return;
        }
        let fast = if k(KeyCode::ShiftLeft) || k(KeyCode::ShiftRight) {
            FAST
        } else {
            1.0
        };
        if self.orbit {
            // W/S zoom, the rest circles.
            let towards = v.dot(q * Vec3::NEG_Z);
            self.distance = (self.distance * (1.0 - towards * dt * fast)).max(1e-6);
            self.yaw -= v.dot(q * Vec3::X) * dt * fast;
            self.pitch = (self.pitch + v.y * dt * fast).clamp(-1.55, 1.55);
            self.position = self.target - self.orientation() * Vec3::NEG_Z * self.distance;
        } else {
            self.position += v.normalize() * self.speed * fast * dt;
        }
    }
}

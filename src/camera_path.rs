//! Scripted camera paths: a documented JSON format of keyframes, smooth interpolation (Catmull–Rom on
//! positions, slerp on orientations), and generators for a model (orbit, fly-in, flythrough).
//!
//! ```json
//! {
//!   "keyframes": [
//!     { "time": 0.0, "position": [0, 1, 5], "look_at": [0, 0, 0], "fov_deg": 50 },
//!     { "time": 4.0, "position": [5, 1, 0], "orientation": [0, 0.38, 0, 0.92] }
//!   ]
//! }
//! ```
//! Each keyframe has a `time` in seconds (strictly increasing), a `position`, and either a `look_at`
//! point or an `orientation` quaternion `[x, y, z, w]` (the camera looks down its −Z, +Y up);
//! `fov_deg` (vertical, default 50) and `up` (for `look_at`, default +Y) are optional.

use crate::refine::Camera;
use crate::refine::criteria::look_rotation;
use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The longest path, in seconds (a day): longer ones are a typo, and would ask a render for an
/// unbounded number of frames.
pub const MAX_SECONDS: f32 = 86_400.0;

/// The largest number a keyframe may hold: squares and cross products of such numbers stay finite in
/// `f32`, so every sample of a valid path is a finite camera.
pub const MAX_COORDINATE: f32 = 1e18;

/// Vertical field of view when a keyframe names none.
pub const DEFAULT_FOV_DEG: f32 = 50.0;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    pub time: f32,
    pub position: [f32; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub look_at: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation: Option<[f32; 4]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<[f32; 3]>,
    #[serde(default = "default_fov")]
    pub fov_deg: f32,
}

fn default_fov() -> f32 {
    DEFAULT_FOV_DEG
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraPath {
    pub keyframes: Vec<Keyframe>,
}

/// A camera path file that cannot be used, with where and why.
#[derive(Debug, thiserror::Error)]
#[error("{}{}: {message}", path.display(), location.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
pub struct PathError {
    pub path: PathBuf,
    /// Line and column, when the problem is at a place in the text.
    pub location: Option<(usize, usize)>,
    pub message: String,
}

impl Keyframe {
    fn rotation(&self) -> Quat {
        match (self.orientation, self.look_at) {
            (Some(q), _) => Quat::from_array(q).normalize(),
            (None, Some(target)) => look_rotation(
                Vec3::from_array(target) - Vec3::from_array(self.position),
                self.up.map_or(Vec3::Y, Vec3::from_array),
            ),
            (None, None) => Quat::IDENTITY,
        }
    }
}

impl CameraPath {
    /// Reads and checks a path file.
    pub fn load(path: &Path) -> Result<CameraPath, PathError> {
        let text = std::fs::read_to_string(path).map_err(|e| PathError {
            path: path.into(),
            location: None,
            message: format!("cannot read: {e}"),
        })?;
        Self::parse(&text, path)
    }

    /// Parses and checks path text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<CameraPath, PathError> {
        let parsed: CameraPath = serde_json::from_str(text).map_err(|e| PathError {
            path: path.into(),
            location: Some((e.line(), e.column())),
            message: e.to_string(),
        })?;
        parsed.validate().map_err(|message| PathError {
            path: path.into(),
            location: None,
            message,
        })?;
        Ok(parsed)
    }

    /// Keyframes present, times finite and strictly increasing, every number finite, each keyframe
    /// oriented one way, fields of view in (0°, 180°).
    pub fn validate(&self) -> Result<(), String> {
        if self.keyframes.is_empty() {
            return Err("the path has no keyframes".into());
        }
        for (i, k) in self.keyframes.iter().enumerate() {
            let numbers = k
                .position
                .iter()
                .chain(k.look_at.iter().flatten())
                .chain(k.orientation.iter().flatten())
                .chain(k.up.iter().flatten())
                .chain([&k.time, &k.fov_deg]);
            if numbers.clone().any(|x| !x.is_finite()) {
                return Err(format!("keyframe {i} has a number that is not finite"));
            }
            if numbers.into_iter().any(|x| x.abs() > MAX_COORDINATE) {
                return Err(format!(
                    "keyframe {i} has a number larger than {MAX_COORDINATE:e} in magnitude"
                ));
            }
            if k.look_at.is_some() && k.orientation.is_some() {
                return Err(format!(
                    "keyframe {i} has both look_at and orientation; give one"
                ));
            }
            if k.look_at.is_none() && k.orientation.is_none() {
                return Err(format!(
                    "keyframe {i} has neither look_at nor orientation; give one"
                ));
            }
            if let Some(target) = k.look_at {
                let (target, eye) = (Vec3::from_array(target), Vec3::from_array(k.position));
                // Relative to the coordinates' size: the direction must survive rounding.
                let scale = target.abs().max(eye.abs()).max_element();
                if (target - eye).abs().max_element() <= scale * 1e-6 {
                    return Err(format!("keyframe {i} looks at its own position"));
                }
            }
            if let Some(q) = k.orientation
                && Quat::from_array(q).length() < 1e-6
            {
                return Err(format!("keyframe {i} has a zero orientation quaternion"));
            }
            if !(k.fov_deg > 0.0 && k.fov_deg < 180.0) {
                return Err(format!(
                    "keyframe {i} has fov_deg {}; it must be between 0 and 180",
                    k.fov_deg
                ));
            }
            if i > 0 && k.time <= self.keyframes[i - 1].time {
                return Err(format!(
                    "keyframe {i} has time {} after {}: times must increase",
                    k.time,
                    self.keyframes[i - 1].time
                ));
            }
        }
        if self.duration() > MAX_SECONDS {
            return Err(format!(
                "the path lasts {} s; at most {MAX_SECONDS} s (a day) is allowed",
                self.duration()
            ));
        }
        Ok(())
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a path serialises")
    }

    /// Seconds from the first keyframe to the last.
    pub fn duration(&self) -> f32 {
        self.keyframes.last().map_or(0.0, |k| k.time) - self.keyframes[0].time
    }

    /// Position, orientation and vertical field of view (radians) at `t` seconds from the start,
    /// clamped to the path.
    pub fn sample(&self, t: f32) -> (Vec3, Quat, f32) {
        let k = &self.keyframes;
        let time = (k[0].time + t).clamp(k[0].time, k[k.len() - 1].time);
        let i = k
            .partition_point(|f| f.time <= time)
            .clamp(1, k.len().max(2) - 1)
            - 1;
        if k.len() == 1 {
            return (
                Vec3::from_array(k[0].position),
                k[0].rotation(),
                k[0].fov_deg.to_radians(),
            );
        }
        let (a, b) = (&k[i], &k[i + 1]);
        let u = ((time - a.time) / (b.time - a.time)).clamp(0.0, 1.0);
        let p = |j: usize| Vec3::from_array(k[j].position);
        let before = if i > 0 {
            p(i - 1)
        } else {
            2.0 * p(i) - p(i + 1)
        };
        let after = if i + 2 < k.len() {
            p(i + 2)
        } else {
            2.0 * p(i + 1) - p(i)
        };
        let position = catmull_rom(before, p(i), p(i + 1), after, u);
        let (qa, mut qb) = (a.rotation(), b.rotation());
        if qa.dot(qb) < 0.0 {
            qb = -qb;
        }
        let fov = a.fov_deg + (b.fov_deg - a.fov_deg) * u;
        (position, qa.slerp(qb, u), fov.to_radians())
    }

    /// The camera at `t` seconds.
    pub fn camera(&self, t: f32, viewport_px: [u32; 2], near: f32, far: f32) -> Camera {
        let (position, orientation, fov_y_radians) = self.sample(t);
        Camera {
            position,
            orientation,
            fov_y_radians,
            viewport_px,
            near,
            far,
        }
    }

    /// Once around the model's bounding sphere `(center, radius)` at 2.5 radii, a little above it.
    pub fn orbit(center: Vec3, radius: f32, seconds: f32) -> CameraPath {
        let steps = 12;
        let keyframes = (0..=steps)
            .map(|i| {
                let a = i as f32 / steps as f32 * std::f32::consts::TAU;
                let eye = center + Vec3::new(a.sin(), 0.35, a.cos()) * radius * 2.5;
                look(i as f32 / steps as f32 * seconds, eye, center)
            })
            .collect();
        CameraPath { keyframes }
    }

    /// Tao et al., Fig. 6: from far away (12 radii) to close to the surface (0.4 radii), approaching
    /// geometrically so that the screen-space size grows steadily.
    pub fn fly_in(center: Vec3, radius: f32, seconds: f32) -> CameraPath {
        let dir = Vec3::new(0.3, 0.25, 1.0).normalize();
        let steps = 8;
        let keyframes = (0..=steps)
            .map(|i| {
                let t = i as f32 / steps as f32;
                let distance = radius * 12.0 * (0.4f32 / 12.0).powf(t);
                look(t * seconds, center + dir * (radius + distance), center)
            })
            .collect();
        CameraPath { keyframes }
    }

    /// In from one side, close past the model and through its bounding box, out the other side.
    pub fn flythrough(center: Vec3, radius: f32, seconds: f32) -> CameraPath {
        let points = [
            Vec3::new(-3.0, 0.6, 2.0),
            Vec3::new(-1.2, 0.3, 0.9),
            Vec3::new(-0.2, 0.1, 0.3),
            Vec3::new(0.6, 0.0, -0.1),
            Vec3::new(1.5, 0.3, -0.9),
            Vec3::new(3.0, 0.8, -2.0),
        ];
        let n = points.len();
        let keyframes = points
            .iter()
            .enumerate()
            .map(|(i, &p)| {
                // Look ahead along the path (the last keyframe back at the model).
                let target = if i + 1 < n {
                    center + points[i + 1] * radius * 1.5
                } else {
                    center
                };
                look(
                    i as f32 / (n - 1) as f32 * seconds,
                    center + p * radius,
                    target,
                )
            })
            .collect();
        CameraPath { keyframes }
    }
}

fn look(time: f32, eye: Vec3, target: Vec3) -> Keyframe {
    Keyframe {
        time,
        position: eye.to_array(),
        look_at: Some(target.to_array()),
        orientation: None,
        up: None,
        fov_deg: DEFAULT_FOV_DEG,
    }
}

/// Uniform Catmull–Rom between `p1` and `p2`.
fn catmull_rom(p0: Vec3, p1: Vec3, p2: Vec3, p3: Vec3, u: f32) -> Vec3 {
    let (u2, u3) = (u * u, u * u * u);
    0.5 * ((2.0 * p1)
        + (p2 - p0) * u
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u2
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * u3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_through_keyframes() {
        let path = CameraPath::orbit(Vec3::ZERO, 1.0, 12.0);
        path.validate().unwrap();
        for k in &path.keyframes {
            let (p, q, fov) = path.sample(k.time);
            assert!((p - Vec3::from_array(k.position)).length() < 1e-4);
            assert!(q.dot(k.rotation()).abs() > 0.9999);
            assert!((fov - DEFAULT_FOV_DEG.to_radians()).abs() < 1e-6);
        }
        // Between keyframes the orbit stays near its circle.
        let (p, _, _) = path.sample(0.5);
        assert!((p.length() - 2.5 * (1.0f32 + 0.35 * 0.35).sqrt()).abs() < 0.05);
    }

    #[test]
    fn errors_name_the_place() {
        let e = CameraPath::parse(
            "{\n  \"keyframes\": [ {\"time\": 0,\n \"position\": [0, 0] } ] }",
            Path::new("p.json"),
        )
        .unwrap_err();
        assert_eq!(e.location.map(|l| l.0), Some(3));
        assert!(e.to_string().starts_with("p.json:3:"), "{e}");
        let e = CameraPath::parse(
            r#"{"keyframes": [{"time": 1, "position": [0,0,1], "look_at": [0,0,0]},
                              {"time": 1, "position": [0,0,2], "look_at": [0,0,0]}]}"#,
            Path::new("p.json"),
        )
        .unwrap_err();
        assert!(e.message.contains("times must increase"), "{e}");
        let e = CameraPath::parse(r#"{"keyframes": []}"#, Path::new("p.json")).unwrap_err();
        assert!(e.message.contains("no keyframes"));
        let e = CameraPath::parse(
            r#"{"keyframes": [{"time": 0, "position": [0,0,1]}]}"#,
            Path::new("p.json"),
        )
        .unwrap_err();
        assert!(e.message.contains("neither look_at nor orientation"));
        let e = CameraPath::parse(
            r#"{"keyframes": [{"time": 0, "position": [0,0,1], "look_at": [0,0,0], "fvo": 3}]}"#,
            Path::new("p.json"),
        )
        .unwrap_err();
        assert!(e.message.contains("unknown field"), "{e}");
    }

    #[test]
    fn round_trips_through_json() {
        let path = CameraPath::flythrough(Vec3::ONE, 2.0, 5.0);
        let back = CameraPath::parse(&path.to_json(), Path::new("x")).unwrap();
        assert_eq!(back, path);
    }
}

//! Scripted runs of the viewer, for tests and demos: play a camera path over a number of frames, apply
//! UI actions at given frames, take screenshots, write the per-frame statistics, exit.
//!
//! ```json
//! {
//!   "frames": 90,
//!   "path": "fly-in",
//!   "actions": [
//!     { "frame": 30, "wireframe": true },
//!     { "frame": 45, "tau": 4.0 },
//!     { "frame": 89, "screenshot": "out/view.png" }
//!   ],
//!   "stats": "out/view-stats.json"
//! }
//! ```
//! `path` is `orbit`, `fly-in`, `flythrough` (generated for the model) or a camera path file; without
//! it the camera stays where `F` puts it.

use crate::display::ColorBy;
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Script {
    pub frames: u32,
    #[serde(default)]
    pub path: Option<String>,
    #[serde(default)]
    pub actions: Vec<Action>,
    /// Where to write every frame's statistics (JSON) when the script ends.
    #[serde(default)]
    pub stats: Option<PathBuf>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Action {
    pub frame: u32,
    #[serde(flatten)]
    pub what: What,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum What {
    Wireframe(bool),
    Tau(f32),
    Budget(Option<u32>),
    ColorBy(ColorBy),
    Flat(bool),
    Vsync(bool),
    Geomorph(u32),
    VisitLimit(u32),
    /// The frame rate the viewer holds by raising τ; 0 turns the hold off.
    HoldFps(f32),
    Frustum(bool),
    Normal(bool),
    ScreenError(bool),
    Shading(bool),
    Freeze(bool),
    Orbit(bool),
    Help(bool),
    Compare(bool),
    /// Target triangle count of the compare view.
    CompareTriangles(u32),
    /// The compare view's second row (simplifications within a distance) at this ε, a share of the
    /// diagonal; `null` hides it.
    CompareWithin(Option<f64>),
    Open(PathBuf),
    Screenshot(PathBuf),
    /// Start recording the camera into this file; `null` stops and writes it.
    Record(Option<PathBuf>),
}

/// A script file that cannot be used, with where and why.
#[derive(Debug, thiserror::Error)]
#[error("{}{}: {message}", path.display(), location.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
pub struct ScriptError {
    pub path: PathBuf,
    /// Line and column, when the problem is at a place in the text.
    pub location: Option<(usize, usize)>,
    pub message: String,
}

/// The most frames a script may ask for (a day at 60 fps): more is a typo.
pub const MAX_FRAMES: u32 = 5_184_000;

impl Script {
    pub fn load(path: &Path) -> Result<Script, ScriptError> {
        let bytes = std::fs::read(path).map_err(|e| ScriptError {
            path: path.into(),
            location: None,
            message: format!("cannot read: {e}"),
        })?;
        Script::parse(&bytes, path)
    }

    /// Parses and checks script text; `path` names it in errors.
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Script, ScriptError> {
        let script: Script = serde_json::from_slice(bytes).map_err(|e| ScriptError {
            path: path.into(),
            location: Some((e.line(), e.column())),
            message: e.to_string(),
        })?;
        let fail = |message: String| ScriptError {
            path: path.into(),
            location: None,
            message,
        };
        if script.frames == 0 || script.frames > MAX_FRAMES {
            return Err(fail(format!(
                "frames is {}; it must be between 1 and {MAX_FRAMES}",
                script.frames
            )));
        }
        for a in &script.actions {
            match a.what {
                What::Tau(t) if !(t > 0.0 && t.is_finite()) => {
                    return Err(fail(format!(
                        "the action at frame {} sets tau to {t}; it must be a positive number of pixels",
                        a.frame
                    )));
                }
                What::HoldFps(f) if !(f >= 0.0 && f.is_finite()) => {
                    return Err(fail(format!(
                        "the action at frame {} sets hold_fps to {f}; it must be 0 (off) or a positive frame rate",
                        a.frame
                    )));
                }
                _ => {}
            }
        }
        Ok(script)
    }

    /// `--frames N --screenshot FILE` as a script: a fly-in, a screenshot at the end.
    pub fn simple(frames: u32, screenshot: Option<PathBuf>) -> Script {
        let frames = frames.max(1);
        Script {
            frames,
            path: Some("fly-in".into()),
            actions: screenshot
                .map(|s| Action {
                    frame: frames - 1,
                    what: What::Screenshot(s),
                })
                .into_iter()
                .collect(),
            stats: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn actions_parse_and_bad_values_name_their_frame() {
        let path = Path::new("demo.json");
        let ok =
            br#"{"frames": 3, "actions": [{"frame": 0, "hold_fps": 0}, {"frame": 1, "tau": 2.5}]}"#;
        let s = Script::parse(ok, path).unwrap();
        assert!(matches!(s.actions[0].what, What::HoldFps(f) if f == 0.0));
        let bad = br#"{"frames": 3, "actions": [{"frame": 2, "hold_fps": -5}]}"#;
        let e = Script::parse(bad, path).unwrap_err().to_string();
        assert!(
            e.starts_with("demo.json: ") && e.contains("frame 2") && e.contains("hold_fps"),
            "{e}"
        );
        let e = Script::parse(
            br#"{"frames": 3, "actions": [{"frame": 1, "tau": 0}]}"#,
            path,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("frame 1 sets tau to 0"), "{e}");
        let e = Script::parse(br#"{"frames": 0}"#, path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("frames is 0"), "{e}");
        // Syntax errors say where.
        let e = Script::parse(b"{\"frames\": 3,\n \"actions\": [}", path)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("demo.json:2:"), "{e}");
    }
}

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

use crate::render::ColorBy;
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
    Open(PathBuf),
    Screenshot(PathBuf),
    /// Start recording the camera into this file; `null` stops and writes it.
    Record(Option<PathBuf>),
}

impl Script {
    pub fn load(path: &Path) -> Result<Script, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        serde_json::from_str(&text)
            .map_err(|e| format!("{}:{}:{}: {e}", path.display(), e.line(), e.column()))
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

//! What the viewer remembers between runs: LOD and display choices, the window size, recent files.
//! Stored as JSON in the user's config directory (`~/.config/vunify/viewer.json` on Linux).

use crate::refine::{Mode, Tests};
use crate::render::ColorBy;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ViewerSettings {
    pub tolerance_px: f32,
    pub budget: u32,
    pub budget_mode: bool,
    /// Hold this frame rate by raising τ while frames are slower (see [`crate::refine::Hold`]); 0
    /// turns the hold off. Default 25.
    pub hold_fps: f32,
    /// Front nodes visited per frame; 0 means all (no amortisation).
    pub visit_limit: u32,
    pub geomorph_frames: u32,
    pub tests: Tests,
    pub wireframe: bool,
    pub color_by: ColorBy,
    pub flat: bool,
    pub vsync: bool,
    pub orbit: bool,
    pub show_help: bool,
    pub window: [u32; 2],
    pub recent: Vec<PathBuf>,
}

/// The frame rate the viewer holds unless told otherwise: fluid enough to fly with, low enough that
/// a software rasteriser keeps τ = 1 px on models of a few hundred thousand triangles (the dragon
/// flies at ~35 fps on lavapipe at 1280 × 720, BENCHMARKS.md).
pub const DEFAULT_HOLD_FPS: f32 = 25.0;

impl Default for ViewerSettings {
    fn default() -> Self {
        ViewerSettings {
            tolerance_px: 1.0,
            budget: 100_000,
            budget_mode: false,
            hold_fps: DEFAULT_HOLD_FPS,
            visit_limit: 0,
            geomorph_frames: 0,
            tests: Tests::default(),
            wireframe: false,
            color_by: ColorBy::Auto,
            flat: false,
            vsync: true,
            orbit: false,
            show_help: false,
            window: [1280, 720],
            recent: Vec::new(),
        }
    }
}

impl ViewerSettings {
    pub fn mode(&self) -> Mode {
        if self.budget_mode {
            Mode::Budget(self.budget)
        } else {
            Mode::Tolerance
        }
    }

    fn file() -> Option<PathBuf> {
        Some(dirs::config_dir()?.join("vunify").join("viewer.json"))
    }

    /// The saved settings, or the defaults (a missing or unreadable file is not an error: the
    /// viewer starts with defaults and says so on stderr).
    pub fn load() -> ViewerSettings {
        let Some(file) = Self::file() else {
            return ViewerSettings::default();
        };
        match std::fs::read_to_string(&file) {
            Ok(text) => serde_json::from_str(&text).unwrap_or_else(|e| {
                eprintln!("vunify: ignoring {}: {e}", file.display());
                ViewerSettings::default()
            }),
            Err(_) => ViewerSettings::default(),
        }
    }

    pub fn save(&self) {
        let Some(file) = Self::file() else { return };
        if let Some(dir) = file.parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        let json = serde_json::to_string_pretty(self).expect("settings serialise");
        if let Err(e) = crate::export::write_atomic(&file, json.as_bytes()) {
            eprintln!("vunify: cannot save settings to {}: {e}", file.display());
        }
    }

    pub fn remember(&mut self, path: PathBuf) {
        self.recent.retain(|p| p != &path);
        self.recent.insert(0, path);
        self.recent.truncate(8);
    }
}

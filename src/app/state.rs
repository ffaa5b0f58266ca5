//! What the viewer holds between frames: the model on view, the panel's state, playback and
//! recording.

use super::*;

/// One frame's line in the statistics history.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct FrameLine {
    pub time_s: f64,
    pub frame_ms: f64,
    pub upload_ms: f64,
    pub upload_bytes: u64,
    pub ui_ms: f64,
    pub stats: FrameStats,
    /// A streamed tree's cache after the frame.
    pub cache: Option<crate::refine::CacheStats>,
}

pub struct Playback {
    pub path: CameraPath,
    pub file: String,
    pub t: f32,
    pub playing: bool,
}

pub struct Recording {
    pub keyframes: Vec<Keyframe>,
    pub started: Instant,
}

/// What the panel shows and changes.
pub struct ViewState {
    pub model: Option<ModelView>,
    pub loading: Option<(Receiver<LoadMessage>, PathBuf, f32, String)>,
    pub error: Option<String>,
    pub message: Option<String>,
    pub controls: Controls,
    pub frozen: Option<Camera>,
    /// How far the frame-rate hold raises τ now.
    pub hold: crate::refine::Hold,
    pub history: VecDeque<FrameLine>,
    pub all_frames: Vec<FrameLine>,
    /// Every error shown, for scripted runs' statistics.
    pub error_log: Vec<String>,
    pub playback: Option<Playback>,
    pub recording: Option<Recording>,
    pub compare: Option<CompareView>,
    /// ε of the compare view's second row, in % of the diagonal.
    pub within_epsilon: f32,
    pub open_text: String,
    pub path_text: String,
    pub record_text: String,
    pub screenshot: Option<PathBuf>,
    pub screenshots_taken: u32,
    pub started: Instant,
    pub frame_index: u64,
    pub wireframe_kind: &'static str,
    pub gpu_name: String,
    /// The 3D view's size in pixels (the window right of the panel).
    pub size: [u32; 2],
    /// Where the 3D view starts, in pixels from the window's left edge.
    pub scene_x: u32,
}

pub struct ModelView {
    pub loaded: Loaded,
    pub refiner: Refiner,
    pub renderer: Renderer,
    /// The front of a streamed tree (then `refiner` is unused, and `loaded.hierarchy` is the
    /// part read so far).
    pub streamed: Option<Box<crate::refine::Streamed>>,
}

/// Makes a loaded model the one on view.
pub(super) fn install(
    gfx: &Gfx,
    view: &mut ViewState,
    mut loaded: Loaded,
    settings: &ViewerSettings,
) {
    let mut renderer = Renderer::new(&gfx.gpu.device, gfx.scene_format);
    renderer.set_hierarchy(&gfx.gpu.device, &gfx.gpu.queue, &loaded.hierarchy);
    view.controls.frame(loaded.center, loaded.radius);
    view.controls.orbit = settings.orbit;
    let refiner = Refiner::new(
        &loaded.hierarchy,
        refine_settings(settings, view.hold.scale()),
    );
    view.message = Some(format!(
        "{}: {} triangles, {} vertices{}",
        loaded.path.display(),
        loaded.tree.triangles,
        loaded.tree.leaf_count,
        if loaded.cached {
            " (tree from the cache)"
        } else {
            ""
        }
    ));
    view.error = None;
    view.compare = None;
    view.frozen = None;
    let mut streamed = loaded.streamed.take();
    if let Some(s) = &mut streamed {
        s.set_settings(refine_settings(settings, view.hold.scale()));
    }
    view.model = Some(ModelView {
        loaded,
        refiner,
        renderer,
        streamed,
    });
}

/// The runtime's settings for the viewer's, with τ raised `tau_scale` times (the frame-rate hold).
pub(super) fn refine_settings(s: &ViewerSettings, tau_scale: f32) -> Settings {
    Settings {
        tolerance_px: s.tolerance_px * tau_scale,
        mode: s.mode(),
        tests: s.tests,
        visit_limit: (s.visit_limit > 0).then_some(s.visit_limit as usize),
        geomorph_frames: s.geomorph_frames,
        ..Default::default()
    }
}

impl ViewState {
    /// Starts loading a model in the background; the current one stays until it is ready.
    pub fn open(&mut self, path: PathBuf) {
        self.error = None;
        self.loading = Some((
            model::spawn_load(path.clone(), Metric::Qem),
            path,
            0.0,
            "starting".into(),
        ));
    }

    pub(super) fn camera(&self, size: [u32; 2]) -> Camera {
        let (near, far) = match &self.model {
            Some(m) => crate::render::job::clip_planes(m.loaded.hierarchy.diagonal),
            None => (0.01, 100.0),
        };
        Camera {
            position: self.controls.position,
            orientation: self.controls.orientation(),
            fov_y_radians: crate::camera_path::DEFAULT_FOV_DEG.to_radians(),
            viewport_px: size,
            near,
            far,
        }
    }
}

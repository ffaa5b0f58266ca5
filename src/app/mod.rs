//! The interactive fly-through viewer (winit + egui on the wgpu renderer): `vunify view [MODEL]`.
//!
//! One window; the 3D view fills it and an egui panel sits on the left. Per frame: move the camera
//! (keys, mouse, or a playing camera path), adapt the front to the refinement camera (the view camera,
//! or a frozen one), upload what changed, draw the model (or the compare view's four cuts), then the UI.
//! Models load and build on a background thread; the frame never waits for them.

mod compare;
mod controls;
mod model;
pub mod script;
mod settings;
mod ui;

use crate::path::{CameraPath, Keyframe};
use crate::refine::{Camera, FrameStats, Refiner, Settings};
use crate::render::{DrawOptions, Gpu, Renderer, Target, headless::read_texture};
use crate::simplify::Metric;
use compare::CompareView;
use controls::Controls;
use glam::Vec3;
use model::{LoadMessage, Loaded};
use script::{Script, What};
use settings::ViewerSettings;
use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::mpsc::Receiver;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{DeviceEvent, ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

/// Seconds of statistics the panel's plot shows.
const HISTORY_SECONDS: f64 = 10.0;
/// A recorded camera path gets a keyframe this often (seconds).
const RECORD_EVERY: f32 = 0.25;

pub struct ViewArgs {
    pub model: PathBuf,
    pub script: Option<Script>,
    /// Window size in pixels (default: the remembered one).
    pub size: Option<[u32; 2]>,
}

/// Opens the viewer; returns when the window closes (or a script ends).
pub fn run(args: ViewArgs) -> anyhow::Result<()> {
    let event_loop = EventLoop::new()?;
    let mut settings = ViewerSettings::load();
    if let Some(size) = args.size {
        settings.window = size;
    }
    if args.script.is_some() {
        // Scripted runs start from the defaults, so that their pictures do not depend on the user.
        // Without vsync, so that a scripted run measures how fast frames can be made.
        settings = ViewerSettings {
            window: settings.window,
            vsync: false,
            ..Default::default()
        };
    }
    let mut app = App {
        args,
        settings,
        running: None,
        result: Ok(()),
    };
    event_loop.run_app(&mut app)?;
    app.result
}

struct App {
    args: ViewArgs,
    settings: ViewerSettings,
    running: Option<Running>,
    result: anyhow::Result<()>,
}

/// The window and everything drawn into it.
struct Gfx {
    window: Arc<Window>,
    gpu: Gpu,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// The surface's format for egui (non-sRGB) and its sRGB twin for the 3D pass.
    ui_format: wgpu::TextureFormat,
    scene_format: wgpu::TextureFormat,
    depth: wgpu::TextureView,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
}

/// One frame's line in the statistics history.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct FrameLine {
    pub time_s: f64,
    pub frame_ms: f64,
    pub upload_ms: f64,
    pub upload_bytes: u64,
    pub ui_ms: f64,
    pub stats: FrameStats,
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
    pub history: VecDeque<FrameLine>,
    pub all_frames: Vec<FrameLine>,
    /// Every error shown, for scripted runs' statistics.
    pub error_log: Vec<String>,
    pub playback: Option<Playback>,
    pub recording: Option<Recording>,
    pub compare: Option<CompareView>,
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
}

struct Running {
    gfx: Gfx,
    view: ViewState,
    last: Instant,
    script: Option<Script>,
}

impl App {
    fn start(&mut self, event_loop: &ActiveEventLoop) -> anyhow::Result<Running> {
        let [w, h] = self.settings.window;
        let attributes = Window::default_attributes()
            .with_title("vunify")
            .with_inner_size(winit::dpi::PhysicalSize::new(w.max(320), h.max(240)));
        let window = Arc::new(event_loop.create_window(attributes)?);
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_with_display_handle_from_env(
                Box::new(event_loop.owned_display_handle()),
            ));
        let surface = instance.create_surface(window.clone())?;
        let gpu = Gpu::with_instance(instance, Some(&surface))?;
        let caps = surface.get_capabilities(&gpu.adapter);
        // egui wants a linear (non-sRGB) target; the 3D pass draws through an sRGB view of it.
        let ui_format = caps
            .formats
            .iter()
            .copied()
            .find(|f| !f.is_srgb())
            .unwrap_or(caps.formats[0]);
        let scene_format = ui_format.add_srgb_suffix();
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format: ui_format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: present_mode(self.settings.vsync),
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes[0],
            view_formats: vec![scene_format],
            color_space: Default::default(),
        };
        surface.configure(&gpu.device, &config);
        let depth = depth_view(&gpu.device, [config.width, config.height]);
        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &*window,
            Some(window.scale_factor() as f32),
            None,
            Some(gpu.device.limits().max_texture_dimension_2d as usize),
        );
        let egui_renderer = egui_wgpu::Renderer::new(&gpu.device, ui_format, Default::default());
        let wireframe_kind = Renderer::new(&gpu.device, scene_format).wireframe_kind();
        let gpu_name = gpu.adapter_name();
        let gfx = Gfx {
            window,
            gpu,
            surface,
            config,
            ui_format,
            scene_format,
            depth,
            egui_ctx,
            egui_state,
            egui_renderer,
        };
        let mut view = ViewState {
            model: None,
            loading: None,
            error: None,
            message: None,
            controls: Controls::framing(Vec3::ZERO, 1.0),
            frozen: None,
            history: VecDeque::new(),
            all_frames: Vec::new(),
            error_log: Vec::new(),
            playback: None,
            recording: None,
            compare: None,
            open_text: String::new(),
            path_text: "fly-in".into(),
            record_text: "out/recorded-path.json".into(),
            screenshot: None,
            screenshots_taken: 0,
            started: Instant::now(),
            frame_index: 0,
            wireframe_kind,
            gpu_name,
            size: [gfx.config.width, gfx.config.height],
            scene_x: 0,
        };
        view.controls.orbit = self.settings.orbit;
        let script = self.args.script.clone();
        if script.is_some() {
            // A script runs on the loaded model: load it now, before the first frame.
            let loaded = model::load(&self.args.model, Metric::Qem, &mut |_, _| {})
                .map_err(|e| anyhow::anyhow!(e))?;
            install(&gfx, &mut view, loaded, &self.settings);
        } else {
            view.open(self.args.model.clone());
        }
        Ok(Running {
            gfx,
            view,
            last: Instant::now(),
            script,
        })
    }
}

fn present_mode(vsync: bool) -> wgpu::PresentMode {
    // TOOLCHAIN.md: get_default_config picks Immediate on Xvfb; choose explicitly.
    if vsync {
        wgpu::PresentMode::AutoVsync
    } else {
        wgpu::PresentMode::AutoNoVsync
    }
}

fn depth_view(device: &wgpu::Device, size: [u32; 2]) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("window depth"),
            size: wgpu::Extent3d {
                width: size[0].max(1),
                height: size[1].max(1),
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: crate::render::renderer::DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        })
        .create_view(&Default::default())
}

/// Makes a loaded model the one on view.
fn install(gfx: &Gfx, view: &mut ViewState, loaded: Loaded, settings: &ViewerSettings) {
    let mut renderer = Renderer::new(&gfx.gpu.device, gfx.scene_format);
    renderer.set_hierarchy(&gfx.gpu.device, &gfx.gpu.queue, &loaded.hierarchy);
    view.controls.frame(loaded.center, loaded.radius);
    view.controls.orbit = settings.orbit;
    let refiner = Refiner::new(&loaded.hierarchy, refine_settings(settings));
    view.message = Some(format!(
        "{}: {} triangles, {} vertices{}",
        loaded.path.display(),
        loaded.tree.triangles.len(),
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
    view.model = Some(ModelView {
        loaded,
        refiner,
        renderer,
    });
}

fn refine_settings(s: &ViewerSettings) -> Settings {
    Settings {
        tolerance_px: s.tolerance_px,
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

    fn camera(&self, size: [u32; 2]) -> Camera {
        let (near, far) = match &self.model {
            Some(m) => crate::render::job::clip_planes(m.loaded.hierarchy.diagonal),
            None => (0.01, 100.0),
        };
        Camera {
            position: self.controls.position,
            orientation: self.controls.orientation(),
            fov_y_radians: crate::path::DEFAULT_FOV_DEG.to_radians(),
            viewport_px: size,
            near,
            far,
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match self.start(event_loop) {
            Ok(r) => {
                r.gfx.window.request_redraw();
                self.running = Some(r);
            }
            Err(e) => {
                self.result = Err(e);
                event_loop.exit();
            }
        }
    }

    fn device_event(&mut self, _: &ActiveEventLoop, _: winit::event::DeviceId, event: DeviceEvent) {
        if let (Some(r), DeviceEvent::MouseMotion { delta }) = (&mut self.running, event) {
            r.view.controls.mouse_moved(delta.0 as f32, delta.1 as f32);
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(r) = &self.running {
            r.gfx.window.request_redraw();
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(r) = &mut self.running else { return };
        let response = r.gfx.egui_state.on_window_event(&r.gfx.window, &event);
        match event {
            WindowEvent::CloseRequested => {
                self.settings.save();
                event_loop.exit();
            }
            WindowEvent::Resized(size) => {
                r.gfx.config.width = size.width.max(1);
                r.gfx.config.height = size.height.max(1);
                r.gfx.surface.configure(&r.gfx.gpu.device, &r.gfx.config);
                r.gfx.depth =
                    depth_view(&r.gfx.gpu.device, [r.gfx.config.width, r.gfx.config.height]);
                self.settings.window = [size.width, size.height];
            }
            WindowEvent::DroppedFile(path) => {
                self.settings.remember(path.clone());
                r.view.open(path);
            }
            WindowEvent::KeyboardInput { event, .. } if !response.consumed => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    if event.state == ElementState::Pressed {
                        r.view.controls.keys.insert(code);
                        if !event.repeat {
                            shortcut(code, &mut r.view, &mut self.settings);
                        }
                    } else {
                        r.view.controls.keys.remove(&code);
                    }
                }
            }
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Right,
                ..
            } => {
                r.view.controls.looking = state == ElementState::Pressed && !response.consumed;
            }
            WindowEvent::MouseWheel { delta, .. } if !response.consumed => {
                let notches = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                r.view.controls.wheel(notches);
            }
            WindowEvent::RedrawRequested => match frame(r, &mut self.settings) {
                Ok(true) => {}
                Ok(false) => {
                    event_loop.exit();
                }
                Err(e) => {
                    self.result = Err(e);
                    event_loop.exit();
                }
            },
            _ => {}
        }
    }
}

/// Keyboard shortcuts (the help overlay lists them).
fn shortcut(code: KeyCode, view: &mut ViewState, settings: &mut ViewerSettings) {
    match code {
        KeyCode::KeyF => {
            if let Some(m) = &view.model {
                let (c, r) = (m.loaded.center, m.loaded.radius);
                view.controls.frame(c, r);
            }
        }
        KeyCode::KeyH | KeyCode::F1 => settings.show_help = !settings.show_help,
        KeyCode::KeyR => settings.wireframe = !settings.wireframe,
        KeyCode::KeyO => {
            settings.orbit = !settings.orbit;
            view.controls.orbit = settings.orbit;
            if let Some(m) = &view.model {
                view.controls.target = m.loaded.center;
                view.controls.distance = (view.controls.position - m.loaded.center).length();
            }
        }
        KeyCode::KeyL => {
            view.frozen = match view.frozen {
                Some(_) => None,
                None => Some(view.camera(view.size)),
            }
        }
        KeyCode::Space => {
            if let Some(p) = &mut view.playback {
                p.playing = !p.playing;
            }
        }
        KeyCode::F12 | KeyCode::KeyP => {
            view.screenshots_taken += 1;
            view.screenshot = Some(PathBuf::from(format!(
                "out/screenshot-{:03}.png",
                view.screenshots_taken
            )));
        }
        _ => {}
    }
}

/// One frame. Returns `Ok(false)` when a script has finished.
fn frame(r: &mut Running, settings: &mut ViewerSettings) -> anyhow::Result<bool> {
    let now = Instant::now();
    let dt = now.duration_since(r.last).as_secs_f32().min(0.25);
    r.last = now;
    let gfx = &mut r.gfx;
    let view = &mut r.view;
    let size = [gfx.config.width, gfx.config.height];
    // vsync switched in the panel: reconfigure the surface with the chosen present mode.
    if gfx.config.present_mode != present_mode(settings.vsync) {
        gfx.config.present_mode = present_mode(settings.vsync);
        gfx.surface.configure(&gfx.gpu.device, &gfx.config);
    }
    // The 3D view is the window right of the panel.
    let panel_px =
        ((ui::PANEL_WIDTH * gfx.egui_ctx.pixels_per_point()).round() as u32).min(size[0] / 2);
    view.scene_x = panel_px;
    view.size = [size[0] - panel_px, size[1]];

    // Background loads.
    if let Some((rx, path, share, what)) = &mut view.loading {
        let mut done = None;
        while let Ok(message) = rx.try_recv() {
            match message {
                LoadMessage::Progress(s, w) => {
                    *share = s;
                    *what = w;
                }
                LoadMessage::Done(result) => done = Some((result, path.clone())),
            }
        }
        if let Some((result, path)) = done {
            view.loading = None;
            match result {
                Ok(loaded) => {
                    settings.remember(path);
                    install(gfx, view, loaded, settings);
                }
                Err(e) => {
                    view.error_log.push(e.clone());
                    view.error = Some(e);
                }
            }
        }
    }

    // The script's actions for this frame, and its camera path.
    let mut script_done = false;
    if let Some(script) = &r.script {
        if view.frame_index == 0
            && let Some(p) = &script.path
        {
            start_playback(view, p);
        }
        let now_frame = view.frame_index;
        for a in script
            .actions
            .iter()
            .filter(|a| a.frame as u64 == now_frame)
        {
            apply(&a.what, view, settings);
        }
        if let Some(p) = &mut view.playback {
            // Scripts are frame-driven: the path spreads over the script's frames.
            p.playing = false;
            p.t = p.path.duration() * view.frame_index as f32 / (script.frames.max(2) - 1) as f32;
        }
        script_done = view.frame_index + 1 >= script.frames as u64;
    }

    // Camera.
    if let Some(p) = &mut view.playback {
        if p.playing {
            p.t += dt;
            if p.t > p.path.duration() {
                p.t = 0.0;
            }
        }
        let (position, orientation, _) = p.path.sample(p.t);
        view.controls.set_pose(position, orientation);
    } else {
        view.controls.update(dt);
    }
    let camera = view.camera(view.size);
    if let Some(rec) = &mut view.recording {
        let t = rec.started.elapsed().as_secs_f32();
        if rec
            .keyframes
            .last()
            .is_none_or(|k| t - k.time >= RECORD_EVERY)
        {
            rec.keyframes.push(Keyframe {
                time: t,
                position: camera.position.to_array(),
                look_at: None,
                orientation: Some(camera.orientation.to_array()),
                up: None,
                fov_deg: camera.fov_y_radians.to_degrees(),
            });
        }
    }

    // Refine and upload.
    let mut line = FrameLine {
        time_s: view.started.elapsed().as_secs_f64(),
        frame_ms: 0.0,
        upload_ms: 0.0,
        upload_bytes: 0,
        ui_ms: 0.0,
        stats: FrameStats::default(),
    };
    if let Some(m) = &mut view.model {
        m.refiner.settings = refine_settings(settings);
        let lod_camera = match view.frozen {
            Some(f) => f,
            None => camera,
        };
        line.stats = m.refiner.update(&m.loaded.hierarchy, &lod_camera);
        let t0 = Instant::now();
        let (front, moved) = m.refiner.output();
        let upload = m
            .renderer
            .upload(&gfx.gpu.device, &gfx.gpu.queue, front, moved);
        line.upload_ms = t0.elapsed().as_secs_f64() * 1e3;
        line.upload_bytes = upload.bytes;
    }
    if let Some(c) = &mut view.compare {
        c.update(&gfx.gpu.device, &gfx.gpu.queue, gfx.scene_format, dt);
    }

    // UI.
    let t0 = Instant::now();
    let input = gfx.egui_state.take_egui_input(&gfx.window);
    let egui::FullOutput {
        platform_output,
        textures_delta: mut textures,
        shapes,
        pixels_per_point,
        ..
    } = gfx
        .egui_ctx
        .run_ui(input, |ui| ui::panel(ui, view, settings, &camera));
    gfx.egui_state
        .handle_platform_output(&gfx.window, platform_output);
    let paint_jobs = gfx.egui_ctx.tessellate(shapes, pixels_per_point);
    // Texture uploads now, frees after drawing; egui checks in debug builds that none is dropped.
    for (id, deltas) in &textures.set {
        for delta in deltas {
            gfx.egui_renderer
                .update_texture(&gfx.gpu.device, &gfx.gpu.queue, *id, delta);
        }
    }
    let frees = std::mem::take(&mut textures.free);
    textures.clear();
    line.ui_ms = t0.elapsed().as_secs_f64() * 1e3;
    let screen = egui_wgpu::ScreenDescriptor {
        size_in_pixels: size,
        pixels_per_point,
    };

    // Draw: the window, and the same frame offscreen for a screenshot.
    let surface_texture = match gfx.surface.get_current_texture() {
        wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
            Some(t)
        }
        _ => {
            gfx.surface.configure(&gfx.gpu.device, &gfx.config);
            None
        }
    };
    if let Some(texture) = surface_texture {
        let scene_view = texture.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(gfx.scene_format),
            ..Default::default()
        });
        let ui_view = texture.texture.create_view(&Default::default());
        draw_frame(
            &gfx.gpu,
            &mut gfx.egui_renderer,
            view,
            settings,
            &camera,
            &scene_view,
            &ui_view,
            &gfx.depth,
            &paint_jobs,
            &screen,
        );
        gfx.gpu.queue.present(texture);
    }
    if let Some(file) = view.screenshot.take() {
        let shot = screenshot(gfx, view, settings, &camera, &paint_jobs, &screen)?;
        if let Some(dir) = file.parent() {
            std::fs::create_dir_all(dir).ok();
        }
        crate::render::job::save(&shot, &file)?;
        view.message = Some(format!("wrote {}", file.display()));
    }
    for id in &frees {
        gfx.egui_renderer.free_texture(id);
    }

    line.frame_ms = now.elapsed().as_secs_f64() * 1e3;
    view.history.push_back(line);
    while view
        .history
        .front()
        .is_some_and(|l| line.time_s - l.time_s > HISTORY_SECONDS)
    {
        view.history.pop_front();
    }
    if r.script.is_some() {
        view.all_frames.push(line);
    }
    view.frame_index += 1;
    if script_done {
        if let Some(file) = r.script.as_ref().and_then(|s| s.stats.clone()) {
            let json = serde_json::to_string_pretty(&serde_json::json!({
                "frames": view.all_frames,
                "errors": view.error_log,
            }))?;
            crate::export::write_atomic(&file, json.as_bytes())?;
        }
        return Ok(false);
    }
    Ok(true)
}

fn start_playback(view: &mut ViewState, what: &str) {
    let Some(m) = &view.model else { return };
    let (c, r) = (m.loaded.center, m.loaded.radius);
    let path = match what {
        "orbit" => Ok(CameraPath::orbit(c, r, 10.0)),
        "fly-in" => Ok(CameraPath::fly_in(c, r, 10.0)),
        "flythrough" => Ok(CameraPath::flythrough(c, r, 10.0)),
        file => CameraPath::load(std::path::Path::new(file)).map_err(|e| e.to_string()),
    };
    match path {
        Ok(path) => {
            view.playback = Some(Playback {
                path,
                file: what.to_string(),
                t: 0.0,
                playing: true,
            })
        }
        Err(e) => view.error = Some(e),
    }
}

/// A script action, or the same change from the panel.
fn apply(what: &What, view: &mut ViewState, settings: &mut ViewerSettings) {
    match what {
        What::Wireframe(on) => settings.wireframe = *on,
        What::Tau(t) => settings.tolerance_px = t.max(0.01),
        What::Budget(b) => {
            settings.budget_mode = b.is_some();
            if let Some(b) = b {
                settings.budget = *b;
            }
        }
        What::ColorBy(c) => settings.color_by = *c,
        What::Flat(on) => settings.flat = *on,
        What::Vsync(on) => settings.vsync = *on,
        What::Geomorph(f) => settings.geomorph_frames = *f,
        What::VisitLimit(k) => settings.visit_limit = *k,
        What::Frustum(on) => settings.tests.frustum = *on,
        What::Normal(on) => settings.tests.normal = *on,
        What::ScreenError(on) => settings.tests.screen_error = *on,
        What::Shading(on) => settings.tests.shading = *on,
        What::Freeze(on) => view.frozen = on.then(|| view.camera(view.size)),
        What::Orbit(on) => {
            settings.orbit = *on;
            view.controls.orbit = *on;
        }
        What::Help(on) => settings.show_help = *on,
        What::Compare(on) => toggle_compare(view, *on),
        What::CompareTriangles(n) => {
            if let Some(c) = &mut view.compare {
                c.target = *n;
            }
        }
        What::Open(path) => view.open(path.clone()),
        What::Record(Some(file)) => {
            view.record_text = file.display().to_string();
            view.recording = Some(Recording {
                keyframes: Vec::new(),
                started: Instant::now(),
            });
        }
        What::Record(None) => stop_recording(view),
        What::Screenshot(path) => view.screenshot = Some(path.clone()),
    }
}

/// Ends the recording and writes it where the panel says (a path `vunify render --path` replays).
pub(crate) fn stop_recording(view: &mut ViewState) {
    let Some(rec) = view.recording.take() else {
        return;
    };
    let path = CameraPath {
        keyframes: rec.keyframes,
    };
    let file = PathBuf::from(view.record_text.trim());
    if let Some(dir) = file.parent() {
        let _ = std::fs::create_dir_all(dir);
    }
    let written = path.validate().and_then(|_| {
        crate::export::write_atomic(&file, path.to_json().as_bytes()).map_err(|e| e.to_string())
    });
    match written {
        Ok(()) => {
            view.message = Some(format!(
                "wrote {} (vunify render --path replays it)",
                file.display()
            ))
        }
        Err(e) => {
            let e = format!("{}: {e}", file.display());
            view.error_log.push(e.clone());
            view.error = Some(e);
        }
    }
}

pub(crate) fn toggle_compare(view: &mut ViewState, on: bool) {
    if !on {
        view.compare = None;
        return;
    }
    let Some(m) = &view.model else { return };
    let is_vtree = m
        .loaded
        .path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("vtree"));
    if is_vtree {
        view.error = Some(
            "the compare view builds the model with every metric, so it needs the mesh file, not a .vtree"
                .into(),
        );
        return;
    }
    let target = (m.loaded.tree.triangles.len() as u32 / 10).max(1);
    view.compare = Some(CompareView::new(&m.loaded.path, target));
}

/// The 3D view (or the compare view's quadrants), the frozen frustum, then the UI, into the views.
#[allow(clippy::too_many_arguments)]
fn draw_frame(
    gpu: &Gpu,
    egui_renderer: &mut egui_wgpu::Renderer,
    view: &ViewState,
    settings: &ViewerSettings,
    camera: &Camera,
    scene_view: &wgpu::TextureView,
    ui_view: &wgpu::TextureView,
    depth: &wgpu::TextureView,
    paint_jobs: &[egui::ClippedPrimitive],
    screen: &egui_wgpu::ScreenDescriptor,
) {
    let (device, queue) = (&gpu.device, &gpu.queue);
    let mut encoder = device.create_command_encoder(&Default::default());
    let [x0, w] = [view.scene_x, view.size[0]];
    let h = screen.size_in_pixels[1];
    let draw = DrawOptions {
        color_by: settings.color_by,
        flat: settings.flat,
        wireframe: settings.wireframe,
        tolerance_px: settings.tolerance_px,
        viewport: Some([x0 as f32, 0.0, w.max(1) as f32, h.max(1) as f32]),
        ..Default::default()
    };
    match (&view.compare, &view.model) {
        (Some(compare), _) => {
            // Clear once, then each ready method into its quadrant.
            let mut cleared = false;
            for (i, slot) in compare.slots.iter().enumerate() {
                let (qw, qh) = (w / 2, h / 2);
                let (x, y) = (x0 + (i as u32 % 2) * qw, (i as u32 / 2) * qh);
                if let Some(ready) = &slot.ready {
                    let mut cam = *camera;
                    cam.viewport_px = [qw.max(1), qh.max(1)];
                    let options = DrawOptions {
                        viewport: Some([x as f32, y as f32, qw.max(1) as f32, qh.max(1) as f32]),
                        clear: !cleared,
                        ..draw
                    };
                    ready.renderer.draw(
                        device,
                        queue,
                        &mut encoder,
                        Target {
                            color: scene_view,
                            depth,
                        },
                        &cam,
                        &options,
                    );
                    // Each renderer has its own uniform buffer, but writes land at submit: submit
                    // per quadrant.
                    queue.submit([std::mem::replace(
                        &mut encoder,
                        device.create_command_encoder(&Default::default()),
                    )
                    .finish()]);
                    cleared = true;
                }
            }
            if !cleared {
                clear(&mut encoder, scene_view, depth);
            }
        }
        (None, Some(m)) => m.renderer.draw(
            device,
            queue,
            &mut encoder,
            Target {
                color: scene_view,
                depth,
            },
            camera,
            &draw,
        ),
        (None, None) => clear(&mut encoder, scene_view, depth),
    }
    // egui's buffers, then its pass over the 3D image.
    let egui_buffers =
        egui_renderer.update_buffers(device, queue, &mut encoder, paint_jobs, screen);
    {
        let mut ui_pass =
            pass(&mut encoder, "egui", ui_view, wgpu::LoadOp::Load, None).forget_lifetime();
        egui_renderer.render(&mut ui_pass, paint_jobs, screen);
    }
    queue.submit(egui_buffers.into_iter().chain([encoder.finish()]));
}

fn clear(encoder: &mut wgpu::CommandEncoder, color: &wgpu::TextureView, depth: &wgpu::TextureView) {
    let [r, g, b, a] = DrawOptions::default().background;
    pass(
        encoder,
        "clear",
        color,
        wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a }),
        Some(depth),
    );
}

/// A render pass over `color` (loaded or cleared) and, when given, a cleared depth buffer.
fn pass<'a>(
    encoder: &'a mut wgpu::CommandEncoder,
    label: &str,
    color: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
    depth: Option<&wgpu::TextureView>,
) -> wgpu::RenderPass<'a> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: color,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load,
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: depth.map(|view| wgpu::RenderPassDepthStencilAttachment {
            view,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// The frame as the window shows it (3D and UI), rendered again offscreen and read back.
fn screenshot(
    gfx: &mut Gfx,
    view: &ViewState,
    settings: &ViewerSettings,
    camera: &Camera,
    paint_jobs: &[egui::ClippedPrimitive],
    screen: &egui_wgpu::ScreenDescriptor,
) -> anyhow::Result<image::RgbaImage> {
    let device = gfx.gpu.device.clone();
    let [w, h] = screen.size_in_pixels;
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("screenshot"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: gfx.ui_format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[gfx.scene_format],
    });
    let scene_view = texture.create_view(&wgpu::TextureViewDescriptor {
        format: Some(gfx.scene_format),
        ..Default::default()
    });
    let ui_view = texture.create_view(&Default::default());
    let depth = depth_view(&device, [w, h]);
    draw_frame(
        &gfx.gpu,
        &mut gfx.egui_renderer,
        view,
        settings,
        camera,
        &scene_view,
        &ui_view,
        &depth,
        paint_jobs,
        screen,
    );
    Ok(read_texture(&gfx.gpu.device, &gfx.gpu.queue, &texture)?)
}

//! The interactive fly-through viewer (winit + egui on the wgpu renderer): `vunify view [MODEL]`.
//!
//! One window; the 3D view fills it and an egui panel sits on the left. Per frame: move the camera
//! (keys, mouse, or a playing camera path), adapt the front to the refinement camera (the view camera,
//! or a frozen one), upload what changed, draw the model (or the compare view's four cuts), then the UI.
//! Models load and build on a background thread; the frame never waits for them.

mod compare;
mod controls;
mod draw;
mod frame;
mod model;
mod settings;
mod state;
mod ui;

use crate::camera_path::{CameraPath, Keyframe};
use crate::refine::{Camera, FrameStats, Refiner, Settings};
use crate::render::{DrawOptions, Gpu, Renderer, Target, headless::read_texture};
use crate::script::{Script, What};
use crate::simplify::Metric;
use compare::CompareView;
use controls::Controls;
use glam::Vec3;
use model::{LoadMessage, Loaded};
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

use draw::*;
use frame::*;
pub use model::stream_trees_within;
use state::*;
pub use state::{FrameLine, ModelView, Playback, Recording, ViewState};

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
            hold: Default::default(),
            history: VecDeque::new(),
            all_frames: Vec::new(),
            error_log: Vec::new(),
            playback: None,
            recording: None,
            compare: None,
            within_epsilon: 1.0,
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

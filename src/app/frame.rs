//! One frame of the viewer: input, background loads, script, camera, refinement and upload, UI,
//! drawing.

use super::*;

/// Keyboard shortcuts (the help overlay lists them).
pub(super) fn shortcut(code: KeyCode, view: &mut ViewState, settings: &mut ViewerSettings) {
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
pub(super) fn frame(r: &mut Running, settings: &mut ViewerSettings) -> anyhow::Result<bool> {
    let now = Instant::now();
    let dt = now.duration_since(r.last).as_secs_f32().min(0.25);
    r.last = now;
    let size = layout(&mut r.gfx, &mut r.view, settings);
    poll_loading(&r.gfx, &mut r.view, settings);
    let script_done = run_script(r.script.as_ref(), &mut r.view, settings);
    let camera = move_camera(&mut r.view, dt);
    let gfx = &mut r.gfx;
    let view = &mut r.view;
    let mut line = refine_and_upload(gfx, view, settings, &camera);
    if let Some(c) = &mut view.compare {
        c.update(&gfx.gpu.device, &gfx.gpu.queue, gfx.scene_format, dt);
    }
    let t0 = Instant::now();
    let ui = run_ui(gfx, view, settings, &camera, size);
    line.ui_ms = t0.elapsed().as_secs_f64() * 1e3;
    present(gfx, view, settings, &camera, &ui)?;
    for id in &ui.frees {
        gfx.egui_renderer.free_texture(id);
    }
    line.frame_ms = now.elapsed().as_secs_f64() * 1e3;
    record_line(view, line, r.script.is_some());
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

/// The surface follows the vsync setting; the 3D view is the window right of the panel. Returns
/// the window's size in pixels.
fn layout(gfx: &mut Gfx, view: &mut ViewState, settings: &ViewerSettings) -> [u32; 2] {
    let size = [gfx.config.width, gfx.config.height];
    if gfx.config.present_mode != present_mode(settings.vsync) {
        gfx.config.present_mode = present_mode(settings.vsync);
        gfx.surface.configure(&gfx.gpu.device, &gfx.config);
    }
    let panel_px =
        ((ui::PANEL_WIDTH * gfx.egui_ctx.pixels_per_point()).round() as u32).min(size[0] / 2);
    view.scene_x = panel_px;
    view.size = [size[0] - panel_px, size[1]];
    size
}

/// Takes the background load's progress, and its model or error when it is done.
fn poll_loading(gfx: &Gfx, view: &mut ViewState, settings: &mut ViewerSettings) {
    let Some((rx, path, share, what)) = &mut view.loading else {
        return;
    };
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

/// The script's actions for this frame, and its camera path. Returns whether this is its last
/// frame.
fn run_script(
    script: Option<&Script>,
    view: &mut ViewState,
    settings: &mut ViewerSettings,
) -> bool {
    let Some(script) = script else {
        return false;
    };
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
    view.frame_index + 1 >= script.frames as u64
}

/// Moves the camera (a playing path, or the controls) by `dt` seconds, and records it if a
/// recording is on. Returns the view camera.
fn move_camera(view: &mut ViewState, dt: f32) -> Camera {
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
    camera
}

/// Adapts the front to the refinement camera (the view camera, or a frozen one) and uploads what
/// changed. Returns the frame's statistics so far.
fn refine_and_upload(
    gfx: &Gfx,
    view: &mut ViewState,
    settings: &ViewerSettings,
    camera: &Camera,
) -> FrameLine {
    let mut line = FrameLine {
        time_s: view.started.elapsed().as_secs_f64(),
        frame_ms: 0.0,
        upload_ms: 0.0,
        upload_bytes: 0,
        ui_ms: 0.0,
        stats: FrameStats::default(),
        cache: None,
    };
    if let Some(m) = &mut view.model {
        // The hold weighs the last frame; budget mode regulates τ itself.
        let hold_fps = if settings.budget_mode {
            0.0
        } else {
            settings.hold_fps
        };
        let (last_ms, last_triangles) = view
            .history
            .back()
            .map_or((0.0, 0), |l| (l.frame_ms, l.stats.triangles));
        let scale = view.hold.next(last_ms, last_triangles, hold_fps);
        let lod_camera = view.frozen.unwrap_or(*camera);
        let (device, queue) = (&gfx.gpu.device, &gfx.gpu.queue);
        let t0;
        let upload = match &mut m.streamed {
            Some(s) => {
                s.set_settings(refine_settings(settings, scale));
                let frame = s.update(&lod_camera);
                (line.stats, line.cache) = (frame.stats, Some(frame.cache));
                t0 = Instant::now();
                if frame.new_part {
                    m.loaded.hierarchy = s.hierarchy_arc();
                    m.renderer.set_hierarchy(device, queue, &m.loaded.hierarchy);
                }
                for (_, e) in s.take_failures() {
                    view.error_log.push(e.to_string());
                    view.error = Some(format!("{e}; the front stays coarse there"));
                }
                let (h, front, moved) = s.output();
                m.renderer.upload(device, queue, h, front, moved)
            }
            None => {
                m.refiner.settings = refine_settings(settings, scale);
                line.stats = m.refiner.update(&m.loaded.hierarchy, &lod_camera);
                t0 = Instant::now();
                let (front, moved) = m.refiner.output();
                m.renderer
                    .upload(device, queue, &m.loaded.hierarchy, front, moved)
            }
        };
        line.upload_ms = t0.elapsed().as_secs_f64() * 1e3;
        line.upload_bytes = upload.bytes;
    }
    line
}

/// The UI's output for this frame: what to paint, and the textures to free after drawing.
pub(super) struct UiFrame {
    pub(super) paint_jobs: Vec<egui::ClippedPrimitive>,
    pub(super) frees: Vec<egui::TextureId>,
    pub(super) screen: egui_wgpu::ScreenDescriptor,
}

/// Runs the panel and uploads its textures (frees wait until after drawing; egui checks in debug
/// builds that none is dropped).
fn run_ui(
    gfx: &mut Gfx,
    view: &mut ViewState,
    settings: &mut ViewerSettings,
    camera: &Camera,
    size: [u32; 2],
) -> UiFrame {
    let input = gfx.egui_state.take_egui_input(&gfx.window);
    let egui::FullOutput {
        platform_output,
        textures_delta: mut textures,
        shapes,
        pixels_per_point,
        ..
    } = gfx
        .egui_ctx
        .run_ui(input, |ui| ui::panel(ui, view, settings, camera));
    gfx.egui_state
        .handle_platform_output(&gfx.window, platform_output);
    let paint_jobs = gfx.egui_ctx.tessellate(shapes, pixels_per_point);
    for (id, deltas) in &textures.set {
        for delta in deltas {
            gfx.egui_renderer
                .update_texture(&gfx.gpu.device, &gfx.gpu.queue, *id, delta);
        }
    }
    let frees = std::mem::take(&mut textures.free);
    textures.clear();
    UiFrame {
        paint_jobs,
        frees: frees.into_iter().collect(),
        screen: egui_wgpu::ScreenDescriptor {
            size_in_pixels: size,
            pixels_per_point,
        },
    }
}

/// Draws the frame into the window, and the same frame offscreen when a screenshot is due.
fn present(
    gfx: &mut Gfx,
    view: &mut ViewState,
    settings: &ViewerSettings,
    camera: &Camera,
    ui: &UiFrame,
) -> anyhow::Result<()> {
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
            camera,
            &scene_view,
            &ui_view,
            &gfx.depth,
            &ui.paint_jobs,
            &ui.screen,
        );
        gfx.gpu.queue.present(texture);
    }
    if let Some(file) = view.screenshot.take() {
        let shot = screenshot(gfx, view, settings, camera, &ui.paint_jobs, &ui.screen)?;
        if let Some(dir) = file.parent() {
            std::fs::create_dir_all(dir).ok();
        }
        crate::render::job::save(&shot, &file)?;
        view.message = Some(format!("wrote {}", file.display()));
    }
    Ok(())
}

/// Adds the frame's line to the plotted history (and, in scripted runs, to the statistics file's).
fn record_line(view: &mut ViewState, line: FrameLine, scripted: bool) {
    view.history.push_back(line);
    while view
        .history
        .front()
        .is_some_and(|l| line.time_s - l.time_s > HISTORY_SECONDS)
    {
        view.history.pop_front();
    }
    if scripted {
        view.all_frames.push(line);
    }
    view.frame_index += 1;
}

pub(super) fn start_playback(view: &mut ViewState, what: &str) {
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
pub(super) fn apply(what: &What, view: &mut ViewState, settings: &mut ViewerSettings) {
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
        What::HoldFps(f) => settings.hold_fps = f.max(0.0),
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
        What::CompareWithin(epsilon) => {
            if let Some(e) = epsilon {
                view.within_epsilon = (100.0 * e) as f32;
            }
            if let Some(c) = &mut view.compare {
                c.set_within(*epsilon);
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
    let target = (m.loaded.tree.triangles as u32 / 10).max(1);
    view.compare = Some(CompareView::new(&m.loaded.path, target));
}

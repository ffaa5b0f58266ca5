//! The egui panel: file, LOD controls, display, navigation, camera paths, the compare view, statistics;
//! the keyboard help; the frozen refinement frustum and the compare view's labels drawn over the 3D view.

use super::frame::{apply, start_playback, toggle_compare};
use super::settings::ViewerSettings;
use super::{Recording, ViewState};
use crate::refine::Camera;
use crate::render::ColorBy;
use egui::{Color32, RichText, Ui};
use glam::{Vec3, Vec4};
use std::path::PathBuf;
use std::time::Instant;

/// The panel's width in points; the 3D view takes the rest of the window.
pub const PANEL_WIDTH: f32 = 290.0;
const ERROR_RED: Color32 = Color32::from_rgb(255, 110, 100);

pub fn panel(ui: &mut Ui, view: &mut ViewState, settings: &mut ViewerSettings, camera: &Camera) {
    egui::Panel::left("controls")
        .resizable(false)
        .exact_size(PANEL_WIDTH)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                file_section(ui, view, settings);
                lod_section(ui, view, settings);
                display_section(ui, view, settings);
                navigation_section(ui, view, settings);
                path_section(ui, view);
                compare_section(ui, view);
                stats_section(ui, view);
            });
        });
    overlays(ui, view, settings, camera);
}

fn file_section(ui: &mut Ui, view: &mut ViewState, settings: &mut ViewerSettings) {
    ui.heading("vunify");
    match &view.model {
        Some(m) => {
            let name = m
                .loaded
                .path
                .file_name()
                .map(|n| n.to_string_lossy().to_string())
                .unwrap_or_default();
            ui.label(format!(
                "{name}: {} triangles, {} vertices, {} part(s)",
                m.loaded.tree.triangles,
                m.loaded.tree.leaf_count,
                m.loaded.tree.parts.max(1)
            ));
        }
        None => {
            ui.label("no model yet");
        }
    }
    if let Some((_, path, share, what)) = &view.loading {
        ui.label(format!("opening {}", path.display()));
        ui.add(
            egui::ProgressBar::new(*share)
                .text(what.as_str())
                .show_percentage(),
        );
    }
    if let Some(e) = view.error.clone() {
        ui.colored_label(ERROR_RED, format!("error: {e}"));
        if ui.small_button("dismiss").clicked() {
            view.error = None;
        }
    }
    if let Some(m) = &view.message {
        ui.label(RichText::new(m).small().weak());
    }
    ui.collapsing("Open…", |ui| {
        ui.label("A .vtree opens at once; a mesh (.obj, .ply, .off, .xz, .gltf, .glb) is built in the background. Files can also be dropped on the window.");
        ui.horizontal(|ui| {
            ui.text_edit_singleline(&mut view.open_text);
            if ui.button("Open").clicked() && !view.open_text.trim().is_empty() {
                let p = PathBuf::from(view.open_text.trim());
                view.open(p);
            }
        });
        let recent = settings.recent.clone();
        for p in recent {
            if ui.small_button(p.display().to_string()).clicked() {
                view.open(p);
            }
        }
    });
    ui.separator();
}

fn lod_section(ui: &mut Ui, view: &mut ViewState, settings: &mut ViewerSettings) {
    ui.strong("Level of detail");
    ui.add(
        egui::Slider::new(&mut settings.tolerance_px, 0.1..=50.0)
            .logarithmic(true)
            .text("τ (pixels)"),
    );
    ui.horizontal(|ui| {
        ui.radio_value(&mut settings.budget_mode, false, "tolerance");
        ui.radio_value(&mut settings.budget_mode, true, "budget");
        ui.add_enabled(
            settings.budget_mode,
            egui::DragValue::new(&mut settings.budget)
                .range(10..=50_000_000)
                .speed(100.0)
                .suffix(" triangles"),
        );
    });
    ui.add_enabled(
        !settings.budget_mode,
        egui::Slider::new(&mut settings.hold_fps, 0.0..=120.0).text("hold fps (0: off)"),
    )
    .on_hover_text("Raise τ while frames are slower than this; back to your τ once they are fast");
    ui.add(
        egui::Slider::new(&mut settings.visit_limit, 0..=100_000)
            .logarithmic(true)
            .text("visits a frame (0: all)"),
    );
    ui.add(
        egui::Slider::new(&mut settings.geomorph_frames, 0..=60).text("geomorph frames (0: off)"),
    );
    ui.horizontal(|ui| {
        ui.checkbox(&mut settings.tests.frustum, "frustum");
        ui.checkbox(&mut settings.tests.normal, "normal");
        ui.checkbox(&mut settings.tests.screen_error, "screen error");
    });
    ui.checkbox(
        &mut settings.tests.shading,
        "weigh shading too (sub-pixel bumps)",
    );
    ui.checkbox(
        &mut settings.tests.strict,
        "strict bound (nothing in view strays over τ)",
    )
    .on_hover_text(
        "Project each node's strict deviation bound instead of its measured error: \
         nothing in view strays over τ, with many more triangles (the back-face test is \
         left out under it)",
    );
    let mut frozen = view.frozen.is_some();
    if ui
        .checkbox(&mut frozen, "freeze LOD (L): fly out and look at the front")
        .changed()
    {
        apply(&crate::script::What::Freeze(frozen), view, settings);
    }
    ui.separator();
}

fn display_section(ui: &mut Ui, view: &mut ViewState, settings: &mut ViewerSettings) {
    ui.strong("Display");
    ui.horizontal(|ui| {
        ui.checkbox(&mut settings.wireframe, "wireframe (R)");
        ui.label(
            RichText::new(format!("({})", view.wireframe_kind))
                .small()
                .weak(),
        );
        ui.checkbox(&mut settings.flat, "flat");
    });
    egui::ComboBox::from_label("colour")
        .selected_text(match settings.color_by {
            ColorBy::Auto => "model",
            ColorBy::Shaded => "shaded",
            ColorBy::Baked => "baked (unlit)",
            ColorBy::Depth => "tree depth",
            ColorBy::Error => "projected error",
            ColorBy::Texture => "texture",
            ColorBy::Uv => "UV checker",
        })
        .show_ui(ui, |ui| {
            ui.selectable_value(
                &mut settings.color_by,
                ColorBy::Auto,
                "model (texture, else vertex colours, if any)",
            );
            ui.selectable_value(&mut settings.color_by, ColorBy::Texture, "texture");
            ui.selectable_value(
                &mut settings.color_by,
                ColorBy::Uv,
                "UV checker (seams, stretch)",
            );
            ui.selectable_value(&mut settings.color_by, ColorBy::Shaded, "shaded");
            ui.selectable_value(
                &mut settings.color_by,
                ColorBy::Baked,
                "baked lighting (vertex colours, unlit)",
            );
            ui.selectable_value(&mut settings.color_by, ColorBy::Depth, "tree depth");
            ui.selectable_value(
                &mut settings.color_by,
                ColorBy::Error,
                "projected error (green = τ)",
            );
        });
    if ui
        .checkbox(&mut settings.vsync, "vsync (applies on restart)")
        .changed()
    {
        view.message = Some("vsync changes apply the next time the viewer starts".into());
    }
    ui.separator();
}

fn navigation_section(ui: &mut Ui, view: &mut ViewState, settings: &mut ViewerSettings) {
    ui.strong("Navigation");
    ui.horizontal(|ui| {
        if ui.checkbox(&mut settings.orbit, "orbit (O)").changed() {
            apply(&crate::script::What::Orbit(settings.orbit), view, settings);
        }
        if ui.button("frame (F)").clicked()
            && let Some(m) = &view.model
        {
            let (c, r) = (m.loaded.center, m.loaded.radius);
            view.controls.frame(c, r);
        }
        if ui.button("help (H)").clicked() {
            settings.show_help = !settings.show_help;
        }
    });
    ui.label(RichText::new(format!("speed {:.3} units/s (wheel)", view.controls.speed)).small());
    ui.separator();
}

fn path_section(ui: &mut Ui, view: &mut ViewState) {
    ui.strong("Camera path");
    ui.horizontal(|ui| {
        ui.add(egui::TextEdit::singleline(&mut view.path_text).desired_width(150.0));
        if ui
            .button("play")
            .on_hover_text("orbit, fly-in, flythrough, or a path file")
            .clicked()
        {
            let what = view.path_text.trim().to_string();
            start_playback(view, &what);
        }
    });
    if let Some(p) = &mut view.playback {
        ui.horizontal(|ui| {
            if ui
                .button(if p.playing { "pause" } else { "play" })
                .clicked()
            {
                p.playing = !p.playing;
            }
            let duration = p.path.duration();
            ui.add(egui::Slider::new(&mut p.t, 0.0..=duration).text("s"));
        });
        let mut stop = false;
        ui.horizontal(|ui| {
            ui.label(RichText::new(&p.file).small());
            stop = ui.small_button("stop").clicked();
        });
        if stop {
            view.playback = None;
        }
    }
    ui.horizontal(|ui| match &view.recording {
        None => {
            if ui.button("record").clicked() {
                view.recording = Some(Recording {
                    keyframes: Vec::new(),
                    started: Instant::now(),
                });
            }
        }
        Some(rec) => {
            ui.label(format!("recording: {} keyframes", rec.keyframes.len()));
            if ui.button("stop and save").clicked() {
                super::frame::stop_recording(view);
            }
        }
    });
    ui.horizontal(|ui| {
        ui.label("save to");
        ui.text_edit_singleline(&mut view.record_text);
    });
    ui.separator();
}

fn compare_section(ui: &mut Ui, view: &mut ViewState) {
    ui.strong("Compare methods (Garland & Heckbert; Chen's comparison)");
    let mut on = view.compare.is_some();
    if ui.checkbox(&mut on, "four metrics side by side").changed() {
        toggle_compare(view, on);
    }
    let mut message = None;
    if let Some(c) = &mut view.compare {
        let total = view
            .model
            .as_ref()
            .map_or(1, |m| m.loaded.tree.triangles as u32)
            .max(1);
        ui.add(
            egui::Slider::new(&mut c.target, 1..=total)
                .logarithmic(true)
                .text("triangles"),
        );
        ui.checkbox(&mut c.sweep, "sweep down and up");
        let mut within = c.within.is_some();
        let mut epsilon = view.within_epsilon;
        let (toggled, settled) = ui
            .horizontal(|ui| {
                let toggled = ui.checkbox(&mut within, "within ε (second row)").changed();
                let r = ui
                    .add(
                        egui::DragValue::new(&mut epsilon)
                            .range(0.1..=10.0)
                            .speed(0.05)
                            .suffix(" %"),
                    )
                    .on_hover_text(
                        "bounded and the three envelope methods at this ε (a share of the diagonal)",
                    );
                (toggled, r.drag_stopped() || (r.changed() && !r.dragged()))
            })
            .inner;
        view.within_epsilon = epsilon;
        // Rebuilt when switched on or when ε settles (not at every step of a drag).
        if toggled || (settled && within) {
            c.set_within(within.then_some(0.01 * f64::from(epsilon)));
        }
        for slot in &c.slots {
            ui.horizontal(|ui| {
                ui.label(slot.shown.label());
                if let Some(e) = &slot.error {
                    ui.colored_label(ERROR_RED, e);
                } else if let Some(ready) = &slot.ready {
                    ui.label(format!("{} triangles", ready.front.triangle_count()));
                    if ui.small_button("export OBJ").clicked() {
                        let dir = std::path::Path::new("out/compare");
                        message = Some(match ready.export(dir, &slot.shown.label()) {
                            Ok(f) => Ok(format!("wrote {}", f.display())),
                            Err(e) => Err(e),
                        });
                    }
                } else {
                    ui.add(
                        egui::ProgressBar::new(slot.progress)
                            .desired_width(120.0)
                            .show_percentage(),
                    );
                }
            });
        }
    }
    match message {
        Some(Ok(m)) => view.message = Some(m),
        Some(Err(e)) => view.error = Some(e),
        None => {}
    }
    ui.separator();
}

fn stats_section(ui: &mut Ui, view: &mut ViewState) {
    ui.strong("Statistics");
    let Some(last) = view.history.back().copied() else {
        return;
    };
    let n = view.history.len();
    let span = (last.time_s - view.history.front().map_or(last.time_s, |f| f.time_s)).max(1e-6);
    let fps = if n > 1 { (n - 1) as f64 / span } else { 0.0 };
    let s = last.stats;
    egui::Grid::new("stats").num_columns(2).show(ui, |ui| {
        let mut row = |k: &str, v: String| {
            ui.label(k);
            ui.label(v);
            ui.end_row();
        };
        row("fps", format!("{fps:.1} ({:.1} ms a frame)", last.frame_ms));
        row("triangles drawn", s.triangles.to_string());
        row("front", format!("{} vertices", s.active_vertices));
        row("splits / unifies", format!("{} / {}", s.splits, s.unifies));
        row("visited", s.visited.to_string());
        row("refine", format!("{:.2} ms", s.refine_secs * 1e3));
        if let Some(c) = last.cache {
            let first = view.history.front().and_then(|f| f.cache).unwrap_or(c);
            let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
            row(
                "tree cache",
                format!("{:.0} / {:.0} MiB", mib(c.resident_bytes), mib(c.budget)),
            );
            row(
                "pages",
                format!(
                    "{} resident, {} pending, {:.1} MB/s{}",
                    c.resident_pages,
                    c.pending,
                    (c.loaded_bytes - first.loaded_bytes) as f64 / 1e6 / span,
                    if c.failed > 0 {
                        format!(", {} unreadable", c.failed)
                    } else {
                        String::new()
                    }
                ),
            );
        }
        row(
            "upload",
            format!("{:.2} ms, {} bytes", last.upload_ms, last.upload_bytes),
        );
        row("UI", format!("{:.2} ms", last.ui_ms));
        row(
            "τ used",
            format!(
                "{:.2} px{}{}",
                s.tolerance_px,
                if view.hold.scale() > 1.0 {
                    format!(" (×{:.2} to hold the frame rate)", view.hold.scale())
                } else {
                    String::new()
                },
                if s.converged { ", converged" } else { "" }
            ),
        );
        row("GPU", view.gpu_name.clone());
    });
    let t0 = last.time_s;
    let triangles: Vec<[f64; 2]> = view
        .history
        .iter()
        .map(|l| [l.time_s - t0, l.stats.triangles as f64])
        .collect();
    let refine: Vec<[f64; 2]> = view
        .history
        .iter()
        .map(|l| [l.time_s - t0, l.stats.refine_secs * 1e3])
        .collect();
    let frame: Vec<[f64; 2]> = view
        .history
        .iter()
        .map(|l| [l.time_s - t0, l.frame_ms])
        .collect();
    ui.label(RichText::new("triangles drawn, last 10 s").small());
    egui_plot::Plot::new("triangles plot")
        .height(80.0)
        .show_x(false)
        .allow_zoom(false)
        .allow_drag(false)
        .allow_scroll(false)
        .show(ui, |p| p.line(egui_plot::Line::new("triangles", triangles)));
    ui.label(RichText::new("frame and refine ms").small());
    egui_plot::Plot::new("time plot")
        .height(80.0)
        .show_x(false)
        .allow_zoom(false)
        .allow_drag(false)
        .allow_scroll(false)
        .show(ui, |p| {
            p.line(egui_plot::Line::new("frame ms", frame));
            p.line(egui_plot::Line::new("refine ms", refine));
        });
}

/// Help, the frozen frustum, the compare view's labels.
fn overlays(ui: &mut Ui, view: &mut ViewState, settings: &mut ViewerSettings, camera: &Camera) {
    let ctx = ui.ctx().clone();
    if settings.show_help {
        egui::Window::new("Keys")
            .collapsible(false)
            .anchor(egui::Align2::RIGHT_TOP, [-10.0, 10.0])
            .show(&ctx, |ui| {
                egui::Grid::new("keys").show(ui, |ui| {
                    for (k, v) in [
                        ("W A S D", "fly forward, left, back, right"),
                        ("Q / E", "down / up"),
                        ("right mouse", "look around (orbit: circle the model)"),
                        ("wheel", "flying speed (orbit: distance)"),
                        ("Shift", "five times faster"),
                        ("F", "frame the model"),
                        ("O", "orbit mode on / off"),
                        ("L", "freeze the LOD (refine from a fixed camera)"),
                        ("R", "wireframe on / off"),
                        ("Space", "pause / play the camera path"),
                        ("P or F12", "screenshot to out/"),
                        ("H or F1", "this help"),
                        ("drop a file", "open it"),
                    ] {
                        ui.strong(k);
                        ui.label(v);
                        ui.end_row();
                    }
                });
            });
    }
    let painter = ctx.layer_painter(egui::LayerId::new(
        egui::Order::Background,
        egui::Id::unique("vunify overlay"),
    ));
    let ppp = ctx.pixels_per_point();
    if let (Some(frozen), Some(m)) = (view.frozen, &view.model) {
        // The frozen camera's frustum out to the model's far side, projected into the view.
        let depth = (frozen.position.distance(m.loaded.center) + m.loaded.radius).min(frozen.far);
        let corners = frustum_corners(&frozen, frozen.near.max(depth * 0.02), depth);
        let to_screen = |p: Vec3| -> Option<egui::Pos2> {
            let c = camera.clip_from_world() * p.extend(1.0);
            (c.w > 1e-6).then(|| {
                let ndc = c / c.w;
                egui::pos2(
                    (view.scene_x as f32 + (ndc.x * 0.5 + 0.5) * camera.viewport_px[0] as f32)
                        / ppp,
                    (0.5 - ndc.y * 0.5) * camera.viewport_px[1] as f32 / ppp,
                )
            })
        };
        let stroke = egui::Stroke::new(1.5, Color32::from_rgb(255, 200, 60));
        for (a, b) in [
            (0, 1),
            (1, 2),
            (2, 3),
            (3, 0),
            (4, 5),
            (5, 6),
            (6, 7),
            (7, 4),
            (0, 4),
            (1, 5),
            (2, 6),
            (3, 7),
        ] {
            if let (Some(p), Some(q)) = (to_screen(corners[a]), to_screen(corners[b])) {
                painter.line_segment([p, q], stroke);
            }
        }
        if let Some(p) = to_screen(frozen.position) {
            painter.circle_filled(p, 4.0, stroke.color);
        }
    }
    if let Some(c) = &view.compare {
        let [w, h] = view.size;
        for (i, slot) in c.slots.iter().enumerate() {
            let ([x, y], _) = c.cell(i, w, h);
            let x = view.scene_x + x;
            let text = match (&slot.ready, &slot.error) {
                (Some(r), _) => format!(
                    "{}: {} triangles",
                    slot.shown.label(),
                    r.front.triangle_count()
                ),
                (None, Some(e)) => format!("{}: {e}", slot.shown.label()),
                (None, None) => format!(
                    "{}: building {:.0} %",
                    slot.shown.label(),
                    slot.progress * 100.0
                ),
            };
            let at = egui::pos2(x as f32 / ppp + 10.0, y as f32 / ppp + 10.0);
            painter.text(
                at,
                egui::Align2::LEFT_TOP,
                text,
                egui::FontId::proportional(15.0),
                Color32::WHITE,
            );
        }
    }
}

/// Near-plane corners then far-plane corners (at `near` and `far` along the view).
fn frustum_corners(camera: &Camera, near: f32, far: f32) -> [Vec3; 8] {
    let inv = camera.clip_from_world().inverse();
    let (zn, zf) = (depth_of(camera, near), depth_of(camera, far));
    let mut out = [Vec3::ZERO; 8];
    for (i, (x, y)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .into_iter()
        .enumerate()
    {
        for (j, z) in [zn, zf].into_iter().enumerate() {
            let p = inv * Vec4::new(x, y, z, 1.0);
            out[i + 4 * j] = p.truncate() / p.w;
        }
    }
    out
}

/// NDC depth of a point `distance` in front of the camera.
fn depth_of(camera: &Camera, distance: f32) -> f32 {
    let c = camera.clip_from_view() * Vec4::new(0.0, 0.0, -distance, 1.0);
    c.z / c.w
}

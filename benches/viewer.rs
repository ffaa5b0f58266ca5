//! Issue 5's benchmark: the viewer on the dragon at 1280×720 under Xvfb on lavapipe, flying in, with
//! the LOD front at τ = 1 px, with the viewer's default settings (which hold 25 fps by raising τ when
//! frames are slow), and with the full mesh (all three tests off, so every node splits), in the same
//! run: frames per second, and the time the UI takes per frame.
//!
//! `cargo bench --bench viewer [-- --model dragon --frames 150]` (needs Xvfb)

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

mod common;
use common::arg;

fn main() {
    let model = common::model_file(&arg("--model", "dragon"));
    let frames: u32 = arg("--frames", "150").parse().unwrap();
    let work = std::env::temp_dir().join("vunify-viewer-bench");
    std::fs::create_dir_all(&work).unwrap();

    let display = ":123";
    let mut xvfb = Command::new("Xvfb")
        .args([display, "-screen", "0", "1600x900x24", "-nolisten", "tcp"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("Xvfb (apt-get install xvfb)");
    std::thread::sleep(Duration::from_millis(800));

    let mut rows = Vec::new();
    // (name, file tag, the frame-rate hold, all tests off)
    let runs = [
        ("LOD, τ = 1 px (hold off)", "lod", 0.0, false),
        ("LOD, default settings (holds 25 fps)", "hold", 25.0, false),
        ("full mesh", "full", 0.0, true),
    ];
    for (name, tag, hold, off) in runs {
        let stats = work.join(format!("stats-{tag}.json"));
        let mut actions = vec![serde_json::json!({"frame": 0, "hold_fps": hold})];
        if off {
            for t in ["frustum", "normal", "screen_error"] {
                actions.push(serde_json::json!({"frame": 0, t: false}));
            }
        }
        let script = work.join(format!("script-{tag}.json"));
        std::fs::write(
            &script,
            serde_json::json!({"frames": frames, "path": "fly-in", "actions": actions, "stats": stats}).to_string(),
        )
        .unwrap();
        let status = Command::new(env!("CARGO_BIN_EXE_vunify"))
            .args(["view"])
            .arg(&model)
            .args(["--size", "1280x720", "--script"])
            .arg(&script)
            .env("DISPLAY", display)
            .env_remove("WAYLAND_DISPLAY")
            .status()
            .unwrap();
        assert!(status.success());
        rows.push((name, summarize(&stats)));
    }
    let _ = xvfb.kill();
    let _ = xvfb.wait();
    println!(
        "# viewer bench: {}, fly-in over {frames} frames at 1280x720 (Xvfb, lavapipe); first 10 frames left out",
        model.display()
    );
    println!(
        "| | fps (median frame) | frame ms median | frame ms p95 | UI ms median | UI ms p95 | refine ms median | triangles median | τ used median (px) |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (name, s) in &rows {
        println!(
            "| {name} | {:.1} | {:.1} | {:.1} | {:.2} | {:.2} | {:.2} | {:.0} | {:.2} |",
            1000.0 / s[0],
            s[0],
            s[1],
            s[2],
            s[3],
            s[4],
            s[5],
            s[6]
        );
    }
    if let [(_, lod), _, (_, full)] = &rows[..] {
        println!(
            "LOD frames are {:.1}x faster (median frame time)",
            full[0] / lod[0]
        );
    }
}

/// Median and p95 frame ms, median and p95 UI ms, median refine ms, median triangles, median τ.
fn summarize(stats: &Path) -> [f64; 7] {
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(stats).unwrap()).unwrap();
    let frames = &report["frames"].as_array().unwrap()[10..];
    let col = |f: &dyn Fn(&serde_json::Value) -> f64| {
        let mut v: Vec<f64> = frames.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v
    };
    let q = |v: &[f64], p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    let frame = col(&|l| l["frame_ms"].as_f64().unwrap());
    let ui = col(&|l| l["ui_ms"].as_f64().unwrap());
    let refine = col(&|l| l["stats"]["refine_secs"].as_f64().unwrap() * 1e3);
    let tris = col(&|l| l["stats"]["triangles"].as_f64().unwrap());
    let tau = col(&|l| l["stats"]["tolerance_px"].as_f64().unwrap());
    [
        q(&frame, 0.5),
        q(&frame, 0.95),
        q(&ui, 0.5),
        q(&ui, 0.95),
        q(&refine, 0.5),
        q(&tris, 0.5),
        q(&tau, 0.5),
    ]
}

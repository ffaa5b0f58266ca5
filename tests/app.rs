//! The viewer under Xvfb on lavapipe: a scripted run plays a camera path and a few UI actions, takes a
//! screenshot and exits; the screenshot shows the panel and the model, and the statistics moved. In CI
//! (`CI` set) a missing Xvfb or GPU fails the test instead of skipping it.
#![cfg(feature = "viewer")]

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

struct Xvfb {
    child: Child,
    display: String,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        // SIGTERM first, so that the server removes its lock file and socket (SIGKILL leaves
        // them, and enough of them use up the display numbers).
        let terminated = Command::new("kill")
            .arg(self.child.id().to_string())
            .status()
            .is_ok_and(|s| s.success());
        if !terminated {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

/// Display `n`'s lock file names a server that is gone (killed without cleaning up): the number
/// is free again once its lock and socket are removed.
fn clear_stale_display(n: u32) {
    let lock = format!("/tmp/.X{n}-lock");
    let Ok(text) = std::fs::read_to_string(&lock) else {
        return;
    };
    let alive = text
        .trim()
        .parse::<u32>()
        .is_ok_and(|pid| Path::new(&format!("/proc/{pid}")).exists());
    if !alive {
        let _ = std::fs::remove_file(&lock);
        let _ = std::fs::remove_file(format!("/tmp/.X11-unix/X{n}"));
    }
}

/// The tests here run one at a time: two starting Xvfb at once would pick the same free display
/// number, and one would end up on the other's server.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// A private X server on a free display number, or `None` (skipping) outside CI without Xvfb.
fn xvfb() -> Option<Xvfb> {
    for n in 90..140 {
        clear_stale_display(n);
        if Path::new(&format!("/tmp/.X11-unix/X{n}")).exists()
            || Path::new(&format!("/tmp/.X{n}-lock")).exists()
        {
            continue;
        }
        let display = format!(":{n}");
        let child = match Command::new("Xvfb")
            .args([
                display.as_str(),
                "-screen",
                "0",
                "1280x800x24",
                "-nolisten",
                "tcp",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
        {
            Ok(c) => c,
            Err(e) if std::env::var_os("CI").is_some() => panic!("CI has no Xvfb: {e}"),
            Err(e) => {
                eprintln!("skipping: cannot start Xvfb ({e}); scripts/test.sh installs it");
                return None;
            }
        };
        // Wait for the server's socket.
        for _ in 0..100 {
            if Path::new(&format!("/tmp/.X11-unix/X{n}")).exists() {
                return Some(Xvfb { child, display });
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        panic!("Xvfb {display} did not start");
    }
    panic!("no free X display number");
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vunify-app-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn scripted_run_shows_the_model_and_the_panel() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let Some(x) = xvfb() else { return };
    let shot = tmp("view.png");
    let stats = tmp("stats.json");
    let script = tmp("script.json");
    let recorded = tmp("recorded.json");
    let bad = tmp("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap();
    std::fs::write(
        &script,
        serde_json::json!({
            "frames": 60,
            "path": "fly-in",
            "actions": [
                // τ stays as set (the frame-rate hold would raise it on a slow machine).
                {"frame": 0, "hold_fps": 0},
                {"frame": 2, "open": bad},
                {"frame": 5, "record": recorded},
                {"frame": 50, "record": null},
                {"frame": 10, "vsync": true},
                {"frame": 12, "vsync": false},
                {"frame": 20, "wireframe": true},
                {"frame": 40, "tau": 2.0},
                {"frame": 59, "screenshot": shot},
            ],
            "stats": stats,
        })
        .to_string(),
    )
    .unwrap();
    view_script(
        &x,
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/cessna.obj")),
        "1024x640",
        &script,
    );

    let image = image::open(&shot).expect("the screenshot").to_rgba8();
    assert_eq!(image.dimensions(), (1024, 640));
    // The panel (left 290 points at scale 1): egui's grey, with light text on it.
    let panel_px = (0..640).flat_map(|y| (0..280).map(move |x| (x, y)));
    let (mut text, mut panel) = (0, 0);
    for (x, y) in panel_px {
        let p = image.get_pixel(x, y);
        panel += 1;
        text += (p[0] > 150 && p[1] > 150 && p[2] > 150) as u32;
    }
    let share = text as f64 / panel as f64;
    assert!(
        share > 0.01 && share < 0.5,
        "panel text covers {:.1} % of the panel",
        share * 100.0
    );
    // The 3D view: the light-grey model over the dark background.
    let (mut model, mut total) = (0, 0);
    for y in 0..640 {
        for x in 300..1024 {
            let p = image.get_pixel(x, y);
            total += 1;
            model += (p[0] > 90 && p[1] > 90 && p[2] > 90) as u32;
        }
    }
    let share = model as f64 / total as f64;
    assert!(
        share > 0.02,
        "the model covers only {:.2} % of the 3D view",
        share * 100.0
    );

    // The recorded camera path is one `vunify render --path` reads.
    let path = vunify::camera_path::CameraPath::load(&recorded).expect("the recorded path");
    assert!(!path.keyframes.is_empty());

    // Statistics: one line a frame; the front refines as the camera flies in.
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    let lines = report["frames"].as_array().unwrap();
    // The bad file was reported (with its name and line) and the viewer went on.
    let errors = report["errors"].as_array().unwrap();
    assert!(
        errors
            .iter()
            .any(|e| e.as_str().unwrap().contains("bad.obj") && e.as_str().unwrap().contains(":3")),
        "{errors:?}"
    );
    assert_eq!(lines.len(), 60);
    let triangles = |i: usize| lines[i]["stats"]["triangles"].as_u64().unwrap();
    assert!(triangles(0) > 0);
    assert!(
        triangles(39) > triangles(1),
        "flying in refines: {} then {}",
        triangles(1),
        triangles(39)
    );
    assert!(
        triangles(41) < triangles(39),
        "τ 1 → 2 coarsens: {} then {}",
        triangles(39),
        triangles(41)
    );
    eprintln!(
        "triangles: frame 1 {}, 39 {}, 41 {}",
        triangles(1),
        triangles(39),
        triangles(41)
    );
}

/// The compare view with its second row: the four metrics' cuts above, `bounded` and the three
/// envelope methods at ε = 2 % below, each viewport showing its model.
#[test]
fn compare_view_shows_the_methods_within_epsilon() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let Some(x) = xvfb() else { return };
    let shot = tmp("compare.png");
    let script = tmp("compare.json");
    let model = tmp("compare-box.obj");
    let bumpy = {
        let mut m =
            common::subdivided(&vunify::fixtures::cuboid(glam::Vec3::new(2.0, 1.0, 1.0)), 3);
        for p in &mut m.positions {
            p.z += 0.03 * (5.0 * p.x).sin();
        }
        m
    };
    std::fs::write(&model, vunify::export::obj_string(&bumpy)).unwrap();
    std::fs::write(
        &script,
        serde_json::json!({
            "frames": 150,
            "actions": [
                {"frame": 1, "compare": true},
                {"frame": 2, "compare_within": 0.02},
                {"frame": 149, "screenshot": shot},
            ],
        })
        .to_string(),
    )
    .unwrap();
    view_script(&x, &model, "1200x600", &script);
    let image = image::open(&shot).expect("the screenshot").to_rgba8();
    // The 3D view right of the 290-point panel: 4 × 2 viewports, each with light model pixels.
    let (x0, w, h) = (290, 1200 - 290, 600);
    for cell in 0..8u32 {
        let (cx, cy) = (x0 + (cell % 4) * (w / 4), (cell / 4) * (h / 2));
        let mut model = 0;
        for y in cy + 30..cy + h / 2 {
            for x in cx..cx + w / 4 {
                let p = image.get_pixel(x, y);
                model += (p[0] > 90 && p[1] > 90 && p[2] > 90) as u32;
            }
        }
        assert!(
            model > 500,
            "viewport {cell} shows only {model} model pixels"
        );
    }
}

/// Runs `vunify view MODEL --size SIZE --script SCRIPT` on the private X server, with settings and
/// the tree cache in a private home (not the user's); fails the test unless it exits cleanly.
fn view_script(x: &Xvfb, model: &Path, size: &str, script: &Path) {
    let runtime = tempdir_0700();
    let out = Command::new(env!("CARGO_BIN_EXE_vunify"))
        .arg("view")
        .arg(model)
        .args(["--size", size, "--script"])
        .arg(script)
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .env("XDG_RUNTIME_DIR", &runtime)
        .env("HOME", &runtime)
        .env("XDG_CONFIG_HOME", runtime.join("config"))
        .env("XDG_CACHE_HOME", runtime.join("cache"))
        .output()
        .expect("run vunify view");
    assert!(
        out.status.success(),
        "exit {:?}\nstdout: {}\nstderr: {}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn tempdir_0700() -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let d = tmp("runtime");
    std::fs::create_dir_all(&d).unwrap();
    std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o700)).unwrap();
    d
}

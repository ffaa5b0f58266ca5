//! Issue 4's benchmark: the dragon along the fly-in path at 1024×768 on the adapter (lavapipe here),
//! full mesh against LOD at τ = 1 px in the same run: frame time, triangles, PSNR, differing pixels,
//! upload volume.
//!
//! `cargo bench --bench render [-- --model dragon --seconds 10 --fps 10 --tau 1 --size 1024x768]`

use vunify::camera_path::CameraPath;
use vunify::mesh::CleanOptions;
use vunify::refine::{Hierarchy, Settings};
use vunify::render::job::{RenderJob, render_path};
use vunify::render::{DrawOptions, Gpu};
use vunify::vtree::{self, BuildOptions};

mod common;
use common::arg;

fn main() {
    let model = common::model_file(&arg("--model", "dragon"));
    let seconds: f32 = arg("--seconds", "10").parse().unwrap();
    let fps: f32 = arg("--fps", "10").parse().unwrap();
    let tau: f32 = arg("--tau", "1").parse().unwrap();
    let size = arg("--size", "1024x768");
    let (w, h) = size.split_once('x').unwrap();
    let size = [w.parse().unwrap(), h.parse().unwrap()];
    let (mesh, _) = vunify::mesh::load(&model, &CleanOptions::default()).unwrap();
    let (tree, _) = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {}).unwrap();
    let hierarchy = Hierarchy::new(&tree);
    let (lo, hi) = mesh.bounds();
    let path = CameraPath::fly_in((lo + hi) * 0.5, (hi - lo).length() * 0.5, seconds);
    let gpu = Gpu::headless().unwrap_or_else(|e| panic!("{e}"));
    let job = RenderJob {
        size,
        settings: Settings {
            tolerance_px: tau,
            tests: vunify::refine::Tests {
                shading: !std::env::args().any(|a| a == "--geometric"),
                ..Default::default()
            },
            ..Default::default()
        },
        draw: DrawOptions {
            tolerance_px: tau,
            ..Default::default()
        },
        fps,
        every: usize::MAX,
        compare: true,
        full: false,
        out_dir: std::env::temp_dir().join("vunify-render-bench"),
        started: None,
    };
    let s = render_path(&gpu, &hierarchy, &path, &job, &mut |_, _| {}).unwrap();
    let o = |x: Option<f64>| x.map_or("n/a".to_string(), |v| format!("{v:.1}"));
    let model = model.display();
    println!(
        "# render bench: {model}, fly-in {seconds} s at {fps} fps ({} frames), {}x{}, tau = {tau} px, {}",
        s.frames, size[0], size[1], s.adapter
    );
    println!(
        "| | GPU ms median | GPU ms p95 | frame ms median (render + readback) | frame ms p95 | triangles mean | triangles max |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    println!(
        "| full mesh | {} | {} | {} | {} | {} | {} |",
        o(s.full_gpu_ms_median),
        o(s.full_gpu_ms_p95),
        o(s.full_frame_ms_median),
        o(s.full_frame_ms_p95),
        s.full_triangles,
        s.full_triangles
    );
    println!(
        "| LOD τ = {tau} px | {} | {} | {:.1} | {:.1} | {:.0} | {} |",
        o(s.gpu_ms_median),
        o(s.gpu_ms_p95),
        s.frame_ms_median,
        s.frame_ms_p95,
        s.triangles_mean,
        s.triangles_max
    );
    println!(
        "speed-up (GPU median): {}; PSNR mean {:.1} dB (worst {:.1} dB, frame {}); pixels off by > 8/255: mean {:.3} %, max {:.3} %; refine median {:.3} ms; upload {:.0} bytes a frame",
        match (s.full_gpu_ms_median, s.gpu_ms_median) {
            (Some(f), Some(l)) => format!("{:.1}x", f / l),
            _ => "n/a".into(),
        },
        s.psnr_db_mean.unwrap_or(0.0),
        s.psnr_db_min.unwrap_or(0.0),
        s.worst_frame.unwrap_or(0),
        s.differing_mean.unwrap_or(0.0) * 100.0,
        s.differing_max.unwrap_or(0.0) * 100.0,
        s.refine_ms_median,
        s.upload_bytes_mean,
    );
}

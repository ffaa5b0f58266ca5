//! Simplifying a lit mesh at equal triangle counts (issue 22 §5): Liu and Wu's superfaces
//! against meshoptimizer's `simplify_with_attributes` (colour weight 1, its documented default) and
//! against the vertex tree's build-order cut, each drawn whole (`--full`, colours unlit) from one
//! camera and compared with the full lit mesh: PSNR, and the share of pixels off by more than 2/255.
//!
//!     vunify radiosity assets/scenes/room.obj -o room.ply
//!     cargo bench --bench lit -- --lit room.ply --camera docs/radiosity/room-views.json --settings 0.1:2,0.8:50
//!
//! Each distinct keyframe of the camera file is one view.

mod common;

use std::path::Path;
use vunify::camera_path::CameraPath;
use vunify::mesh::{CleanOptions, Mesh, load};
use vunify::radiosity::superfaces::{SuperfaceOptions, simplify_superfaces};
use vunify::refine::{Front, Hierarchy};
use vunify::render::headless::{Gpu, OFFSCREEN_FORMAT, Offscreen};
use vunify::render::job::{camera_at, frame};
use vunify::render::renderer::{ColorBy, DrawOptions, Renderer};
use vunify::vtree::{self, BuildOptions};

const SIZE: [u32; 2] = [640, 480];

/// The mesh drawn whole from the views at times `views` of the camera path (one tree, one upload).
fn pictures(
    gpu: &Gpu,
    mesh: &Mesh,
    camera_path: &CameraPath,
    views: &[f32],
    diagonal: f32,
) -> Vec<image::RgbaImage> {
    let (tree, _) = vtree::build(mesh, &BuildOptions::default(), &mut |_, _| {}).expect("builds");
    let h = Hierarchy::new(&tree);
    let mut all = Front::new(&h);
    all.refine_all(&h);
    let mut renderer = Renderer::new(&gpu.device, OFFSCREEN_FORMAT);
    renderer.set_hierarchy(&gpu.device, &gpu.queue, &h);
    renderer.set_triangles(&gpu.device, &gpu.queue, &all.all_vertices(&h));
    let target = Offscreen::new(&gpu.device, SIZE);
    let draw = DrawOptions {
        color_by: ColorBy::Baked,
        ..Default::default()
    };
    views
        .iter()
        .map(|&t| {
            let camera = camera_at(camera_path, t, SIZE, diagonal);
            frame(gpu, &mut renderer, &target, &camera, &draw)
                .expect("renders")
                .0
        })
        .collect()
}

/// PSNR (dB) and the share of pixels with a channel off by more than 2/255.
fn judge(a: &image::RgbaImage, b: &image::RgbaImage) -> (f64, f64) {
    let psnr = vunify::render::image_diff::compare(a, b).psnr_db;
    let off = a
        .pixels()
        .zip(b.pixels())
        .filter(|(p, q)| (0..3).any(|c| p[c].abs_diff(q[c]) > 2))
        .count();
    (psnr, off as f64 / (a.width() * a.height()) as f64)
}

fn main() {
    let lit_file = common::arg("--lit", "room.ply");
    let camera_file = common::arg("--camera", "room-camera.json");
    let settings = common::arg("--settings", "0.1:2,0.8:50");
    let (lit, _) = load(Path::new(&lit_file), &CleanOptions::default()).expect("the lit mesh");
    let camera_path = CameraPath::load(Path::new(&camera_file)).expect("the camera");
    let gpu = Gpu::headless().expect("a GPU (lavapipe)");
    let diagonal = lit.diagonal();
    // Each distinct keyframe is a view.
    let mut views: Vec<f32> = Vec::new();
    for (k, key) in camera_path.keyframes.iter().enumerate() {
        let same = |o: &vunify::camera_path::Keyframe| {
            o.position == key.position && o.look_at == key.look_at
        };
        if !camera_path.keyframes[..k].iter().any(same) {
            views.push(key.time);
        }
    }
    let references = pictures(&gpu, &lit, &camera_path, &views, diagonal);
    let (tree, _) = vtree::build(&lit, &BuildOptions::default(), &mut |_, _| {}).expect("builds");
    println!(
        "{lit_file}: {} triangles, {} views (PSNR and pixels off: mean over the views, then the worst view)",
        lit.triangle_count(),
        views.len()
    );
    println!("| (ε, δ) | method | triangles | PSNR | pixels off > 2/255 |");
    println!("|---|---|---:|---:|---:|");
    for s in settings.split(',') {
        let (e, d) = s.split_once(':').expect("ε:δ");
        let options = SuperfaceOptions {
            epsilon: e.parse().expect("ε"),
            delta: d.parse().expect("δ"),
            distance: 0.0,
            discs: false,
        };
        let (ours, _) = simplify_superfaces(&lit, &options).expect("superfaces");
        let n = ours.triangle_count();
        let peer = common::meshopt_with_colours(&lit, n);
        let cut = vtree::cut_at_triangles(&tree, n as u32).mesh;
        for (name, mesh) in [
            ("superfaces", &ours),
            ("meshopt (colour 1)", &peer),
            ("vertex tree", &cut),
        ] {
            let judged: Vec<(f64, f64)> = pictures(&gpu, mesh, &camera_path, &views, diagonal)
                .iter()
                .zip(&references)
                .map(|(image, reference)| judge(image, reference))
                .collect();
            let count = judged.len() as f64;
            let psnr = judged.iter().map(|j| j.0).sum::<f64>() / count;
            let off = judged.iter().map(|j| j.1).sum::<f64>() / count;
            let worst = judged.iter().map(|j| j.0).fold(f64::INFINITY, f64::min);
            let worst_off = judged.iter().map(|j| j.1).fold(0.0, f64::max);
            println!(
                "| ({e}, {d}) | {name} | {} | {psnr:.2} dB (worst {worst:.2}) | {:.1} % (worst {:.1} %) |",
                mesh.triangle_count(),
                100.0 * off,
                100.0 * worst_off
            );
        }
    }
}

//! The refinement runtime along scripted camera paths: per-frame adaptation time, split and
//! unify operations per second, triangles drawn, memory per original vertex; against building the same
//! front from scratch (a fresh refiner from the root) and extracting the same triangle count from the
//! tree, in the same run.
//!
//! `cargo bench --bench refine [-- --models dragon,bunny --frames 600 --size 1920x1080 --tau 1 --warm]`
//! Models come from `$VUNIFY_MODELS` (required).
//!
//! Between frames the bench writes [`EVICT_BYTES`] of memory (not timed), as the product's rasteriser
//! streams its framebuffers and vertex data through the caches between two refinements: a frame
//! starts with nothing of the hierarchy in cache, as it does in `vunify render` and the viewer.
//! `--warm` leaves the caches alone (the runtime's best case).

use glam::Vec3;
use std::path::PathBuf;
use std::time::Instant;
use vunify::mesh::CleanOptions;
use vunify::refine::{Camera, Hierarchy, Refiner, Settings};
use vunify::vtree::{self, BuildOptions};

struct Args {
    models: Vec<String>,
    frames: usize,
    size: [u32; 2],
    tau: f32,
}

fn args() -> Args {
    let mut a = Args {
        models: vec!["stanford-dragon.obj.xz".into()],
        frames: 600,
        size: [1920, 1080],
        tau: 1.0,
    };
    let argv: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < argv.len() {
        let value = argv.get(i + 1).cloned().unwrap_or_default();
        match argv[i].as_str() {
            "--models" => {
                a.models = value
                    .split(',')
                    .map(|m| match m {
                        "dragon" => "stanford-dragon.obj.xz".to_string(),
                        "bunny" => "stanford-bunny.obj".to_string(),
                        m if m.contains('.') => m.to_string(),
                        m => format!("{m}.obj"),
                    })
                    .collect()
            }
            "--frames" => a.frames = value.parse().expect("--frames N"),
            "--tau" => a.tau = value.parse().expect("--tau PX"),
            "--size" => {
                let (w, h) = value.split_once('x').expect("--size WxH");
                a.size = [w.parse().unwrap(), h.parse().unwrap()];
            }
            _ => {
                i += 1;
                continue;
            }
        }
        i += 2;
    }
    a
}

/// Memory written between frames to evict the caches: twice the largest last-level cache here.
const EVICT_BYTES: usize = 64 << 20;

/// Writes every cache line of `scratch`, pushing what the last frame used out of the caches.
fn evict_caches(scratch: &mut [u8]) {
    for line in scratch.chunks_mut(64) {
        line[0] = line[0].wrapping_add(1);
    }
    std::hint::black_box(scratch);
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

/// Orbit: once around the model at 2.5 radii, slightly above it.
fn orbit(center: Vec3, radius: f32, frames: usize, size: [u32; 2]) -> Vec<Camera> {
    (0..frames)
        .map(|i| {
            let a = i as f32 / frames as f32 * std::f32::consts::TAU;
            let eye = center + Vec3::new(a.cos(), 0.35, a.sin()) * radius * 2.5;
            camera(eye, center, radius, size)
        })
        .collect()
}

/// Fly-in (Tao et al.'s Fig. 6): from 12 radii away to 0.4 radii from the surface, geometrically, aimed
/// at a point on the model's side.
fn fly_in(center: Vec3, radius: f32, frames: usize, size: [u32; 2]) -> Vec<Camera> {
    let dir = Vec3::new(0.3, 0.25, 1.0).normalize();
    (0..frames)
        .map(|i| {
            let t = i as f32 / (frames - 1).max(1) as f32;
            let distance = radius * 12.0 * (0.4f32 / 12.0).powf(t);
            camera(center + dir * (radius + distance), center, radius, size)
        })
        .collect()
}

fn camera(eye: Vec3, target: Vec3, radius: f32, size: [u32; 2]) -> Camera {
    Camera::looking_at(
        eye,
        target,
        Vec3::Y,
        50f32.to_radians(),
        size,
        radius * 1e-3,
        radius * 100.0,
    )
}

/// Replays of each path's operations; the median rate is reported.
const REPLAYS: usize = 9;

/// The table's title and header.
fn print_header(args: &Args, warm: bool) {
    println!(
        "# refine bench: {} frames a path, {}x{}, tau = {} px, caches {}",
        args.frames,
        args.size[0],
        args.size[1],
        args.tau,
        if warm {
            "warm"
        } else {
            "evicted between frames"
        }
    );
    println!(
        "| model | path | median ms | p99 ms | max ms | operations | operations/s (M, in the loop) | operations/s (M, replayed) | triangles median | triangles max | from-scratch front ms | extract same count ms | bytes/vertex |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
}

fn main() {
    let args = args();
    let dir = PathBuf::from(
        std::env::var_os("VUNIFY_MODELS")
            .expect("set VUNIFY_MODELS to the folder of the test models (see the README)"),
    );
    let warm = std::env::args().any(|a| a == "--warm");
    print_header(&args, warm);
    for name in &args.models {
        let (mesh, _) = vunify::mesh::load(&dir.join(name), &CleanOptions::default())
            .unwrap_or_else(|e| panic!("{e}"));
        let (tree, _) = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {}).unwrap();
        let h = Hierarchy::new(&tree);
        let (lo, hi) = mesh.bounds();
        let (center, radius) = ((lo + hi) * 0.5, (hi - lo).length() * 0.5);
        // Raw operation throughput: every split from the root down, every unify back up.
        {
            let mut f = vunify::refine::Front::new(&h);
            let t0 = Instant::now();
            f.refine_all(&h);
            let split_s = t0.elapsed().as_secs_f64();
            let t0 = Instant::now();
            f.coarsen_all(&h);
            let unify_s = t0.elapsed().as_secs_f64();
            println!(
                "{name}: {} splits in {:.1} ms ({:.2} M/s), {} unifies in {:.1} ms ({:.2} M/s); tree {:.0} B/vertex, front (all triangles) {:.0} B/vertex",
                f.splits,
                split_s * 1e3,
                f.splits as f64 / split_s / 1e6,
                f.unifies,
                unify_s * 1e3,
                f.unifies as f64 / unify_s / 1e6,
                h.bytes() as f64 / h.leaf_count as f64,
                f.bytes() as f64 / h.leaf_count as f64,
            );
        }
        let settings = Settings {
            tolerance_px: args.tau,
            tests: vunify::refine::Tests {
                shading: !std::env::args().any(|a| a == "--geometric"),
                ..Default::default()
            },
            ..Default::default()
        };
        for (path, cameras) in [
            ("orbit", orbit(center, radius, args.frames, args.size)),
            ("fly-in", fly_in(center, radius, args.frames, args.size)),
        ] {
            let mut r = Refiner::new(&h, settings);
            // The first frame builds the front from the root: not steady motion.
            r.update(&h, &cameras[0]);
            let start_front = r.front.clone();
            let mut times = Vec::new();
            let mut triangles = Vec::new();
            let mut ops = 0u64;
            let mut op_secs = 0.0;
            let mut peak_bytes = 0;
            let mut scratch = vec![0u8; if warm { 0 } else { EVICT_BYTES }];
            for c in &cameras[1..] {
                evict_caches(&mut scratch);
                let s = r.update(&h, c);
                times.push(s.refine_secs * 1e3);
                triangles.push(s.triangles as f64);
                ops += (s.splits + s.unifies) as u64;
                op_secs += s.operation_secs;
                peak_bytes = peak_bytes.max(r.bytes());
            }
            // The operations as the runtime ran them, each timed (among the visits, which evict
            // what they use) between fences, less the fences' own cost (see `FrameStats::operation_secs`).
            let loop_rate = ops as f64 / op_secs / 1e6;
            // A second runtime from the same front records the path's operations for the replays
            // (the timed one does not: the log's growth, first touches of memory at ~20 µs a page
            // here, would have been timed with the operations).
            let mut recorder = Refiner::starting_from(&h, start_front.clone(), settings);
            recorder.front.log = Some(Vec::new());
            for c in &cameras[1..] {
                recorder.update(&h, c);
            }
            let log = recorder.front.log.take().unwrap();
            assert_eq!(
                log.len() as u64,
                ops,
                "the recording runtime did as the timed one"
            );
            // The path's operations alone: replayed from the same first front, without view tests;
            // the median of several replays, as one swings with the machine.
            let mut rates: Vec<f64> = (0..REPLAYS)
                .map(|_| {
                    let mut replay = start_front.clone();
                    let t0 = Instant::now();
                    replay.replay(&h, &log);
                    log.len() as f64 / t0.elapsed().as_secs_f64() / 1e6
                })
                .collect();
            rates.sort_by(f64::total_cmp);
            let replay_rate = rates[REPLAYS / 2];
            // Peers, at the median frame: the same front from scratch, and a static extraction of
            // the same triangle count.
            let mid = &cameras[cameras.len() / 2];
            let t0 = Instant::now();
            let mut fresh = Refiner::new(&h, settings);
            let s = fresh.update(&h, mid);
            let scratch_ms = t0.elapsed().as_secs_f64() * 1e3;
            let t0 = Instant::now();
            let cut = vtree::cut_at_triangles(&tree, s.triangles);
            let extract_ms = t0.elapsed().as_secs_f64() * 1e3;
            std::hint::black_box(cut);
            times.sort_by(f64::total_cmp);
            triangles.sort_by(f64::total_cmp);
            println!(
                "| {name} | {path} | {:.3} | {:.3} | {:.3} | {ops} | {loop_rate:.2} | {:.2} | {:.0} | {:.0} | {scratch_ms:.1} | {extract_ms:.1} | {:.1} |",
                percentile(&times, 0.5),
                percentile(&times, 0.99),
                times.last().unwrap(),
                replay_rate,
                percentile(&triangles, 0.5),
                triangles.last().unwrap(),
                (h.bytes() + peak_bytes) as f64 / h.leaf_count as f64,
            );
        }
    }
}

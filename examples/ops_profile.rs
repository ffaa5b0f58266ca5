//! Profiling aid: the dragon's orbit at 1920x1080, τ = 1 px, recorded and replayed many times, so that
//! `perf` sees the operations alone. `cargo run --release --example ops_profile -- TREE.vtree`
//! (default `/tmp/dragon.vtree`). Prints the time of the deviation bounds and the hierarchy, then the
//! orbit's median frame time and operations per second in the loop (median of `LOOPS` orbits from
//! the same start, default 1), the replayed operations per second (mean and best of `ROUNDS`,
//! default 40) and a whole-tree sweep. Compare two builds by alternating their binaries.
//!
//! Other modes: `SWEEPS=N` runs N whole-tree sweeps instead; `WINDOW=N` replays windows of N
//! operations forwards and back twenty times each, so that their data stays in cache (what an
//! operation costs without misses); `FRAMES=N ORBIT_ONLY=1` stops after an orbit of N frames (for a
//! cache simulator: the difference between 600 frames and 2 is the orbit's operations in the loop).
//! `PATH_FLY=1` takes the bench's fly-in instead of the orbit.
use glam::Vec3;
use std::time::Instant;
use vunify::refine::{Camera, Front, Hierarchy, Refiner, Settings};

fn main() {
    let path = std::env::args()
        .nth(1)
        .unwrap_or("/tmp/dragon.vtree".into());
    let tree = vunify::vtree::read(path.as_ref()).unwrap();
    let t0 = Instant::now();
    let bounds = tree.deviation_bounds();
    let t1 = Instant::now();
    let h = Hierarchy::new(&tree);
    println!(
        "deviation bounds {:.1} ms ({} nodes), hierarchy {:.1} ms",
        (t1 - t0).as_secs_f64() * 1e3,
        bounds.len(),
        t1.elapsed().as_secs_f64() * 1e3
    );
    if let Ok(n) = std::env::var("SWEEPS") {
        for _ in 0..n.parse::<usize>().unwrap() {
            let mut f = Front::new(&h);
            let t0 = Instant::now();
            f.refine_all(&h);
            let t1 = Instant::now();
            f.coarsen_all(&h);
            println!(
                "split {:.2} M/s, unify {:.2} M/s",
                f.splits as f64 / (t1 - t0).as_secs_f64() / 1e6,
                f.unifies as f64 / t1.elapsed().as_secs_f64() / 1e6
            );
        }
        return;
    }
    let leaves = &h.position[..h.leaf_count as usize];
    let lo = leaves.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
    let hi = leaves.iter().fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
    let (c, r) = ((lo + hi) * 0.5, (hi - lo).length() * 0.5);
    let frames: usize = std::env::var("FRAMES")
        .ok()
        .and_then(|f| f.parse().ok())
        .unwrap_or(600);
    let fly_in = std::env::var("PATH_FLY").is_ok();
    let cameras: Vec<Camera> = (0..frames)
        .map(|i| {
            let eye = if fly_in {
                // The bench's fly-in: from 12 radii away to 0.4 from the surface, geometrically.
                let t = i as f32 / 599.0;
                c + Vec3::new(0.3, 0.25, 1.0).normalize()
                    * r
                    * (1.0 + 12.0 * (0.4f32 / 12.0).powf(t))
            } else {
                let a = i as f32 / 600.0 * std::f32::consts::TAU;
                c + Vec3::new(a.cos(), 0.35, a.sin()) * r * 2.5
            };
            Camera::looking_at(
                eye,
                c,
                Vec3::Y,
                50f32.to_radians(),
                [1920, 1080],
                r * 1e-3,
                r * 100.0,
            )
        })
        .collect();
    let mut refiner = Refiner::new(&h, Settings::default());
    refiner.update(&h, &cameras[0]);
    let start = refiner.front.clone();
    refiner.front.log = Some(Vec::new());
    let mut op_secs = 0.0;
    let mut frame_ms: Vec<f64> = cameras[1..]
        .iter()
        .map(|cam| {
            let stats = refiner.update(&h, cam);
            op_secs += stats.operation_secs;
            stats.refine_secs * 1e3
        })
        .collect();
    let ops = refiner.front.splits + refiner.front.unifies - start.splits - start.unifies;
    // More orbits from the same start, to take the median of noisy runs.
    let mut in_loop = vec![ops as f64 / op_secs / 1e6];
    let loops: usize = std::env::var("LOOPS")
        .ok()
        .and_then(|l| l.parse().ok())
        .unwrap_or(1);
    for _ in 1..loops {
        let mut again = Refiner::starting_from(start.clone(), Settings::default());
        let mut secs = 0.0;
        for cam in &cameras[1..] {
            let stats = again.update(&h, cam);
            secs += stats.operation_secs;
            frame_ms.push(stats.refine_secs * 1e3);
        }
        let ops = again.front.splits + again.front.unifies - start.splits - start.unifies;
        in_loop.push(ops as f64 / secs / 1e6);
    }
    // Each orbit's rate, in order: a first run that pays for new memory shows here.
    let each: Vec<String> = in_loop.iter().map(|r| format!("{r:.2}")).collect();
    println!("in the loop, each run: {} M ops/s", each.join(" "));
    in_loop.sort_by(f64::total_cmp);
    let in_loop = in_loop[in_loop.len() / 2];
    frame_ms.sort_by(f64::total_cmp);
    if std::env::var("ORBIT_ONLY").is_ok() {
        println!("{} ops", refiner.front.log.as_ref().unwrap().len());
        return;
    }
    let log = refiner.front.log.take().unwrap();
    let rounds: usize = std::env::var("ROUNDS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(40);
    let (mut secs, mut best) = (0.0, f64::INFINITY);
    for _ in 0..rounds {
        let mut f = start.clone();
        let t0 = Instant::now();
        replay(&mut f, &h, &log);
        let dt = t0.elapsed().as_secs_f64();
        secs += dt;
        best = best.min(dt);
    }
    if let Ok(w) = std::env::var("WINDOW") {
        let w: usize = w.parse().unwrap();
        let mut f = start.clone();
        let mut pos = 0;
        let mut results = Vec::new();
        while pos + w <= log.len() {
            let fwd = &log[pos..pos + w];
            // Unifies undo splits and the reverse: the front is back where it was after each pair.
            let back: Vec<u32> = fwd.iter().rev().map(|&o| !o).collect();
            f.replay(&h, fwd);
            f.replay(&h, &back);
            let t0 = Instant::now();
            for _ in 0..20 {
                f.replay(&h, fwd);
                f.replay(&h, &back);
            }
            results.push((40 * w) as f64 / t0.elapsed().as_secs_f64() / 1e6);
            // On to a window further down the log.
            let next = (pos + w * 7).min(log.len());
            f.replay(&h, &log[pos..next]);
            pos = next;
        }
        results.sort_by(f64::total_cmp);
        println!(
            "window {w}: in-cache M ops/s median {:.2} min {:.2} max {:.2} ({} windows)",
            results[results.len() / 2],
            results[0],
            results[results.len() - 1],
            results.len()
        );
        return;
    }
    let mut f = Front::new(&h);
    let t0 = Instant::now();
    f.refine_all(&h);
    let t1 = Instant::now();
    f.coarsen_all(&h);
    let t2 = Instant::now();
    println!(
        "{} frames: median {:.3} ms; in the loop {:.2} M ops/s",
        if fly_in { "fly-in" } else { "orbit" },
        frame_ms[frame_ms.len() / 2],
        in_loop
    );
    println!(
        "{} ops x {rounds}: {:.2} M ops/s (best round {:.2}); sweep: split {:.2} M/s, unify {:.2} M/s",
        log.len(),
        (log.len() * rounds) as f64 / secs / 1e6,
        log.len() as f64 / best / 1e6,
        f.splits as f64 / (t1 - t0).as_secs_f64() / 1e6,
        f.unifies as f64 / (t2 - t1).as_secs_f64() / 1e6,
    );
}

/// Not inlined, so that a cache simulator can count this alone
/// (`valgrind --tool=callgrind --cache-sim=yes --toggle-collect='*ops_profile::replay*'`).
#[inline(never)]
fn replay(f: &mut Front, h: &Hierarchy, log: &[u32]) {
    f.replay(h, log);
}

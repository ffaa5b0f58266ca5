//! Profiling aid: the dragon's orbit at 1920x1080, τ = 1 px, recorded and replayed many times, so that
//! `perf` sees the operations alone. `cargo run --release --example ops_profile -- TREE.vtree`
//! (default `/tmp/dragon.vtree`). Prints the time of the deviation bounds and the hierarchy, then the
//! replayed operations per second (mean and best of `ROUNDS`, default 40) and a whole-tree sweep;
//! `SWEEPS=N` runs N whole-tree sweeps instead. Compare two builds by alternating their binaries.
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
    let cameras: Vec<Camera> = (0..600)
        .map(|i| {
            let a = i as f32 / 600.0 * std::f32::consts::TAU;
            let eye = c + Vec3::new(a.cos(), 0.35, a.sin()) * r * 2.5;
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
    frame_ms.sort_by(f64::total_cmp);
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
    let mut f = Front::new(&h);
    let t0 = Instant::now();
    f.refine_all(&h);
    let t1 = Instant::now();
    f.coarsen_all(&h);
    let t2 = Instant::now();
    println!(
        "orbit frames: median {:.3} ms; in the loop {:.2} M ops/s",
        frame_ms[frame_ms.len() / 2],
        log.len() as f64 / op_secs / 1e6
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

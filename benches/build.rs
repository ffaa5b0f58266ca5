//! Builder benchmark against meshoptimizer, in the same process and run (ratios hold on a noisy shared
//! machine; absolute times drift). Prints Markdown tables for BENCHMARKS.md.
//!
//! cargo bench --bench build [-- --models cow,bunny] [--repeat 3] [--skip-quality] [--skip-metrics]
//! cargo bench --bench build -- --cells N [--threads 1,2,4] [--models dragon] [--repeat 3]
//!
//! With `--cells N`, only the partitioned build's table: time against thread count, whole and in
//! cells of at most N triangles (default threads: 1, 2, 4, … up to the machine's), the runs of one
//! model alternating between thread counts.
//!
//! Build and meshopt times are medians of `--repeat` alternating runs (default 3).
//!
//! Models come from $VUNIFY_MODELS (required).

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::time::Instant;
use vunify::mesh::{self, CleanOptions};
use vunify::simplify::Metric;
use vunify::vtree::{self, BuildOptions};

/// Counts live heap bytes and their peak, so builder and meshopt peaks are measured the same way.
struct Counting;
static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is forwarded to the system allocator with the caller's arguments unchanged;
// the counters only observe sizes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        // SAFETY: the caller's `alloc` contract, passed on.
        let p = unsafe { System.alloc(l) };
        if !p.is_null() {
            let now = LIVE.fetch_add(l.size(), Relaxed) + l.size();
            PEAK.fetch_max(now, Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        // SAFETY: `p` came from this allocator, which is the system's, with layout `l`.
        unsafe { System.dealloc(p, l) };
        LIVE.fetch_sub(l.size(), Relaxed);
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        // SAFETY: as for `dealloc`; the caller's `realloc` contract, passed on.
        let q = unsafe { System.realloc(p, l, new) };
        if !q.is_null() {
            if new > l.size() {
                let now = LIVE.fetch_add(new - l.size(), Relaxed) + new - l.size();
                PEAK.fetch_max(now, Relaxed);
            } else {
                LIVE.fetch_sub(l.size() - new, Relaxed);
            }
        }
        q
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// Runs `f`, returning its result, seconds, and the peak heap bytes it added above what was live.
fn measured<T>(f: impl FnOnce() -> T) -> (T, f64, usize) {
    let base = LIVE.load(Relaxed);
    PEAK.store(base, Relaxed);
    let t = Instant::now();
    let out = f();
    let secs = t.elapsed().as_secs_f64();
    (out, secs, PEAK.load(Relaxed) - base)
}

fn median(xs: &mut [f64]) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs[xs.len() / 2]
}

fn value_of<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    let i = args.iter().position(|a| a == name)?;
    args.get(i + 1).map(String::as_str)
}

/// The partitioned build's time against thread count (medians of `repeat` alternating rounds),
/// beside the whole build's, each on a pool of that many threads (the whole build's node finisher
/// is a thread of its own besides).
fn threads_table(
    paths: impl Iterator<Item = std::path::PathBuf>,
    cells: usize,
    threads: &[usize],
    repeat: usize,
) {
    println!("## Threads: vunify build, whole and in cells of at most {cells} triangles\n");
    println!("| model | triangles | build | threads | seconds | vs 1 thread |");
    println!("|---|---:|---|---:|---:|---:|");
    let options = BuildOptions::default();
    for path in paths {
        let Ok((mesh, _)) = mesh::load(&path, &CleanOptions::default()) else {
            eprintln!("skipping {}", path.display());
            continue;
        };
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().to_string());
        let run = |t: usize, in_cells: bool| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .expect("pool");
            let (_, secs, _) = measured(|| {
                pool.install(|| {
                    if in_cells {
                        vtree::build_partitioned(
                            &mesh,
                            &options,
                            cells,
                            &std::env::temp_dir(),
                            &mut |_, _| {},
                        )
                    } else {
                        vtree::build(&mesh, &options, &mut |_, _| {})
                    }
                    .expect("build")
                })
            });
            secs
        };
        for in_cells in [false, true] {
            let mut times = vec![Vec::new(); threads.len()];
            for _ in 0..repeat {
                for (i, &t) in threads.iter().enumerate() {
                    times[i].push(run(t, in_cells));
                }
            }
            let medians: Vec<f64> = times.iter_mut().map(|t| median(t)).collect();
            for (&t, &m) in threads.iter().zip(&medians) {
                println!(
                    "| {name} | {} | {} | {t} | {m:.2} | {:.2} |",
                    mesh.triangle_count(),
                    if in_cells { "cells" } else { "whole" },
                    m / medians[0]
                );
            }
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let flag = |name: &str| args.iter().any(|a| a == name);
    let models: Vec<String> = args
        .iter()
        .position(|a| a == "--models")
        .and_then(|i| args.get(i + 1))
        .map(|s| s.split(',').map(String::from).collect())
        .unwrap_or_else(|| {
            ["cow", "fandisk", "cessna", "bunny", "horse", "dragon"]
                .map(String::from)
                .to_vec()
        });
    let repeat: usize = args
        .iter()
        .position(|a| a == "--repeat")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(3)
        .max(1);
    let dir = std::env::var("VUNIFY_MODELS")
        .expect("set VUNIFY_MODELS to the folder of the test models (see the README)");
    let file_of = |m: &str| match m {
        "bunny" => "stanford-bunny.obj".to_string(),
        "dragon" => "stanford-dragon.obj.xz".to_string(),
        "laurana" => "laurana50k-vcolor.obj".to_string(),
        other => format!("{other}.obj"),
    };
    let samples = vunify::measure::DEFAULT_SAMPLES;
    if let Some(cells) = value_of(&args, "--cells").and_then(|s| s.parse::<usize>().ok()) {
        let threads: Vec<usize> = value_of(&args, "--threads")
            .map(|s| s.split(',').filter_map(|t| t.parse().ok()).collect())
            .unwrap_or_else(|| {
                let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
                std::iter::successors(Some(1), |&t| (t < cores).then_some(t * 2)).collect()
            });
        let paths = models
            .iter()
            .map(|m| std::path::Path::new(&dir).join(file_of(m)));
        threads_table(paths, cells, &threads, repeat);
        return;
    }

    println!("## Build: vunify whole tree (qem) vs meshopt::simplify to 1 %\n");
    println!(
        "| model | triangles | vunify build s (passes) | vunify build s (greedy) | meshopt 1 % s | ratio passes / meshopt | vunify peak MiB | B/tri | meshopt peak MiB |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut loaded = Vec::new();
    for m in &models {
        let path = std::path::Path::new(&dir).join(file_of(m));
        let (mesh, _) = match mesh::load(&path, &CleanOptions::default()) {
            Ok(x) => x,
            Err(e) => {
                eprintln!("skipping {m}: {e}");
                continue;
            }
        };
        let t = mesh.triangle_count();
        // The build and meshopt alternate `repeat` times and each time is the median: the machine's
        // load drifts, and alternating puts both under the same drift.
        let mut builds = Vec::new();
        let mut meshopts = Vec::new();
        let (mut tree, mut build_peak, mut mo_peak) = (None, 0, 0);
        for _ in 0..repeat {
            let (t_, s_, p_) = measured(|| {
                vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {})
                    .expect("build")
                    .0
            });
            builds.push(s_);
            (tree, build_peak) = (Some(t_), p_);
            let (_, s_, p_) = measured(|| common::meshopt_simplify(&mesh, t / 100));
            meshopts.push(s_);
            mo_peak = p_;
        }
        let tree = tree.expect("at least one run");
        let (build_s, mo_s) = (median(&mut builds), median(&mut meshopts));
        let greedy = BuildOptions {
            schedule: vtree::Schedule::Greedy,
            ..Default::default()
        };
        let (greedy_tree, greedy_s, _) = measured(|| {
            vtree::build(&mesh, &greedy, &mut |_, _| {})
                .expect("build")
                .0
        });
        println!(
            "| {m} | {t} | {build_s:.3} | {greedy_s:.3} | {mo_s:.3} | {:.2}× | {:.1} | {:.0} | {:.1} |",
            build_s / mo_s,
            build_peak as f64 / 1048576.0,
            build_peak as f64 / t as f64,
            mo_peak as f64 / 1048576.0
        );
        loaded.push((m.clone(), mesh, tree, greedy_tree));
    }

    if !flag("--skip-quality") {
        quality_table(&loaded, samples);
    }
    if !flag("--skip-metrics") {
        metrics_table(&loaded, samples);
    }
}

/// A model, its tree and its greedy-schedule tree.
type Loaded = (
    String,
    vunify::mesh::Mesh,
    vtree::VertexTree,
    vtree::VertexTree,
);

/// Hausdorff distance of `extract` against meshopt at the same triangle count. A mesh with vertex
/// colours gets two rows a level, each against the peer doing the same job: the tree built from
/// shape alone (`--color-weight 0`) against `meshopt::simplify`, and the default tree, which weighs
/// colour, against `meshopt::simplify_with_attributes` with the colours at weight 1.
fn quality_table(loaded: &[Loaded], samples: usize) {
    println!(
        "\n## Quality: Hausdorff distance (% of bbox diagonal) of `extract` vs meshopt at the same triangle count\n"
    );
    println!(
        "| model | level | triangles | vunify mean | meshopt mean | mean ratio | vunify max | meshopt max | max ratio | greedy mean / max |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (m, mesh, tree, greedy_tree) in loaded {
        let shape_only = mesh.colors.is_some().then(|| {
            let options = BuildOptions {
                color_weight: 0.0,
                ..Default::default()
            };
            let shape = |schedule| {
                let options = BuildOptions {
                    schedule,
                    ..options
                };
                vtree::build(mesh, &options, &mut |_, _| {})
                    .expect("build")
                    .0
            };
            (
                shape(vtree::Schedule::Passes),
                shape(vtree::Schedule::Greedy),
            )
        });
        for (label, ratio) in [("10 %", 0.10), ("1 %", 0.01)] {
            let target = (mesh.triangle_count() as f64 * ratio) as usize;
            match &shape_only {
                None => {
                    let peer = common::meshopt_simplify(mesh, target);
                    quality_row(m, label, mesh, [tree, greedy_tree], &peer, samples);
                }
                Some((tree0, greedy0)) => {
                    let peer = common::meshopt_simplify(mesh, target);
                    let shape = format!("{label}, shape only");
                    quality_row(m, &shape, mesh, [tree0, greedy0], &peer, samples);
                    let peer = common::meshopt_with_colours(mesh, target);
                    let colour = format!("{label}, with colour");
                    quality_row(m, &colour, mesh, [tree, greedy_tree], &peer, samples);
                }
            }
        }
    }
}

/// One row of the quality table: the tree's and the greedy tree's cuts at the peer's count.
fn quality_row(
    m: &str,
    label: &str,
    mesh: &vunify::mesh::Mesh,
    [tree, greedy_tree]: [&vtree::VertexTree; 2],
    peer: &vunify::mesh::Mesh,
    samples: usize,
) {
    let cut = vtree::cut_at_triangles(tree, peer.triangle_count() as u32);
    let hv = vunify::measure::hausdorff(mesh, &cut.mesh, samples).symmetric;
    let hm = vunify::measure::hausdorff(mesh, peer, samples).symmetric;
    let gcut = vtree::cut_at_triangles(greedy_tree, peer.triangle_count() as u32);
    let hg = vunify::measure::hausdorff(mesh, &gcut.mesh, samples).symmetric;
    println!(
        "| {m} | {label} | {} / {} | {:.4} | {:.4} | {:.2} | {:.4} | {:.4} | {:.2} | {:.4} / {:.4} |",
        cut.mesh.triangle_count(),
        peer.triangle_count(),
        100.0 * hv.mean,
        100.0 * hm.mean,
        hv.mean / hm.mean.max(1e-12),
        100.0 * hv.max,
        100.0 * hm.max,
        hv.max / hm.max.max(1e-12),
        100.0 * hg.mean,
        100.0 * hg.max
    );
}

/// The four metrics side by side, at 10 % and 1 %.
fn metrics_table(loaded: &[Loaded], samples: usize) {
    println!(
        "\n## The four metrics (Chen's comparison of metrics): Hausdorff mean / max (% of diagonal), build seconds\n"
    );
    println!("| model | level | qem | qem-midpoint | edge-length | hybrid |");
    println!("|---|---|---|---|---|---|");
    for (m, mesh, _, _) in loaded {
        let metrics = [
            Metric::Qem,
            Metric::QemMidpoint,
            Metric::EdgeLength,
            Metric::Hybrid,
        ];
        let trees: Vec<(vtree::VertexTree, f64)> = metrics
            .iter()
            .map(|&metric| {
                let o = BuildOptions {
                    metric,
                    ..Default::default()
                };
                let (tree, s, _) =
                    measured(|| vtree::build(mesh, &o, &mut |_, _| {}).expect("build").0);
                (tree, s)
            })
            .collect();
        for (label, ratio) in [("10 %", 0.10), ("1 %", 0.01)] {
            let target = (mesh.triangle_count() as f64 * ratio) as u32;
            let cells: Vec<String> = trees
                .iter()
                .map(|(tree, s)| {
                    let cut = vtree::cut_at_triangles(tree, target);
                    let h = vunify::measure::hausdorff(mesh, &cut.mesh, samples).symmetric;
                    format!("{:.4} / {:.3} ({s:.2} s)", 100.0 * h.mean, 100.0 * h.max)
                })
                .collect();
            println!("| {m} | {label} | {} |", cells.join(" | "));
        }
    }
}

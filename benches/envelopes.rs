//! Simplification within a certified distance: `bounded` against meshoptimizer tuned until the
//! certified meter confirms its result within ε both ways (bisecting its triangle target), in one
//! run on the same machine.
//!
//!     VUNIFY_MODELS=… cargo bench --bench envelopes -- --models cow,bunny --epsilon 0.01
//!
//! With `--paper`, Zou, Shen and Peng's Table 3 instead: every method (`offset-patch`,
//! `single-envelope`, `cohen`, `bounded`) at each ε of `--epsilons` (default 1, 2, 3 %), with its
//! triangles, seconds (the library call, the model already loaded) and both certified upper bounds.
//!
//!     VUNIFY_MODELS=… cargo bench --bench envelopes -- --paper --models cow,bunny

mod common;

use std::time::Instant;
use vunify::measure::{CertifyOptions, certified_hausdorff};
use vunify::mesh::Mesh;
use vunify::simplify::bounded::{BoundedOptions, simplify_bounded};
use vunify::simplify::envelope::{EnvelopeOptions, Method, simplify_envelope};

/// The larger certified upper bound of the two directions, as a fraction of the diagonal.
fn certified(mesh: &Mesh, other: &Mesh) -> f64 {
    let (forward, backward) = certified_both(mesh, other);
    forward.max(backward)
}

/// Both certified upper bounds (input → output, output → input), as fractions of the diagonal.
fn certified_both(mesh: &Mesh, other: &Mesh) -> (f64, f64) {
    let options = CertifyOptions {
        relative: 1e-3,
        ..Default::default()
    };
    match certified_hausdorff(mesh, other, &options) {
        Ok(c) => (c.forward.upper, c.backward.upper),
        Err(_) => (f64::INFINITY, f64::INFINITY),
    }
}

fn paper_table(models: &str, epsilons: &str) {
    for name in models.split(',') {
        let Some(mesh) = common::model_or_skip(name) else {
            continue;
        };
        println!("\n{name} ({} triangles)\n", mesh.triangle_count());
        println!("| ε | method | triangles | seconds | input → output | output → input |");
        println!("|---:|---|---:|---:|---:|---:|");
        for epsilon in epsilons
            .split(',')
            .map(|e| e.parse::<f64>().expect("--epsilons"))
        {
            for method in [
                Some(Method::OffsetPatch),
                Some(Method::SingleEnvelope),
                Some(Method::Cohen),
                None,
            ] {
                let t0 = Instant::now();
                let out = match method {
                    Some(method) => {
                        let options = EnvelopeOptions {
                            method,
                            epsilon,
                            target_triangles: 0,
                        };
                        simplify_envelope(&mesh, &options, &mut |_| {})
                            .expect("simplifies")
                            .0
                    }
                    None => {
                        let options = BoundedOptions {
                            epsilon,
                            target_triangles: 0,
                        };
                        simplify_bounded(&mesh, &options, &mut |_| {})
                            .expect("simplifies")
                            .0
                    }
                };
                let seconds = t0.elapsed().as_secs_f64();
                let (forward, backward) = certified_both(&mesh, &out);
                println!(
                    "| {} % | {} | {} | {seconds:.2} | ≤ {:.3} % | ≤ {:.3} % |",
                    100.0 * epsilon,
                    method.map_or("bounded", Method::name),
                    out.triangle_count(),
                    100.0 * forward,
                    100.0 * backward
                );
            }
        }
    }
}

fn main() {
    let models = common::arg("--models", "cow,beetle,bunny");
    if std::env::args().any(|a| a == "--paper") {
        paper_table(&models, &common::arg("--epsilons", "0.01,0.02,0.03"));
        return;
    }
    let epsilon: f64 = common::arg("--epsilon", "0.01").parse().expect("--epsilon");
    println!(
        "| model | triangles | bounded triangles | bounded s | bounded certified | meshopt tuned triangles | meshopt certified |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for name in models.split(',') {
        let Some(mesh) = common::model_or_skip(name) else {
            continue;
        };
        let t0 = Instant::now();
        let options = BoundedOptions {
            epsilon,
            target_triangles: 0,
        };
        let (out, _) = simplify_bounded(&mesh, &options, &mut |_| {}).expect("simplifies");
        let seconds = t0.elapsed().as_secs_f64();
        let ours = certified(&mesh, &out);
        // The fewest triangles at which meshoptimizer's result is certified within ε: bisection
        // on its target (its quality is not strictly monotone in the target, so this is the
        // fewest the bisection met).
        let (mut lo, mut hi) = (1usize, mesh.triangle_count());
        let mut best = (mesh.triangle_count(), 0.0);
        while lo < hi {
            let mid = (lo + hi) / 2;
            let m = common::meshopt_simplify(&mesh, mid);
            let d = certified(&mesh, &m);
            if d <= epsilon {
                best = (m.triangle_count(), d);
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        println!(
            "| {name} | {} | {} | {seconds:.2} | {:.4} % | {} | {:.4} % |",
            mesh.triangle_count(),
            out.triangle_count(),
            100.0 * ours,
            best.0,
            100.0 * best.1
        );
    }
}

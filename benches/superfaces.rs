//! Liu and Wu's Figs. 8–11: the simplification ratio of `vunify superfaces` against ε (δ = 2) and
//! against δ (ε = 0.8), for lit meshes made by `vunify radiosity`; a table on stdout and two PNG
//! plots. Also the time of each run (the bar: a 100,000-triangle lit mesh in ≤ 1 s).
//!
//!     vunify radiosity assets/scenes/room.obj -o room.ply
//!     vunify radiosity assets/scenes/office.obj -o office.ply
//!     cargo bench --bench superfaces -- --lit room.ply,office.ply --out docs

mod common;

use plotters::prelude::*;
use std::path::{Path, PathBuf};
use vunify::mesh::{CleanOptions, Mesh, load};
use vunify::radiosity::superfaces::{SuperfaceOptions, simplify_superfaces};

const EPSILONS: [f64; 10] = [0.02, 0.04, 0.06, 0.08, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8];
const DELTAS: [f64; 8] = [1.0, 2.0, 4.0, 8.0, 16.0, 25.0, 35.0, 50.0];

/// Output triangles over input triangles, and seconds.
fn ratio(mesh: &Mesh, epsilon: f64, delta: f64) -> (f64, f64) {
    let options = SuperfaceOptions {
        epsilon,
        delta,
        distance: 0.0,
        discs: false,
    };
    let (_, s) = simplify_superfaces(mesh, &options).expect("a lit mesh");
    (s.ratio, s.seconds)
}

fn plot(
    file: &Path,
    title: &str,
    x_label: &str,
    xs: &[f64],
    series: &[(String, Vec<f64>)],
) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::new(file, (800, 500)).into_drawing_area();
    root.fill(&WHITE)?;
    let x_max = xs.iter().copied().fold(0.0, f64::max);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 24))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..x_max * 1.02, 0.0..100.0)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc("triangles kept (%)")
        .label_style(("sans-serif", 16))
        .draw()?;
    for (i, (name, ys)) in series.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(
                xs.iter().zip(ys).map(|(x, y)| (*x, 100.0 * y)),
                colour.stroke_width(2),
            ))?
            .label(name.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        chart.draw_series(
            xs.iter()
                .zip(ys)
                .map(|(x, y)| Circle::new((*x, 100.0 * y), 3, colour.filled())),
        )?;
    }
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 16))
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .draw()?;
    root.present()?;
    Ok(())
}

fn main() {
    plotters::style::register_font(
        "sans-serif",
        FontStyle::Normal,
        epaint_default_fonts::UBUNTU_LIGHT,
    )
    .map_err(|_| "font")
    .expect("the bundled font loads");
    let lit = common::arg("--lit", "room.ply,office.ply");
    let out = PathBuf::from(common::arg("--out", "target/superfaces"));
    std::fs::create_dir_all(&out).expect("the output directory");
    let mut by_epsilon = Vec::new();
    let mut by_delta = Vec::new();
    println!("| lit mesh | triangles | curve | parameter | kept | seconds |");
    println!("|---|---:|---|---:|---:|---:|");
    for file in lit.split(',') {
        let (mesh, _) = match load(Path::new(file), &CleanOptions::default()) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("skipping {file}: {e}");
                continue;
            }
        };
        let name = Path::new(file)
            .file_stem()
            .map_or(file.to_string(), |s| s.to_string_lossy().to_string());
        let n = mesh.triangle_count();
        let row = |curve: &str, p: f64, (r, s): (f64, f64)| {
            println!(
                "| {name} | {n} | {curve} | {p} | {:.1} % | {s:.3} |",
                100.0 * r
            );
            r
        };
        let e: Vec<f64> = EPSILONS
            .iter()
            .map(|&x| row("ε (δ = 2)", x, ratio(&mesh, x, 2.0)))
            .collect();
        let d: Vec<f64> = DELTAS
            .iter()
            .map(|&x| row("δ (ε = 0.8)", x, ratio(&mesh, 0.8, x)))
            .collect();
        by_epsilon.push((name.clone(), e));
        by_delta.push((name, d));
    }
    let a = out.join("superfaces-ratio-epsilon.png");
    let b = out.join("superfaces-ratio-delta.png");
    plot(
        &a,
        "Superfaces: triangles kept against ε (δ = 2)",
        "ε",
        &EPSILONS,
        &by_epsilon,
    )
    .expect("the ε plot");
    plot(
        &b,
        "Superfaces: triangles kept against δ (ε = 0.8)",
        "δ (0–255)",
        &DELTAS,
        &by_delta,
    )
    .expect("the δ plot");
    println!("\nwrote {} and {}", a.display(), b.display());
}

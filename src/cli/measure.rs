//! `vunify measure`: the symmetric Hausdorff distance between two meshes.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use vunify::mesh::{self, CleanOptions};

#[derive(Args)]
pub struct MeasureArgs {
    /// The reference mesh; distances are fractions of its bounding-box diagonal.
    original: PathBuf,
    /// The mesh to compare with it.
    simplified: PathBuf,
    /// Minimum number of surface samples on each mesh (every vertex is sampled, plus points along
    /// edges and inside faces).
    #[arg(long, default_value_t = vunify::measure::DEFAULT_SAMPLES)]
    samples: usize,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

pub fn run(args: MeasureArgs) -> Result<()> {
    let options = CleanOptions::default();
    let (a, _) = mesh::load(&args.original, &options)?;
    let (b, _) = mesh::load(&args.simplified, &options)?;
    let h = vunify::measure::hausdorff(&a, &b, args.samples.max(1));
    if args.json {
        println!("{}", serde_json::to_string_pretty(&h)?);
        return Ok(());
    }
    println!(
        "Hausdorff distance, as % of the original's bounding-box diagonal ({:.6}):",
        h.diagonal
    );
    println!(
        "              {:>10} {:>10} {:>10} {:>10}",
        "max", "mean", "RMS", "samples"
    );
    for (name, s) in [
        ("original→simp", h.forward),
        ("simp→original", h.backward),
        ("symmetric", h.symmetric),
    ] {
        println!(
            "{name:<14}{:>9.4}% {:>9.4}% {:>9.4}% {:>10}",
            100.0 * s.max,
            100.0 * s.mean,
            100.0 * s.rms,
            s.samples
        );
    }
    Ok(())
}

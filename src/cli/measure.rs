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
    /// Certified bounds instead of samples: for each direction a lower and an upper bound that the
    /// true one-sided Hausdorff distance is proven to lie between (branch and bound over triangles;
    /// docs/ENVELOPES.md). Slower than sampling on large meshes.
    #[arg(long)]
    certified: bool,
    /// With --certified: stop when the bounds are within this fraction of the lower bound.
    #[arg(long, default_value_t = vunify::measure::CertifyOptions::default().relative, requires = "certified")]
    tolerance: f64,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

pub fn run(args: MeasureArgs) -> Result<()> {
    let options = CleanOptions::default();
    let (a, _) = mesh::load(&args.original, &options)?;
    let (b, _) = mesh::load(&args.simplified, &options)?;
    if args.certified {
        return certified(&args, &a, &b);
    }
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

/// `--certified`: bounds on both one-sided distances.
fn certified(args: &MeasureArgs, a: &vunify::mesh::Mesh, b: &vunify::mesh::Mesh) -> Result<()> {
    if !(args.tolerance > 0.0 && args.tolerance < 1.0) {
        anyhow::bail!(
            "--tolerance must be between 0 and 1, got {}",
            args.tolerance
        );
    }
    let options = vunify::measure::CertifyOptions {
        relative: args.tolerance,
        ..Default::default()
    };
    let t0 = std::time::Instant::now();
    let c = vunify::measure::certified_hausdorff(a, b, &options).map_err(|e| {
        anyhow::anyhow!(
            "{} / {}: {e}",
            args.original.display(),
            args.simplified.display()
        )
    })?;
    let seconds = t0.elapsed().as_secs_f64();
    if args.json {
        let mut j = serde_json::to_value(c)?;
        j["seconds"] = seconds.into();
        println!("{}", serde_json::to_string_pretty(&j)?);
        return Ok(());
    }
    println!(
        "Certified Hausdorff distance, as % of the first mesh's bounding-box diagonal ({:.6}):",
        c.diagonal
    );
    println!(
        "              {:>12} {:>12}  {:>9}",
        "lower", "upper", "splits"
    );
    for (name, s) in [("A → B", c.forward), ("B → A", c.backward)] {
        println!(
            "{name:<14}{:>11.5}% {:>11.5}%  {:>9}{}",
            100.0 * s.lower,
            100.0 * s.upper,
            s.splits,
            if s.converged {
                ""
            } else {
                "  (split budget spent: the bounds hold but are farther apart than asked)"
            }
        );
    }
    println!(
        "tolerance     {} % of the lower bound, or {} of the diagonal; {seconds:.2} s",
        100.0 * c.options.relative,
        c.options.absolute
    );
    Ok(())
}

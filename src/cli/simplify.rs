//! `vunify simplify`: a static simplification with a certified distance.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;
use vunify::mesh::{self, CleanOptions};
use vunify::simplify::bounded::{BoundedOptions, simplify_bounded};

#[derive(Clone, Copy, clap::ValueEnum)]
enum Method {
    /// Edge collapses in quadric order, each accepted only when the result is certified within ε
    /// of the input in both directions (docs/ENVELOPES.md).
    Bounded,
}

#[derive(Args)]
pub struct SimplifyArgs {
    /// Input mesh (.obj, .ply, .off, optionally .xz).
    input: PathBuf,
    /// Output mesh, written atomically (.obj).
    #[arg(short, long)]
    output: PathBuf,
    /// How to simplify. (The offset-patch, single-envelope and Cohen envelope methods are not built
    /// yet.)
    #[arg(long, value_enum, default_value_t = Method::Bounded)]
    method: Method,
    /// ε: the largest distance allowed between input and output, both ways, as a fraction of the
    /// input's bounding-box diagonal.
    #[arg(long, default_value_t = 0.01)]
    epsilon: f64,
    /// Stop at this many triangles (default: as few as ε allows).
    #[arg(long)]
    target_triangles: Option<usize>,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: SimplifyArgs) -> Result<()> {
    if !(args.epsilon > 0.0 && args.epsilon < 1.0) {
        bail!(
            "--epsilon must be between 0 and 1 (a fraction of the diagonal), got {}",
            args.epsilon
        );
    }
    let Method::Bounded = args.method;
    let (mesh, _) = mesh::load(&args.input, &CleanOptions::default())?;
    let options = BoundedOptions {
        epsilon: args.epsilon,
        target_triangles: args.target_triangles.unwrap_or(0),
    };
    let bar = super::progress_bar(
        mesh.triangle_count() as u64,
        "simplifying [{bar:40}] {msg} triangles ({elapsed})",
    );
    let total = mesh.triangle_count();
    let (out, stats) = simplify_bounded(&mesh, &options, &mut |now| {
        bar.set_position((total - now) as u64);
        bar.set_message(now.to_string());
    })
    .map_err(|e| anyhow::anyhow!("{}: {e}", args.input.display()))?;
    bar.finish_and_clear();
    vunify::export::write_obj(&out, &args.output)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    if args.json {
        let j = serde_json::json!({
            "input": args.input, "output": args.output, "method": "bounded",
            "epsilon": args.epsilon, "input_triangles": total, "triangles": stats.triangles,
            "seconds": stats.seconds, "collapses_tried": stats.collapses_tried,
            "collapses_accepted": stats.collapses_accepted, "certified_checks": stats.checks,
        });
        println!("{}", serde_json::to_string_pretty(&j)?);
        return Ok(());
    }
    println!(
        "{} → {} triangles within ε = {} % of the diagonal, both ways (certified), in {:.2} s",
        total,
        stats.triangles,
        100.0 * args.epsilon,
        stats.seconds
    );
    println!(
        "collapses  {} tried, {} accepted; {} certified checks",
        stats.collapses_tried, stats.collapses_accepted, stats.checks
    );
    println!("wrote      {}", args.output.display());
    Ok(())
}

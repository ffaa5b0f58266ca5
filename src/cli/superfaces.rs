//! `vunify superfaces`: a lit mesh simplified the way of Liu and Wu's paper (docs/RADIOSITY.md).

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;
use vunify::mesh::{self, CleanOptions};
use vunify::radiosity::superfaces::{SuperfaceOptions, simplify_superfaces};

#[derive(Args)]
pub struct SuperfacesArgs {
    /// The lit mesh, with vertex colours (the PLY or OBJ of `vunify radiosity`).
    input: PathBuf,
    /// Output mesh, written atomically: .ply, .obj or .off (optionally .xz), .glb or .gltf.
    #[arg(short, long)]
    output: PathBuf,
    /// ε: patches merge while their relative radiosity change, over areas in units of the mean
    /// triangle, stays below it (the paper's range: 0.06–0.8).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.1)]
    epsilon: f64,
    /// δ: a boundary vertex goes when its colour is within δ (0–255) of its new edge's.
    #[arg(long, allow_negative_numbers = true, default_value_t = 2.0)]
    delta: f64,
    /// ... and it lies within this share of the diagonal of the new edge (0: only vertices on a
    /// straight line).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    distance: f64,
    /// Keep every superface a disc: a superface does not close round another, so no hole is
    /// bridged (the paper lets them; more triangles, but smoother gradients on the bundled scenes).
    #[arg(long)]
    discs: bool,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: SuperfacesArgs) -> Result<()> {
    for (option, value) in [
        ("--epsilon", args.epsilon),
        ("--delta", args.delta),
        ("--distance", args.distance),
    ] {
        if !(value >= 0.0 && value.is_finite()) {
            bail!("{option} must be a finite number, at least 0, got {value}");
        }
    }
    if mesh::Format::from_path(&args.output).is_none() {
        bail!(
            "{}: the output name must end in .obj, .ply, .off (optionally .xz), .glb or .gltf",
            args.output.display()
        );
    }
    let (lit, _) = mesh::load(&args.input, &CleanOptions::default())?;
    let options = SuperfaceOptions {
        epsilon: args.epsilon,
        delta: args.delta,
        distance: args.distance,
        discs: args.discs,
    };
    let (out, s) = simplify_superfaces(&lit, &options)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.input.display()))?;
    vunify::export::write_mesh(&out, &args.output)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    if args.json {
        let mut j = serde_json::to_value(s)?;
        if let Some(o) = j.as_object_mut() {
            o.insert("epsilon".into(), args.epsilon.into());
            o.insert("delta".into(), args.delta.into());
        }
        println!("{}", serde_json::to_string_pretty(&j)?);
        return Ok(());
    }
    println!(
        "{} → {} triangles ({:.1} %) in {} superfaces ({} holes), ε = {}, δ = {}, in {:.3} s",
        s.triangles_in,
        s.triangles_out,
        100.0 * s.ratio,
        s.superfaces,
        s.holes,
        args.epsilon,
        args.delta,
        s.seconds
    );
    println!(
        "colour     off the lit mesh by at most {:.2} % (mean {:.3} %), relative, at its vertices",
        100.0 * s.color_error_max,
        100.0 * s.color_error_mean
    );
    println!("wrote      {}", args.output.display());
    Ok(())
}

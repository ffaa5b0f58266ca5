//! `vunify radiosity`: a scene lit once, by progressive refinement radiosity, written as a lit mesh.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;
use vunify::radiosity::{RadiosityOptions, Scene, output, solve};

#[derive(Args)]
pub struct RadiosityArgs {
    /// The scene: OBJ with an MTL library (Kd diffuse reflectance, Ke emitted radiant exitance).
    scene: PathBuf,
    /// The lit mesh, written atomically: .ply (float radiosity and 8-bit display colours per vertex,
    /// element radiosity per face) or .obj (`v x y z r g b`, display colours).
    #[arg(short, long)]
    output: PathBuf,
    /// Stop when the unshot power is below this share of the emitted power.
    #[arg(long, default_value_t = RadiosityOptions::default().unshot)]
    unshot: f64,
    /// Longest element edge before adaptive subdivision, as a share of the scene's diagonal.
    #[arg(long, default_value_t = RadiosityOptions::default().element_size)]
    element_size: f64,
    /// Adaptive subdivision stops at elements this long (share of the diagonal).
    #[arg(long, default_value_t = RadiosityOptions::default().min_element_size)]
    min_element_size: f64,
    /// No more subdivision beyond this many elements.
    #[arg(long, default_value_t = RadiosityOptions::default().max_elements)]
    max_elements: usize,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: RadiosityArgs) -> Result<()> {
    if !(args.unshot > 0.0 && args.unshot < 1.0) {
        bail!("--unshot must be between 0 and 1, got {}", args.unshot);
    }
    if !(args.min_element_size > 0.0 && args.min_element_size <= args.element_size) {
        bail!("--min-element-size must be positive and at most --element-size");
    }
    let is_mesh = args
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("ply") || e.eq_ignore_ascii_case("obj"));
    if !is_mesh {
        bail!(
            "{}: the output must end in .ply or .obj",
            args.output.display()
        );
    }
    let scene = Scene::load(&args.scene)?;
    for note in &scene.notes {
        eprintln!("note: {note}");
    }
    let options = RadiosityOptions {
        unshot: args.unshot,
        element_size: args.element_size,
        min_element_size: args.min_element_size,
        max_elements: args.max_elements,
        ..Default::default()
    };
    let bar = super::progress_bar(1000, "radiosity [{bar:40}] {msg} ({elapsed})");
    let solution = solve(&scene, &options, &mut |share, what| {
        bar.set_position((share * 1000.0) as u64);
        bar.set_message(what.to_string());
    });
    bar.finish_and_clear();
    let emitting: Vec<bool> = scene.polygons.iter().map(|p| scene.emits(p)).collect();
    let exposure = output::write(&solution, &emitting, &args.output)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    let s = solution.stats;
    if args.json {
        let j = serde_json::json!({
            "scene": args.scene, "output": args.output, "polygons": scene.polygons.len(),
            "patches": s.patches, "elements": s.elements, "vertices": s.vertices, "shots": s.shots,
            "unshot": s.unshot, "seconds": s.seconds, "exposure": exposure,
        });
        println!("{}", serde_json::to_string_pretty(&j)?);
        return Ok(());
    }
    println!(
        "{}: {} polygons → {} elements ({} vertices) on {} patches",
        args.scene.display(),
        scene.polygons.len(),
        s.elements,
        s.vertices,
        s.patches
    );
    println!(
        "shots      {} in {:.2} s; unshot {:.3} % of the emitted power",
        s.shots,
        s.seconds,
        100.0 * s.unshot
    );
    println!(
        "wrote      {} (display exposure {exposure:.4})",
        args.output.display()
    );
    Ok(())
}

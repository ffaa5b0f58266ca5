//! `vunify radiosity`: a scene lit once, by progressive refinement radiosity, written as a lit mesh.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use vunify::radiosity::{RadiosityOptions, Scene, output, solve::solve_until};

#[derive(Args)]
pub struct RadiosityArgs {
    /// The scene: OBJ with an MTL library (Kd diffuse reflectance, Ke emitted radiant exitance).
    scene: PathBuf,
    /// The lit mesh, written atomically: .ply (float radiosity and 8-bit display colours per vertex,
    /// element radiosity per face) or .obj (`v x y z r g b`, display colours).
    #[arg(short, long)]
    output: PathBuf,
    /// Stop when the unshot power is below this share of the emitted power.
    #[arg(long, allow_negative_numbers = true, default_value_t = RadiosityOptions::default().unshot)]
    unshot: f64,
    /// Longest element edge before adaptive subdivision, as a share of the scene's diagonal.
    #[arg(long, allow_negative_numbers = true, default_value_t = RadiosityOptions::default().element_size)]
    element_size: f64,
    /// Adaptive subdivision stops at elements this long (share of the diagonal).
    #[arg(long, allow_negative_numbers = true, default_value_t = RadiosityOptions::default().min_element_size)]
    min_element_size: f64,
    /// No more subdivision beyond this many elements.
    #[arg(long, default_value_t = RadiosityOptions::default().max_elements)]
    max_elements: usize,
    /// Stop shooting after this many seconds and write the result as it stands, with its unshot
    /// share and the ambient term (Ctrl-C does the same at any time).
    #[arg(long, allow_negative_numbers = true)]
    max_seconds: Option<f64>,
    /// Stop after this many shots and write the result as it stands.
    #[arg(long, default_value_t = RadiosityOptions::default().max_shots)]
    max_shots: usize,
    /// Plain progressive refinement: no overshooting (slower to converge in bright rooms).
    #[arg(long)]
    no_overshoot: bool,
    /// Leave out the ambient term (the estimate of the light still unshot, added to every element).
    #[arg(long)]
    no_ambient: bool,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// Set by Ctrl-C: the solution stops shooting and is written as it stands.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

pub fn run(args: RadiosityArgs) -> Result<()> {
    if !(args.unshot > 0.0 && args.unshot < 1.0) {
        bail!("--unshot must be between 0 and 1, got {}", args.unshot);
    }
    if !(args.element_size > 0.0 && args.element_size < 1.0) {
        bail!(
            "--element-size must be between 0 and 1 (a share of the diagonal), got {}",
            args.element_size
        );
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
    if args
        .max_seconds
        .is_some_and(|s| !(s >= 0.0 && s.is_finite()))
    {
        bail!(
            "--max-seconds must be a finite number of seconds, at least 0, got {}",
            args.max_seconds.unwrap_or_default()
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
        max_shots: args.max_shots,
        max_seconds: args.max_seconds.unwrap_or(f64::INFINITY),
        overshoot: !args.no_overshoot,
        ambient: !args.no_ambient,
        ..Default::default()
    };
    super::on_interrupt(&INTERRUPTED);
    let bar = super::progress_bar(1000, "radiosity [{bar:40}] {msg} ({elapsed})");
    let mut log = super::ProgressLog::new("radiosity");
    let solution = solve_until(
        &scene,
        &options,
        &mut |share, what| {
            bar.set_position((share * 1000.0) as u64);
            bar.set_message(what.to_string());
            log.say(what);
        },
        &INTERRUPTED,
    );
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
            "stop": s.stop, "ambient": s.ambient,
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
        "shots      {} in {:.2} s, {}; unshot {:.3} % of the emitted power",
        s.shots,
        s.seconds,
        s.stop.describe(),
        100.0 * s.unshot
    );
    // Rounding leaves a spent scene's ambient a hair below zero: shown as 0, not "-0.0000".
    let [r, g, b] = s.ambient.map(|x| if x.abs() < 5e-5 { 0.0 } else { x });
    if [r, g, b] != [0.0; 3] {
        println!("ambient    ({r:.4}, {g:.4}, {b:.4}) added, times each surface's reflectance");
    }
    if INTERRUPTED.load(Ordering::Relaxed) {
        eprintln!("interrupted: the result as it stood was written");
    }
    println!(
        "wrote      {} (display exposure {exposure:.4})",
        args.output.display()
    );
    Ok(())
}

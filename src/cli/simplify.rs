//! `vunify simplify`: a static simplification within a distance — certified both ways (`bounded`) or
//! inside one of the envelopes of Zou, Shen and Peng (`offset-patch`, `single-envelope`, `cohen`).

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use vunify::measure::{Bounds, Certified, CertifyOptions, certified_hausdorff};
use vunify::mesh::{self, CleanOptions, Mesh};
use vunify::simplify::bounded::{BoundedOptions, simplify_bounded};
use vunify::simplify::envelope::{self, EnvelopeOptions, simplify_envelope};

#[derive(Clone, Copy, PartialEq, clap::ValueEnum)]
enum Method {
    /// Edge collapses in quadric order, each accepted only when the result is certified within ε
    /// of the input in both directions (docs/ENVELOPES.md). The one to use.
    Bounded,
    /// Zou, Shen and Peng (2005): triangle collapses to the centroid, each kept only between two
    /// local offset patches of its ring, offsets found by bisection. Bounds output → input, per step.
    OffsetPatch,
    /// The same authors' earlier method: triangle collapses inside one whole inner envelope.
    SingleEnvelope,
    /// Cohen et al., Simplification envelopes (1996): triangle collapses between whole inner and
    /// outer envelopes built first.
    Cohen,
}

#[derive(Args)]
pub struct SimplifyArgs {
    /// Input mesh (.obj, .ply, .off, optionally .xz, .gltf, .glb).
    input: PathBuf,
    /// Output mesh, written atomically: .obj, .ply or .off (optionally .xz), .glb, or .gltf with a
    /// .bin beside it.
    #[arg(short, long)]
    output: PathBuf,
    /// How to simplify.
    #[arg(long, value_enum, default_value_t = Method::Bounded)]
    method: Method,
    /// ε, as a fraction of the input's bounding-box diagonal: for `bounded`, the largest distance
    /// allowed between input and output, both ways; for the envelope methods, the largest offset ε0.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.01)]
    epsilon: f64,
    /// Stop at this many triangles (default: as few as ε allows).
    #[arg(long)]
    target_triangles: Option<usize>,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// What any method reports.
struct Summary {
    triangles: usize,
    seconds: f64,
    json: serde_json::Value,
    lines: Vec<String>,
}

pub fn run(args: SimplifyArgs) -> Result<()> {
    if !(args.epsilon > 0.0 && args.epsilon < 1.0) {
        bail!(
            "--epsilon must be between 0 and 1 (a fraction of the diagonal), got {}",
            args.epsilon
        );
    }
    if vunify::mesh::Format::from_path(&args.output).is_none() {
        bail!(
            "{}: the output name must end in .obj, .ply, .off (optionally .xz), .glb or .gltf",
            args.output.display()
        );
    }
    let (mesh, _) = mesh::load(&args.input, &CleanOptions::default())?;
    let total = mesh.triangle_count();
    let bar = super::progress_bar(
        total as u64,
        "simplifying [{bar:40}] {msg} triangles ({elapsed})",
    );
    let mut progress = |now: usize| {
        bar.set_position((total - now) as u64);
        bar.set_message(now.to_string());
    };
    let target_triangles = args.target_triangles.unwrap_or(0);
    let (out, summary) = match args.method {
        Method::Bounded => {
            let options = BoundedOptions {
                epsilon: args.epsilon,
                target_triangles,
            };
            let (out, s) = simplify_bounded(&mesh, &options, &mut progress)
                .map_err(|e| anyhow::anyhow!("{}: {e}", args.input.display()))?;
            let summary = Summary {
                triangles: s.triangles,
                seconds: s.seconds,
                json: serde_json::json!({
                    "collapses_tried": s.collapses_tried,
                    "collapses_accepted": s.collapses_accepted, "certified_checks": s.checks,
                }),
                lines: vec![
                    "bound      both ways, each collapse certified".into(),
                    format!(
                        "collapses  {} tried, {} accepted; {} certified checks",
                        s.collapses_tried, s.collapses_accepted, s.checks
                    ),
                ],
            };
            (out, summary)
        }
        method => {
            let method = match method {
                Method::OffsetPatch => envelope::Method::OffsetPatch,
                Method::SingleEnvelope => envelope::Method::SingleEnvelope,
                _ => envelope::Method::Cohen,
            };
            let options = EnvelopeOptions {
                method,
                epsilon: args.epsilon,
                target_triangles,
            };
            let (out, s) = simplify_envelope(&mesh, &options, &mut progress)
                .map_err(|e| anyhow::anyhow!("{}: {e}", args.input.display()))?;
            (out, envelope_summary(&s))
        }
    };
    bar.finish_and_clear();
    let reached = certify(&mesh, &out, args.epsilon)?;
    let within = reached.forward.within == Some(true) && reached.backward.within == Some(true);
    if args.method == Method::Bounded && !within {
        bail!(
            "{}: the result could not be confirmed within ε = {} % by the certified meter \
             (input → output {}, output → input {}); nothing was written",
            args.input.display(),
            100.0 * args.epsilon,
            interval(&reached.forward),
            interval(&reached.backward)
        );
    }
    vunify::export::write_mesh(&out, &args.output)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    report(&args, total, summary, &reached)
}

/// Prints what a run did (text or `--json`), with the certified distance it reached.
fn report(args: &SimplifyArgs, total: usize, summary: Summary, reached: &Certified) -> Result<()> {
    let within = reached.forward.within == Some(true) && reached.backward.within == Some(true);
    let name = args
        .method
        .to_possible_value()
        .map(|v| v.get_name().to_owned());
    if args.json {
        let mut j = serde_json::json!({
            "input": args.input, "output": args.output, "method": name,
            "epsilon": args.epsilon, "input_triangles": total, "triangles": summary.triangles,
            "seconds": summary.seconds,
        });
        if let (Some(j), Some(extra)) = (j.as_object_mut(), summary.json.as_object()) {
            j.extend(extra.clone());
        }
        let side = |b: &Bounds| serde_json::json!({ "lower": b.lower, "upper": b.upper, "within_epsilon": b.within });
        j["certified"] = serde_json::json!({
            "input_to_output": side(&reached.forward),
            "output_to_input": side(&reached.backward),
            "within_epsilon_both_ways": within,
        });
        println!("{}", serde_json::to_string_pretty(&j)?);
        return Ok(());
    }
    println!(
        "{} → {} triangles, {}, ε = {} % of the diagonal, in {:.2} s",
        total,
        summary.triangles,
        name.unwrap_or_default(),
        100.0 * args.epsilon,
        summary.seconds
    );
    for line in summary.lines {
        println!("{line}");
    }
    println!(
        "certified  input → output {}, output → input {} of the diagonal: {}",
        interval(&reached.forward),
        interval(&reached.backward),
        if within {
            "within ε both ways"
        } else {
            "NOT within ε both ways"
        }
    );
    println!("wrote      {}", args.output.display());
    Ok(())
}

/// The distance the result reached, both ways, by the certified meter, searched until each side
/// is decided against ε (docs/ENVELOPES.md).
fn certify(input: &Mesh, output: &Mesh, epsilon: f64) -> Result<Certified> {
    if output.triangles.is_empty() {
        bail!("the result has no triangles left");
    }
    let options = CertifyOptions {
        epsilon: Some(epsilon),
        ..Default::default()
    };
    Ok(certified_hausdorff(input, output, &options)?)
}

/// `≤ 0.98 %`, or `0.50–0.98 %` where the lower bound is worth giving.
fn interval(b: &Bounds) -> String {
    if b.within == Some(true) {
        format!("≤ {:.4} %", 100.0 * b.upper)
    } else {
        format!("{:.4}–{:.4} %", 100.0 * b.lower, 100.0 * b.upper)
    }
}

fn envelope_summary(s: &envelope::EnvelopeStats) -> Summary {
    let mut lines = vec![
        "bound      each collapse kept inside the envelope (output → input, not certified)".into(),
        format!(
            "collapses  {} tried, {} accepted; refused before the envelope: {} frozen (boundary or \
             non-manifold), {} topology, {} folds",
            s.collapses_tried,
            s.collapses_accepted,
            s.refused_frozen,
            s.refused_topology,
            s.refused_fold
        ),
        format!("tests      {} triangle–triangle", s.intersection_tests),
    ];
    if s.method != envelope::Method::OffsetPatch {
        lines.push(format!(
            "envelope   built in {:.2} s; {} vertices kept at offset 0",
            s.envelope_seconds, s.pinned_vertices
        ));
    }
    Summary {
        triangles: s.triangles,
        seconds: s.seconds,
        json: serde_json::to_value(s).unwrap_or_default(),
        lines,
    }
}

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
    #[arg(long, allow_negative_numbers = true, default_value_t = vunify::measure::CertifyOptions::default().relative, requires = "certified")]
    tolerance: f64,
    /// With --certified: answer whether both one-sided distances are at most E (a fraction of the
    /// first mesh's diagonal). The search runs until it can tell; the exit status is the answer:
    /// 0 both proven at most E, 1 one proven above E, 3 undecided (the distance is too close to E
    /// for the split budget), 2 a usage error.
    #[arg(
        long,
        allow_negative_numbers = true,
        requires = "certified",
        value_name = "E"
    )]
    epsilon: Option<f64>,
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
    if let Some(e) = args.epsilon
        && !(e > 0.0 && e < 1.0)
    {
        anyhow::bail!("--epsilon must be between 0 and 1 (a fraction of the diagonal), got {e}");
    }
    let options = vunify::measure::CertifyOptions {
        relative: args.tolerance,
        epsilon: args.epsilon,
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
    let verdict = args.epsilon.map(|_| Verdict::of(&c));
    if args.json {
        let mut j = serde_json::to_value(c)?;
        j["seconds"] = seconds.into();
        if let Some(v) = verdict {
            j["verdict"] = v.word().into();
        }
        println!("{}", serde_json::to_string_pretty(&j)?);
        verdict.map_or(Ok(()), Verdict::exit)
    } else {
        print_certified(&c, seconds, args.epsilon, verdict);
        verdict.map_or(Ok(()), Verdict::exit)
    }
}

/// The answer to `--epsilon E`.
#[derive(Clone, Copy, PartialEq)]
enum Verdict {
    /// Both directions proven at most E (exit 0).
    Within,
    /// A lower bound above E (exit 1).
    Beyond,
    /// Neither (exit 3).
    Undecided,
}

impl Verdict {
    fn of(c: &vunify::measure::Certified) -> Verdict {
        let sides = [c.forward.within, c.backward.within];
        if sides.contains(&Some(false)) {
            Verdict::Beyond
        } else if sides.iter().all(|s| *s == Some(true)) {
            Verdict::Within
        } else {
            Verdict::Undecided
        }
    }

    fn word(self) -> &'static str {
        match self {
            Verdict::Within => "within",
            Verdict::Beyond => "beyond",
            Verdict::Undecided => "undecided",
        }
    }

    /// Ends the process with the verdict's status (0 returns normally).
    fn exit(self) -> Result<()> {
        match self {
            Verdict::Within => Ok(()),
            Verdict::Beyond => std::process::exit(1),
            Verdict::Undecided => std::process::exit(3),
        }
    }
}

fn print_certified(
    c: &vunify::measure::Certified,
    seconds: f64,
    epsilon: Option<f64>,
    verdict: Option<Verdict>,
) {
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
            match (s.within, s.converged) {
                (Some(true), _) => "  at most ε",
                (Some(false), _) => "  above ε",
                (None, true) => "",
                (None, false) => {
                    "  (split budget spent: the bounds hold but are farther apart than asked)"
                }
            }
        );
    }
    if let (Some(e), Some(v)) = (epsilon, verdict) {
        let e = 100.0 * e;
        match v {
            Verdict::Within => println!("verdict       both ways proven at most ε = {e} %"),
            Verdict::Beyond => {
                println!("verdict       farther than ε = {e} %: a point is proven beyond it")
            }
            Verdict::Undecided => eprintln!(
                "verdict       undecided: the distance is too close to ε = {e} % to tell within the \
                 split budget ({} splits) and the absolute floor ({} of the diagonal)",
                c.options.max_splits, c.options.absolute
            ),
        }
        println!("searched      until each side was decided; {seconds:.2} s");
    } else {
        println!(
            "tolerance     {} % of the lower bound, or {} of the diagonal; {seconds:.2} s",
            100.0 * c.options.relative,
            c.options.absolute
        );
    }
}

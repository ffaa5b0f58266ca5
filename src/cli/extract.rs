//! `vunify extract`: a static level of detail from a `.vtree` (or a chain of them), as a mesh file.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;
use vunify::vtree;

#[derive(Args)]
#[group(id = "target", required = true, multiple = false)]
struct Target {
    /// Keep at most this many triangles.
    #[arg(long, group = "target")]
    triangles: Option<u32>,
    /// Keep this fraction of the triangles (0..1).
    #[arg(long, group = "target")]
    ratio: Option<f64>,
    /// The coarsest front whose nodes' error is at most this, as a fraction of the bounding-box
    /// diagonal. The node error measures deviation where each merge happened: tight, but an
    /// estimate (the Hausdorff distance measured 1–3× it).
    #[arg(long, group = "target")]
    error: Option<f32>,
    /// The coarsest front whose nodes' deviation bound is at most this, as a fraction of the
    /// bounding-box diagonal: a guarantee, no point of the input surface is moved farther (a thin
    /// part may collapse to a line, which is not drawn); more triangles than --error for the same
    /// number.
    #[arg(long, group = "target")]
    bound: Option<f32>,
    /// A chain of static levels, each this fraction of the triangles (e.g. 0.5,0.25,0.1,0.01),
    /// written into one .glb or .gltf: a mesh and a scene per level (the first the default), each
    /// with its triangle count, its node error and its deviation bound (fractions of the diagonal)
    /// in `extras`.
    #[arg(long, group = "target", value_delimiter = ',', num_args = 1..)]
    lod_chain: Option<Vec<f64>>,
}

#[derive(Args)]
pub struct ExtractArgs {
    /// The .vtree file.
    file: PathBuf,
    #[command(flatten)]
    target: Target,
    /// Output mesh, written atomically: .obj, .ply or .off (optionally .xz), .glb, or .gltf with a
    /// .bin beside it.
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run(args: ExtractArgs) -> Result<()> {
    let tree = vtree::read(&args.file)?;
    let total = tree.triangles.len() as u32;
    let fraction = |name: &str, e: f32| {
        if !(e >= 0.0 && e.is_finite()) {
            bail!("--{name} must be a non-negative fraction of the diagonal, got {e}");
        }
        Ok(e * tree.diagonal())
    };
    let t = &args.target;
    if let Some(ratios) = &t.lod_chain {
        return chain(&tree, ratios, &args.output);
    }
    let cut = if let Some(n) = t.triangles {
        vtree::cut_at_triangles(&tree, n)
    } else if let Some(r) = t.ratio {
        if !(0.0..=1.0).contains(&r) {
            bail!("--ratio must be between 0 and 1, got {r}");
        }
        vtree::cut_at_triangles(&tree, (r * total as f64).round() as u32)
    } else if let Some(e) = t.error {
        vtree::cut_at_error(&tree, fraction("error", e)?)
    } else if let Some(b) = t.bound {
        vtree::cut_at_bound(&tree, fraction("bound", b)?)
    } else {
        unreachable!("clap requires exactly one target")
    };
    vunify::export::write_mesh(&cut.mesh, &args.output)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    println!(
        "wrote {}: {} vertices, {} triangles (of {total}){}",
        args.output.display(),
        cut.mesh.vertex_count(),
        cut.mesh.triangle_count(),
        if cut.dropped > 0 {
            format!(", {} repeated triangles dropped", cut.dropped)
        } else {
            String::new()
        }
    );
    Ok(())
}

/// `--lod-chain`: the levels at each ratio, in one glTF file.
fn chain(tree: &vtree::VertexTree, ratios: &[f64], output: &std::path::Path) -> Result<()> {
    if let Some(r) = ratios.iter().find(|r| !(**r > 0.0 && **r <= 1.0)) {
        bail!("--lod-chain: each ratio must be in (0, 1], got {r}");
    }
    let total = tree.triangles.len() as u32;
    let diagonal = tree.diagonal().max(f32::MIN_POSITIVE);
    let bounds = tree.deviation_bounds();
    let cuts: Vec<(vtree::Cut, f64)> = ratios
        .iter()
        .map(|&r| {
            (
                vtree::cut_at_triangles(tree, (r * total as f64).round() as u32),
                r,
            )
        })
        .collect();
    let levels: Vec<(&vunify::mesh::Mesh, serde_json::Value)> = cuts
        .iter()
        .map(|(cut, ratio)| {
            let worst = |f: &dyn Fn(u32) -> f32| {
                cut.nodes.iter().map(|&u| f(u)).fold(0.0f32, f32::max) / diagonal
            };
            let extras = serde_json::json!({
                "ratio": ratio,
                "triangles": cut.mesh.triangle_count(),
                "error": worst(&|u| tree.nodes[u as usize].error),
                "bound": worst(&|u| bounds[u as usize]),
            });
            (&cut.mesh, extras)
        })
        .collect();
    vunify::export::write_chain(&levels, output)
        .with_context(|| format!("cannot write {}", output.display()))?;
    println!("wrote {}: {} levels", output.display(), levels.len());
    for (k, (mesh, extras)) in levels.iter().enumerate() {
        println!(
            "  LOD{k}  {:>9} triangles  error {:.4} %  bound {:.4} % of the diagonal",
            mesh.triangle_count(),
            100.0 * extras["error"].as_f64().unwrap_or(0.0),
            100.0 * extras["bound"].as_f64().unwrap_or(0.0)
        );
    }
    Ok(())
}

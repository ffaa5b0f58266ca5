//! `vunify path`: a camera path (JSON) around a model.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;
use vunify::camera_path::CameraPath;
use vunify::vtree;

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum PathKind {
    Orbit,
    FlyIn,
    Flythrough,
}

#[derive(Args)]
pub struct PathArgs {
    /// What kind of path.
    #[arg(long, value_enum, default_value_t = PathKind::Orbit)]
    kind: PathKind,
    /// The model (.vtree, or a mesh: .obj, .ply, .off, optionally .xz, .gltf, .glb) whose bounds the path follows.
    model: PathBuf,
    /// Length of the path in seconds.
    #[arg(long, default_value_t = 10.0)]
    seconds: f32,
    /// Output JSON file (written atomically).
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run(args: PathArgs) -> Result<()> {
    if !(args.seconds > 0.0 && args.seconds <= vunify::camera_path::MAX_SECONDS) {
        bail!(
            "--seconds must be a positive number of at most {} (a day), got {}",
            vunify::camera_path::MAX_SECONDS,
            args.seconds
        );
    }
    let leaf_box = match paged_leaf_box(&args.model)? {
        Some(b) => b,
        None => super::load_tree(&args.model)?.leaf_box(),
    };
    vtree::check_viewable_diagonal(vunify::mesh::diagonal_of(leaf_box.1 - leaf_box.0))
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.model.display()))?;
    let path = camera_path(args.kind, vtree::sphere_of_box(leaf_box), args.seconds);
    vunify::export::write_atomic(&args.output, path.to_json().as_bytes())
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    println!(
        "wrote {}: {} keyframes over {} s",
        args.output.display(),
        path.keyframes.len(),
        args.seconds
    );
    Ok(())
}

/// The box of a paged tree's leaves, read page by page (a 100 M-triangle tree's 2.8 GB are never
/// in memory at once, nor its hierarchy built); `None` for a mesh or an exact tree, which are
/// read whole.
fn paged_leaf_box(model: &std::path::Path) -> Result<Option<(glam::Vec3, glam::Vec3)>> {
    if model.extension().and_then(|e| e.to_str()) != Some("vtree") {
        return Ok(None);
    }
    match vtree::PagedFile::open(model) {
        Ok(file) => Ok(Some(file.survey()?.leaf_box)),
        Err(e) if matches!(e.kind, vtree::FormatErrorKind::WrongVersion { found } if found < 4) => {
            Ok(None)
        }
        Err(e) => Err(e.into()),
    }
}

/// A generated path of this kind around a model's bounding sphere.
pub fn camera_path(
    kind: PathKind,
    (center, radius): (glam::Vec3, f32),
    seconds: f32,
) -> CameraPath {
    match kind {
        PathKind::Orbit => CameraPath::orbit(center, radius, seconds),
        PathKind::FlyIn => CameraPath::fly_in(center, radius, seconds),
        PathKind::Flythrough => CameraPath::flythrough(center, radius, seconds),
    }
}

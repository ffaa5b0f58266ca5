//! `vunify path`: a camera path (JSON) around a model.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;
use vunify::camera_path::CameraPath;
use vunify::vtree::VertexTree;

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
    let tree = super::load_tree(&args.model)?;
    tree.check_viewable()
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.model.display()))?;
    let path = camera_path(args.kind, &tree, args.seconds);
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

/// A generated path of this kind around the tree's leaves.
pub fn camera_path(kind: PathKind, tree: &VertexTree, seconds: f32) -> CameraPath {
    let (center, radius) = tree.bounding_sphere();
    match kind {
        PathKind::Orbit => CameraPath::orbit(center, radius, seconds),
        PathKind::FlyIn => CameraPath::fly_in(center, radius, seconds),
        PathKind::Flythrough => CameraPath::flythrough(center, radius, seconds),
    }
}

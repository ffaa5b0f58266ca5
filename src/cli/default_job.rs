//! `vunify` with no command: the bundled model's tree, then the viewer (or, with no display, the
//! default camera path rendered headless).

use super::render::RenderArgs;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use vunify::mesh::CleanOptions;
use vunify::vtree::BuildOptions;

/// The bundled model (the glTF sample water bottle, textured, CC0: see assets/README.md), compiled
/// into the binary so that an installed `vunify` needs no source tree.
const BUNDLED_MODEL: &[u8] = include_bytes!("../../assets/WaterBottle.glb");
const BUNDLED_NAME: &str = "WaterBottle.glb";

/// Where the default job writes: `out/` in the current directory.
pub fn out_dir() -> PathBuf {
    PathBuf::from("out")
}

/// The bundled model as a file (the viewer's compare view rebuilds it with other metrics): written
/// to `out/WaterBottle.glb` unless a file with the same bytes is already there.
pub fn bundled_model() -> Result<PathBuf> {
    let dir = out_dir();
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let file = dir.join(BUNDLED_NAME);
    if std::fs::read(&file).ok().as_deref() != Some(BUNDLED_MODEL) {
        vunify::export::write_atomic(&file, BUNDLED_MODEL)
            .with_context(|| format!("cannot write {}", file.display()))?;
    }
    Ok(file)
}

pub fn run() -> Result<()> {
    let model = bundled_model()?;
    let tree_file = out_dir().join(Path::new(BUNDLED_NAME).with_extension("vtree"));
    println!("vunify: building the vertex tree of the bundled model {BUNDLED_NAME}");
    super::build::build_and_write(
        &model,
        &tree_file,
        &BuildOptions::default(),
        &CleanOptions::default(),
        super::build::How::Whole,
        vunify::vtree::Encoding::Paged,
        false,
    )?;
    if super::has_display() {
        println!("vunify: opening the viewer (H for the keys)");
        // The mesh rather than the .vtree, so that the compare view can build the other metrics.
        return super::view::open_interactive(model);
    }
    println!(
        "\nvunify: no display (DISPLAY and WAYLAND_DISPLAY are unset), so instead of the viewer it renders \
         the default camera path headless"
    );
    headless_default_path(&tree_file)
}

/// Renders the default camera path over `tree_file` to `out/default-path/`.
pub fn headless_default_path(tree_file: &Path) -> Result<()> {
    let out = out_dir().join("default-path");
    let mut args = RenderArgs::defaults_for(tree_file.to_path_buf());
    args.out = out.clone();
    args.every = 30;
    super::render::run(args)?;
    println!("look at {}", out.join("contact_sheet.png").display());
    Ok(())
}

//! `vunify view`: the interactive viewer.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct ViewArgs {
    /// The model: .vtree opens at once, a mesh (.obj, .ply, .off, optionally .xz, .gltf, .glb) is built in the
    /// background (and cached), a scene (.obj whose materials emit, `Ke`) is lit by radiosity first.
    /// Default: the bundled model.
    model: Option<PathBuf>,
    /// Run a script (JSON: frames, camera path, UI actions, screenshots; the README shows one) and exit.
    #[arg(long)]
    script: Option<PathBuf>,
    /// Scripted shortcut: fly in over this many frames, then exit.
    #[arg(long)]
    frames: Option<u32>,
    /// With --frames: save a screenshot (3D view and panel) of the last frame.
    #[arg(long, requires = "frames")]
    screenshot: Option<PathBuf>,
    /// Window size, WIDTHxHEIGHT (default: the last one used).
    #[arg(long, value_parser = super::parse_size)]
    size: Option<[u32; 2]>,
    /// Stream the tree from its file instead of reading it whole, within SIZE of memory (e.g.
    /// 256M, 1G; see `vunify render --help`): the panel shows the cache, and the front sharpens
    /// where pages arrive. Without it, a paged tree too large to read whole in half of this
    /// machine's memory is streamed within an eighth of it (256 MiB to 1 GiB).
    #[arg(long, value_name = "SIZE", value_parser = super::build::parse_memory)]
    cache: Option<u64>,
}

/// What the window runs, if not interactive.
#[cfg_attr(not(feature = "viewer"), allow(dead_code))]
enum Scripted {
    File(PathBuf),
    FlyIn {
        frames: u32,
        screenshot: Option<PathBuf>,
    },
}

pub fn run(args: ViewArgs) -> Result<()> {
    let model = match args.model {
        Some(m) => m,
        None => super::default_job::bundled_model()?,
    };
    let streaming = args.cache.or_else(|| super::stream_by_default(&model));
    if streaming.is_none() {
        super::warn_if_too_large_to_view(&model);
    }
    if !super::has_display() && streaming.is_some() {
        println!(
            "vunify: no display (DISPLAY and WAYLAND_DISPLAY are unset); rendering the default camera path \
             headless instead"
        );
        let mut render = super::render::RenderArgs::defaults_for(model);
        render.cache = streaming;
        render.out = super::default_job::out_dir().join("default-path");
        render.every = 30;
        return super::render::run(render);
    }
    #[cfg(feature = "viewer")]
    vunify::app::stream_trees_within(streaming);
    if !super::has_display() {
        println!(
            "vunify: no display (DISPLAY and WAYLAND_DISPLAY are unset); rendering the default camera path \
             headless instead"
        );
        let tree = super::load_tree(&model)?;
        let file = std::env::temp_dir().join(format!("vunify-view-{}.vtree", std::process::id()));
        vunify::vtree::write(&tree, &file)?;
        let result = super::default_job::headless_default_path(&file);
        let _ = std::fs::remove_file(&file);
        return result;
    }
    let scripted = match (args.script, args.frames) {
        (Some(file), _) => Some(Scripted::File(file)),
        (None, Some(frames)) => Some(Scripted::FlyIn {
            frames,
            screenshot: args.screenshot,
        }),
        (None, None) => None,
    };
    open(model, scripted, args.size)
}

#[cfg(not(feature = "viewer"))]
fn open(_: PathBuf, _: Option<Scripted>, _: Option<[u32; 2]>) -> Result<()> {
    anyhow::bail!(
        "this vunify was built without the `viewer` feature: rebuild with default features to view"
    )
}

/// Opens the window on `model`; returns when it closes (or a script ends).
#[cfg(feature = "viewer")]
fn open(model: PathBuf, scripted: Option<Scripted>, size: Option<[u32; 2]>) -> Result<()> {
    use vunify::script::Script;
    let script = match scripted {
        Some(Scripted::File(file)) => Some(Script::load(&file)?),
        Some(Scripted::FlyIn { frames, screenshot }) => Some(Script::simple(frames, screenshot)),
        None => None,
    };
    vunify::app::run(vunify::app::ViewArgs {
        model,
        script,
        size,
    })
}

/// The viewer on `model`, interactive (the default job's way in).
pub fn open_interactive(model: PathBuf) -> Result<()> {
    open(model, None, None)
}

//! `vunify render`: a camera path over a model, rendered headless.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct RenderArgs {
    /// The model: a .vtree opens at once; a mesh (.obj, .ply, .off, optionally .xz, .gltf, .glb) is built first; a
    /// scene (.obj whose materials emit, `Ke`) is lit by radiosity, then built.
    pub model: PathBuf,
    /// Camera path JSON (see `vunify path`); default: an orbit of the model.
    #[arg(long)]
    path: Option<PathBuf>,
    /// Output directory for frames, stats.csv and the contact sheet.
    #[arg(long, default_value = "out/render")]
    pub out: PathBuf,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x768", value_parser = super::parse_size)]
    size: [u32; 2],
    /// Screen-space error tolerance τ in pixels.
    #[arg(long, default_value_t = 1.0, conflicts_with = "budget")]
    tau: f32,
    /// Triangle budget: the best screen-space error under this many triangles (instead of --tau).
    #[arg(long)]
    budget: Option<u32>,
    /// Write every K-th frame as PNG (statistics cover every frame).
    #[arg(long, default_value_t = 10)]
    pub every: usize,
    /// Frames per second of path time.
    #[arg(long, default_value_t = 30.0)]
    fps: f32,
    /// Also render the full-resolution mesh each frame: PSNR and share of differing pixels per frame,
    /// and the worst frame side by side with its difference.
    #[arg(long)]
    compare: bool,
    /// Draw triangle edges over the surface.
    #[arg(long)]
    wireframe: bool,
    /// Draw the full mesh, every triangle as it is, instead of the level of detail (e.g. a lit mesh
    /// from `vunify radiosity`, whose lighting the tree's geometric error does not see).
    #[arg(long, conflicts_with = "compare")]
    full: bool,
    /// Screen-space test on geometry alone: leave out the shading term, which also refines where
    /// sub-pixel bumps turn normals across many pixels (fewer triangles, less faithful shading).
    #[arg(long)]
    geometric: bool,
    /// Screen-space test on the strict deviation bound instead of the measured error: no point of
    /// a node in the view is drawn more than τ pixels from where it belongs, with many more
    /// triangles (the back-face test is left out: docs/RUNTIME.md).
    #[arg(long)]
    strict: bool,
    /// Surface colours: auto (the base colour texture for a textured model; baked for lit meshes
    /// from `vunify radiosity`; else vertex colours if any or grey, lit), shaded, baked (vertex
    /// colours unlit), depth (tree depth), error (projected error: blue 0, green τ, red 2τ; on a
    /// streamed tree a vertex standing for pages not read yet shows their error, so what waits
    /// for the disk is red),
    /// texture, or uv (a checker over the texture coordinates, to see seams and stretch).
    #[arg(long, value_enum, default_value = "auto")]
    color_by: ColorChoice,
    /// Stream the tree from its file instead of reading it whole: pages are read as the view
    /// asks for them, on a thread of their own (a frame never waits for the disk), and the front
    /// refines where they have arrived. SIZE (e.g. 256M, 1G) is the memory the tree may hold:
    /// pages read take at most a third of it, the runtime's hierarchy over them the rest.
    /// Without it, a paged tree too large to read whole in half of this machine's memory is
    /// streamed within an eighth of it (at least 256 MiB, at most 1 GiB).
    #[arg(long, value_name = "SIZE", value_parser = super::build::parse_memory, conflicts_with_all = ["compare", "full", "strict"])]
    pub cache: Option<u64>,
    /// Print the summary as JSON instead of text: the medians and 95th percentiles of refinement,
    /// GPU and frame times, triangles, image error with --compare, seconds to the first frame
    /// (`first_frame_s`), the longest frame (`max_frame_ms`) and the peak resident memory
    /// (`peak_resident_mb`). stats.csv has every frame.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum ColorChoice {
    Auto,
    Shaded,
    Baked,
    Depth,
    Error,
    Texture,
    Uv,
}

impl RenderArgs {
    /// The arguments of `vunify render MODEL`, with every default as `--help` states it.
    pub fn defaults_for(model: PathBuf) -> RenderArgs {
        use clap::FromArgMatches;
        let command = <RenderArgs as Args>::augment_args(clap::Command::new("render"));
        let matches = command.get_matches_from([std::ffi::OsString::from("render"), model.into()]);
        RenderArgs::from_arg_matches(&matches).expect("the defaults parse")
    }
}

#[cfg(not(feature = "render"))]
pub fn run(_: RenderArgs) -> Result<()> {
    anyhow::bail!(
        "this vunify was built without the `render` feature: rebuild with default features to render"
    )
}

#[cfg(feature = "render")]
pub fn run(args: RenderArgs) -> Result<()> {
    let started = std::time::Instant::now();
    use anyhow::bail;
    use vunify::refine::Hierarchy;
    use vunify::render::{Gpu, job};
    if !(args.tau > 0.0 && args.tau.is_finite()) {
        bail!(
            "--tau must be a positive number of pixels, got {}",
            args.tau
        );
    }
    if !(args.fps > 0.0 && args.fps <= 1000.0) {
        bail!("--fps must be positive and at most 1000, got {}", args.fps);
    }
    let streaming = match args.cache {
        Some(size) => Some(size),
        None if !(args.compare || args.full || args.strict) => {
            super::stream_by_default(&args.model)
        }
        None => None,
    };
    if let Some(size) = streaming {
        return run_streamed(args, size, started);
    }
    super::warn_if_too_large_to_view(&args.model);
    let tree = super::load_tree(&args.model)?;
    tree.check_viewable()
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.model.display()))?;
    let path = camera_path(&args, tree.bounding_sphere())?;
    let gpu = Gpu::headless()?;
    let job = render_job(&args, started);
    // The runtime reads the hierarchy only: the tree (1.4 GB at 14 M triangles) goes as it is
    // read, before the GPU's buffers are made.
    let h = Hierarchy::from_tree(tree);
    announce(&args, &gpu, "");
    let summary = with_progress(|progress| job::render_path(&gpu, &h, &path, &job, progress))?;
    report(&args, &summary)
}

/// `render` over a tree streamed from its file, its pages within a third of `size` bytes.
#[cfg(feature = "render")]
fn run_streamed(args: RenderArgs, size: u64, started: std::time::Instant) -> Result<()> {
    use vunify::render::{Gpu, job};
    let job = render_job(&args, started);
    let mut streamed = vunify::refine::Streamed::open(&args.model, size / 3, job.settings)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    vunify::vtree::check_viewable_diagonal(streamed.hierarchy().diagonal)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.model.display()))?;
    let path = camera_path(&args, streamed.sphere())?;
    let gpu = Gpu::headless()?;
    announce(
        &args,
        &gpu,
        &format!(", streamed within {} MiB", size >> 20),
    );
    let summary =
        with_progress(|progress| job::render_streamed(&gpu, &mut streamed, &path, &job, progress))?;
    report(&args, &summary)
}

/// The path `--path` names, or an orbit of the model's bounding `sphere`.
#[cfg(feature = "render")]
fn camera_path(
    args: &RenderArgs,
    sphere: (glam::Vec3, f32),
) -> Result<vunify::camera_path::CameraPath> {
    Ok(match &args.path {
        Some(p) => vunify::camera_path::CameraPath::load(p)?,
        None => super::path::camera_path(super::path::PathKind::Orbit, sphere, 10.0),
    })
}

/// Says what is rendered where (unless the summary is to be JSON), with `how` after it.
#[cfg(feature = "render")]
fn announce(args: &RenderArgs, gpu: &vunify::render::Gpu, how: &str) {
    if !args.json {
        println!(
            "rendering {} on {} at {}x{}{how}",
            args.model.display(),
            gpu.adapter_name(),
            args.size[0],
            args.size[1]
        );
    }
}

/// Runs `render` with a progress bar of its frames.
#[cfg(feature = "render")]
fn with_progress<T, E: Into<anyhow::Error>>(
    render: impl FnOnce(&mut dyn FnMut(usize, usize)) -> Result<T, E>,
) -> Result<T> {
    let bar = super::progress_bar(0, "frames [{bar:40}] {pos}/{len} ({eta})");
    let out = render(&mut |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .map_err(Into::into);
    bar.finish_and_clear();
    out
}

#[cfg(feature = "render")]
fn report(args: &RenderArgs, summary: &vunify::render::job::Summary) -> Result<()> {
    for e in &summary.page_errors {
        eprintln!("warning: {e}; the front stayed coarse there");
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(summary)?);
    } else {
        print_summary(summary, &args.out);
    }
    Ok(())
}

/// The render job `args` ask for.
#[cfg(feature = "render")]
fn render_job(args: &RenderArgs, started: std::time::Instant) -> vunify::render::job::RenderJob {
    use vunify::refine::{Mode, Settings};
    use vunify::render::{ColorBy, DrawOptions, job};
    let settings = Settings {
        tolerance_px: args.tau,
        mode: args.budget.map_or(Mode::Tolerance, Mode::Budget),
        tests: vunify::refine::Tests {
            shading: !args.geometric,
            strict: args.strict,
            ..Default::default()
        },
        ..Default::default()
    };
    let draw = DrawOptions {
        color_by: match args.color_by {
            ColorChoice::Auto => ColorBy::Auto,
            ColorChoice::Shaded => ColorBy::Shaded,
            ColorChoice::Baked => ColorBy::Baked,
            ColorChoice::Depth => ColorBy::Depth,
            ColorChoice::Error => ColorBy::Error,
            ColorChoice::Texture => ColorBy::Texture,
            ColorChoice::Uv => ColorBy::Uv,
        },
        wireframe: args.wireframe,
        tolerance_px: args.tau,
        ..Default::default()
    };
    job::RenderJob {
        size: args.size,
        settings,
        draw,
        fps: args.fps,
        every: args.every.max(1),
        compare: args.compare,
        full: args.full,
        out_dir: args.out.clone(),
        started: Some(started),
    }
}

#[cfg(feature = "render")]
fn print_summary(s: &vunify::render::job::Summary, out: &std::path::Path) {
    println!("frames     {} on {}", s.frames, s.adapter);
    println!(
        "triangles  mean {:.0}, max {}{}",
        s.triangles_mean,
        s.triangles_max,
        if s.full_triangles > 0 {
            format!(" (full mesh {})", s.full_triangles)
        } else {
            String::new()
        }
    );
    println!(
        "refine     median {:.3} ms, p95 {:.3} ms; upload {:.0} bytes a frame",
        s.refine_ms_median, s.refine_ms_p95, s.upload_bytes_mean
    );
    if let Some(g) = s.gpu_ms_median {
        println!("gpu        median {g:.2} ms a frame");
    }
    println!(
        "frames     first after {:.2} s, longest {:.1} ms (refine + upload + draw + readback){}",
        s.first_frame_s,
        s.max_frame_ms,
        s.peak_resident_mb
            .map_or(String::new(), |m| format!("; peak resident {m:.0} MiB"))
    );
    if let (Some(mean), Some(min), Some(d), Some(dmax)) = (
        s.psnr_db_mean,
        s.psnr_db_min,
        s.differing_mean,
        s.differing_max,
    ) {
        println!(
            "vs full    PSNR mean {mean:.1} dB, worst {min:.1} dB (frame {}); pixels off by > 8/255: mean {:.3} %, max {:.3} %",
            s.worst_frame.unwrap_or(0),
            d * 100.0,
            dmax * 100.0
        );
    }
    println!("wrote      {} files in {}", s.written.len(), out.display());
}

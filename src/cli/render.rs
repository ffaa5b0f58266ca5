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
    /// colours unlit), depth (tree depth), error (projected error: blue 0, green τ, red 2τ),
    /// texture, or uv (a checker over the texture coordinates, to see seams and stretch).
    #[arg(long, value_enum, default_value = "auto")]
    color_by: ColorChoice,
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
    use vunify::refine::{Hierarchy, Mode, Settings};
    use vunify::render::{ColorBy, DrawOptions, Gpu, job};
    if !(args.tau > 0.0 && args.tau.is_finite()) {
        bail!(
            "--tau must be a positive number of pixels, got {}",
            args.tau
        );
    }
    if !(args.fps > 0.0 && args.fps <= 1000.0) {
        bail!("--fps must be positive and at most 1000, got {}", args.fps);
    }
    super::warn_if_too_large_to_view(&args.model);
    let tree = super::load_tree(&args.model)?;
    tree.check_viewable()
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.model.display()))?;
    let path = match &args.path {
        Some(p) => vunify::camera_path::CameraPath::load(p)?,
        None => {
            super::path::camera_path(super::path::PathKind::Orbit, tree.bounding_sphere(), 10.0)
        }
    };
    let gpu = Gpu::headless()?;
    // The runtime reads the hierarchy only: the tree (1.4 GB at 14 M triangles) goes as it is
    // read, before the GPU's buffers are made.
    let h = Hierarchy::from_tree(tree);
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
    let job = job::RenderJob {
        size: args.size,
        settings,
        draw,
        fps: args.fps,
        every: args.every.max(1),
        compare: args.compare,
        full: args.full,
        out_dir: args.out.clone(),
        started: Some(started),
    };
    if !args.json {
        println!(
            "rendering {} on {} at {}x{}",
            args.model.display(),
            gpu.adapter_name(),
            args.size[0],
            args.size[1]
        );
    }
    let bar = super::progress_bar(0, "frames [{bar:40}] {pos}/{len} ({eta})");
    let summary = job::render_path(&gpu, &h, &path, &job, &mut |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_summary(&summary, &args.out);
    }
    Ok(())
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

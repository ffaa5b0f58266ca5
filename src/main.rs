//! The `vunify` command line. Library errors are typed; here, at the application edge, they become
//! `anyhow` messages for the user.

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::time::Instant;
use vunify::mesh::{self, CleanOptions};
use vunify::simplify::Metric;
use vunify::simplify::metric::HybridWeights;
use vunify::vtree::{self, BuildOptions, Schedule};

/// The model `vunify` runs on when given no command (MIT-licensed, see assets/README.md).
const DEFAULT_MODEL: &str = "assets/cessna.obj";

#[derive(Parser)]
#[command(
    name = "vunify",
    version,
    about = "View-dependent level of detail for triangle meshes.",
    long_about = "\
View-dependent level of detail for triangle meshes.

vunify builds a binary vertex tree of vertex merges (vunify / vsplit, which may join any two vertices
and so change topology) from a mesh or a whole scene, stores it as a .vtree file, and takes static
levels of detail from it, refines it view-dependently every frame and renders it with wgpu. Run without
a command, it builds the tree of the bundled default model and opens the viewer on it; with no display,
it renders the default camera path headless instead."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Build the vertex tree of a mesh (.obj, .ply or .off, optionally .xz) and write it as .vtree.
    Build(BuildArgs),
    /// Print what a .vtree file holds.
    Info {
        /// The .vtree file.
        file: PathBuf,
        /// Also replay the build order and check every cut (slower).
        #[arg(long)]
        check: bool,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Take a static level of detail from a .vtree and write it as OBJ.
    Extract(ExtractArgs),
    /// Write a camera path (JSON) around a model: an orbit, a fly-in (far to near, seed 001 Fig. 6) or
    /// a flythrough (close past and through the model).
    Path(PathArgs),
    /// Render a camera path over a model headless (PNG frames, stats.csv, a contact sheet); with
    /// --compare, measure the LOD against the full mesh frame by frame.
    Render(RenderArgs),
    /// Fly through a model in the interactive viewer (winit + egui); with no display, render the
    /// default camera path headless instead.
    View(ViewCliArgs),
    /// Symmetric Hausdorff distance between two meshes (Metro-style dense sampling).
    Measure {
        /// The reference mesh; distances are fractions of its bounding-box diagonal.
        original: PathBuf,
        /// The mesh to compare with it.
        simplified: PathBuf,
        /// Minimum number of surface samples on each mesh (every vertex is sampled, plus points along
        /// edges and inside faces).
        #[arg(long, default_value_t = vunify::measure::DEFAULT_SAMPLES)]
        samples: usize,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Args)]
struct BuildArgs {
    /// Input mesh or scene: .obj (objects and groups become parts), .ply, .off; may end in .xz.
    input: PathBuf,
    /// Output .vtree file (written atomically). Default: the input's name with .vtree, in the current directory.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// How merges are priced: qem (quadric error, optimal position), qem-midpoint, edge-length, or
    /// hybrid (seed 001: w1·squared distance + w2·feature error).
    #[arg(long, value_enum, default_value_t = Metric::Qem)]
    metric: Metric,
    /// Merge order: passes (default; non-overlapping cheapest merges per pass, as meshoptimizer does)
    /// or greedy (strictly the cheapest pair each time, the paper's algorithm; slower).
    #[arg(long, value_enum, default_value_t = Schedule::Passes)]
    schedule: Schedule,
    /// Vertices without an edge between them are merge candidates when closer than this fraction of
    /// the bounding-box diagonal (0 turns such pairs off until separate parts must be joined).
    #[arg(long, default_value_t = BuildOptions::default().pair_distance)]
    pair_distance: f32,
    /// At most this many nearest non-edge partners per vertex.
    #[arg(long, default_value_t = BuildOptions::default().max_pairs_per_vertex)]
    max_pairs: usize,
    /// Seed 001's θ, degrees: an edge whose dihedral angle is below it is a sharp feature (180 = flat).
    #[arg(long, default_value_t = BuildOptions::default().sharp_angle_deg)]
    sharp_angle: f32,
    /// Hybrid metric: weight w1 of the squared distance (in mean edge lengths).
    #[arg(long, default_value_t = HybridWeights::default().distance)]
    w_dist: f32,
    /// Hybrid metric: weight w2 of the feature error (Tables 1 and 2).
    #[arg(long, default_value_t = HybridWeights::default().feature)]
    w_feature: f32,
    /// Keep vertices with identical positions apart (welding is on by default).
    #[arg(long)]
    no_weld: bool,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

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
}

#[derive(Args)]
struct ExtractArgs {
    /// The .vtree file.
    file: PathBuf,
    #[command(flatten)]
    target: Target,
    /// Output OBJ file (written atomically).
    #[arg(short, long)]
    output: PathBuf,
}

#[derive(Args)]
struct ViewCliArgs {
    /// The model: .vtree opens at once, a mesh (.obj, .ply, .off, optionally .xz) is built in the
    /// background (and cached). Default: the bundled model.
    model: Option<PathBuf>,
    /// Run a script (JSON: frames, camera path, UI actions, screenshots; see src/app/script.rs) and exit.
    #[arg(long)]
    script: Option<PathBuf>,
    /// Scripted shortcut: fly in over this many frames, then exit.
    #[arg(long)]
    frames: Option<u32>,
    /// With --frames: save a screenshot (3D view and panel) of the last frame.
    #[arg(long, requires = "frames")]
    screenshot: Option<PathBuf>,
    /// Window size, WIDTHxHEIGHT (default: the last one used).
    #[arg(long, value_parser = parse_size)]
    size: Option<[u32; 2]>,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum PathKind {
    Orbit,
    FlyIn,
    Flythrough,
}

#[derive(Args)]
struct PathArgs {
    /// What kind of path.
    #[arg(long, value_enum, default_value_t = PathKind::Orbit)]
    kind: PathKind,
    /// The model (.vtree, or a mesh: .obj, .ply, .off, optionally .xz) whose bounds the path follows.
    model: PathBuf,
    /// Length of the path in seconds.
    #[arg(long, default_value_t = 10.0)]
    seconds: f32,
    /// Output JSON file (written atomically).
    #[arg(short, long)]
    output: PathBuf,
}

#[derive(Args)]
struct RenderArgs {
    /// The model: a .vtree opens at once; a mesh (.obj, .ply, .off, optionally .xz) is built first.
    model: PathBuf,
    /// Camera path JSON (see `vunify path`); default: an orbit of the model.
    #[arg(long)]
    path: Option<PathBuf>,
    /// Output directory for frames, stats.csv and the contact sheet.
    #[arg(long, default_value = "out/render")]
    out: PathBuf,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x768", value_parser = parse_size)]
    size: [u32; 2],
    /// Screen-space error tolerance τ in pixels.
    #[arg(long, default_value_t = 1.0, conflicts_with = "budget")]
    tau: f32,
    /// Triangle budget: the best screen-space error under this many triangles (instead of --tau).
    #[arg(long)]
    budget: Option<u32>,
    /// Write every K-th frame as PNG (statistics cover every frame).
    #[arg(long, default_value_t = 10)]
    every: usize,
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
    /// Screen-space test on geometry alone: leave out the shading term, which also refines where
    /// sub-pixel bumps turn normals across many pixels (fewer triangles, less faithful shading).
    #[arg(long)]
    geometric: bool,
    /// Screen-space test on the strict deviation bound instead of the measured error: no point of
    /// the surface drawn more than τ pixels from where it belongs, with many more triangles.
    #[arg(long)]
    strict: bool,
    /// Surface colours: auto (vertex colours if any, else grey), shaded, depth (tree depth) or error
    /// (projected error: blue 0, green τ, red 2τ).
    #[arg(long, value_enum, default_value = "auto")]
    color_by: ColorChoice,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum ColorChoice {
    Auto,
    Shaded,
    Depth,
    Error,
}

fn parse_size(s: &str) -> Result<[u32; 2], String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, got {s:?}"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|&x| (1..=16384).contains(&x))
            .ok_or_else(|| format!("{v:?} is not a size between 1 and 16384"))
    };
    Ok([parse(w)?, parse(h)?])
}

fn main() {
    // Rust ignores SIGPIPE, so writing to a closed pipe (`vunify info F | head`) would panic in
    // `println!`; a command-line tool should end quietly instead, as `cat` does.
    #[cfg(unix)]
    // SAFETY: called first thing, before any thread exists; SIG_DFL is a valid action for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let result = match cli.command {
        None => default_job(),
        Some(Command::Build(args)) => build(args),
        Some(Command::Info { file, check, json }) => info(&file, check, json),
        Some(Command::Extract(args)) => extract(args),
        Some(Command::Path(args)) => path(args),
        Some(Command::Render(args)) => render(args),
        Some(Command::View(args)) => view(args),
        Some(Command::Measure {
            original,
            simplified,
            samples,
            json,
        }) => measure(&original, &simplified, samples, json),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// Peak resident memory of this process so far (Linux `VmHWM`), in bytes.
fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

fn default_job() -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let input = root.join(DEFAULT_MODEL);
    let out_dir = root.join("out");
    std::fs::create_dir_all(&out_dir)
        .with_context(|| format!("cannot create {}", out_dir.display()))?;
    let tree_file = out_dir.join("cessna.vtree");
    println!("vunify: building the vertex tree of the default model {DEFAULT_MODEL}");
    build(BuildArgs {
        input,
        output: Some(tree_file.clone()),
        metric: Metric::Qem,
        schedule: Schedule::Passes,
        pair_distance: BuildOptions::default().pair_distance,
        max_pairs: BuildOptions::default().max_pairs_per_vertex,
        sharp_angle: BuildOptions::default().sharp_angle_deg,
        w_dist: HybridWeights::default().distance,
        w_feature: HybridWeights::default().feature,
        no_weld: false,
        json: false,
    })?;
    if has_display() {
        println!("vunify: opening the viewer (H for the keys)");
        // The mesh rather than the .vtree, so that the compare view can build the other metrics.
        return view(ViewCliArgs {
            model: Some(root.join(DEFAULT_MODEL)),
            script: None,
            frames: None,
            screenshot: None,
            size: None,
        });
    }
    println!(
        "\nvunify: no display (DISPLAY and WAYLAND_DISPLAY are unset), so instead of the viewer it renders \
         the default camera path headless"
    );
    headless_default_path(&tree_file)
}

fn has_display() -> bool {
    ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|x| !x.is_empty()))
}

fn headless_default_path(tree_file: &Path) -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = root.join("out").join("default-path");
    let tree_file = tree_file.to_path_buf();
    render(RenderArgs {
        model: tree_file,
        path: None,
        out: out.clone(),
        size: [1024, 768],
        tau: 1.0,
        budget: None,
        every: 30,
        fps: 30.0,
        compare: false,
        wireframe: false,
        geometric: false,
        strict: false,
        color_by: ColorChoice::Auto,
    })?;
    println!("look at {}", out.join("contact_sheet.png").display());
    Ok(())
}

fn build(args: BuildArgs) -> Result<()> {
    if !(args.pair_distance >= 0.0 && args.pair_distance.is_finite()) {
        bail!(
            "--pair-distance must be a non-negative number, got {}",
            args.pair_distance
        );
    }
    if !(args.sharp_angle > 0.0 && args.sharp_angle <= 180.0) {
        bail!(
            "--sharp-angle must be in (0, 180] degrees, got {}",
            args.sharp_angle
        );
    }
    let output = args.output.clone().unwrap_or_else(|| {
        let stem = args
            .input
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        let stem = stem.trim_end_matches(".xz");
        let stem = stem.rsplit_once('.').map_or(stem, |(s, _)| s);
        PathBuf::from(format!("{stem}.vtree"))
    });
    let t0 = Instant::now();
    let (mesh, cleaned) = mesh::load(
        &args.input,
        &CleanOptions {
            weld: !args.no_weld,
        },
    )?;
    let load_secs = t0.elapsed().as_secs_f64();
    let options = BuildOptions {
        metric: args.metric,
        schedule: args.schedule,
        pair_distance: args.pair_distance,
        max_pairs_per_vertex: args.max_pairs,
        sharp_angle_deg: args.sharp_angle,
        hybrid: HybridWeights {
            distance: args.w_dist,
            feature: args.w_feature,
        },
    };
    let bar = indicatif::ProgressBar::new(mesh.vertex_count().saturating_sub(1) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} merges ({eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message("building");
    let (tree, stats) = vtree::build(&mesh, &options, &mut |done, _| {
        bar.set_position(done as u64)
    })?;
    bar.finish_and_clear();
    vtree::write(&tree, &output).with_context(|| format!("cannot write {}", output.display()))?;
    let peak = peak_memory_bytes();
    if args.json {
        let json = serde_json::json!({
            "input": args.input, "output": output, "metric": args.metric.name(),
            "vertices": mesh.vertex_count(), "triangles": mesh.triangle_count(), "parts": mesh.parts.len(),
            "cleaned": cleaned, "build": stats, "load_seconds": load_secs, "peak_memory_bytes": peak,
        });
        println!("{}", serde_json::to_string_pretty(&json)?);
        return Ok(());
    }
    println!("input      {}", args.input.display());
    println!(
        "           {} vertices, {} triangles, {} part(s)",
        mesh.vertex_count(),
        mesh.triangle_count(),
        mesh.parts.len()
    );
    println!(
        "cleaned    {} welded, {} unused vertices dropped; {} degenerate and {} duplicate faces dropped",
        cleaned.welded_vertices,
        cleaned.unused_vertices,
        cleaned.degenerate_faces,
        cleaned.duplicate_faces
    );
    println!(
        "metric     {}, {:?} schedule ({} rounds, {} pairs priced)",
        args.metric.name(),
        args.schedule,
        stats.rounds,
        stats.pricings
    );
    println!(
        "tree       {} nodes ({} leaves), one root, depth {}",
        stats.nodes, stats.leaves, stats.depth
    );
    println!(
        "pairs      {} feature edges, {} close non-edge pairs, {} flip deferrals, {} widenings",
        stats.feature_edges, stats.proximity_pairs, stats.flip_deferrals, stats.widenings
    );
    println!(
        "time       load {load_secs:.2} s, build {:.2} s",
        stats.seconds
    );
    let p = &stats.phases;
    println!(
        "phases     features {:.2} s, close pairs {:.2} s, leaves {:.2} s, pricing {:.2} s, merging {:.2} s, re-pricing {:.2} s",
        p.features, p.close_pairs, p.leaves, p.pricing, p.merging, p.repricing
    );
    if let Some(p) = peak {
        println!(
            "memory     process peak {:.1} MiB, input included ({:.0} bytes per input triangle)",
            p as f64 / 1048576.0,
            p as f64 / mesh.triangle_count() as f64
        );
    }
    println!("wrote      {}", output.display());
    Ok(())
}

fn info(file: &Path, check: bool, json: bool) -> Result<()> {
    let tree = vtree::read(file)?;
    if check {
        vtree::check_cut(&tree).map_err(|e| {
            anyhow::anyhow!("{}: the build order is inconsistent: {e}", file.display())
        })?;
    }
    let root = &tree.nodes[tree.root() as usize];
    if json {
        let j = serde_json::json!({
            "file": file, "leaves": tree.leaf_count, "nodes": tree.nodes.len(), "triangles": tree.triangles.len(),
            "depth": tree.depth(), "metric": tree.metric.name(), "colors": tree.has_colors, "normals": tree.has_normals,
            "parts": tree.parts, "root_error": root.error, "diagonal": tree.diagonal(), "checked": check,
        });
        println!("{}", serde_json::to_string_pretty(&j)?);
        return Ok(());
    }
    println!("file       {}", file.display());
    println!(
        "tree       {} nodes ({} leaves), depth {}, metric {}",
        tree.nodes.len(),
        tree.leaf_count,
        tree.depth(),
        tree.metric.name()
    );
    println!("triangles  {}", tree.triangles.len());
    println!(
        "attributes colours: {}, normals: {}",
        tree.has_colors, tree.has_normals
    );
    println!(
        "root       error {:.4} ({:.4} % of the diagonal {:.4})",
        root.error,
        100.0 * root.error / tree.diagonal().max(f32::MIN_POSITIVE),
        tree.diagonal()
    );
    println!("parts      {}", tree.parts.len());
    for p in tree.parts.iter().take(20) {
        println!("           {:>8} triangles  {}", p.triangles, p.name);
    }
    if tree.parts.len() > 20 {
        println!("           ... and {} more", tree.parts.len() - 20);
    }
    if check {
        println!("check      every cut of the build order is a valid mesh");
    }
    Ok(())
}

fn extract(args: ExtractArgs) -> Result<()> {
    let tree = vtree::read(&args.file)?;
    let total = tree.triangles.len() as u32;
    let fraction = |name: &str, e: f32| {
        if e.is_nan() || e < 0.0 {
            bail!("--{name} must be a non-negative fraction of the diagonal, got {e}");
        }
        Ok(e * tree.diagonal())
    };
    let t = &args.target;
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
    vunify::export::write_obj(&cut.mesh, &args.output)
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

fn measure(original: &Path, simplified: &Path, samples: usize, json: bool) -> Result<()> {
    let options = CleanOptions::default();
    let (a, _) = mesh::load(original, &options)?;
    let (b, _) = mesh::load(simplified, &options)?;
    let h = vunify::measure::hausdorff(&a, &b, samples.max(1));
    if json {
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

/// A model's tree: read from a .vtree, or built from a mesh (with a progress bar).
fn load_tree(model: &Path) -> Result<vtree::VertexTree> {
    let is_vtree = model
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("vtree"));
    if is_vtree {
        return Ok(vtree::read(model)?);
    }
    let (mesh, _) = mesh::load(model, &CleanOptions::default())?;
    let bar = indicatif::ProgressBar::new(mesh.vertex_count().saturating_sub(1) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("building the tree [{bar:40}] {pos}/{len} merges")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let (tree, _) = vtree::build(&mesh, &BuildOptions::default(), &mut |done, _| {
        bar.set_position(done as u64)
    })?;
    bar.finish_and_clear();
    Ok(tree)
}

/// Centre and radius of the box around a tree's leaves.
fn bounds(tree: &vtree::VertexTree) -> (glam::Vec3, f32) {
    let leaves = &tree.nodes[..tree.leaf_count as usize];
    let lo = leaves
        .iter()
        .fold(glam::Vec3::INFINITY, |a, n| a.min(n.position()));
    let hi = leaves
        .iter()
        .fold(glam::Vec3::NEG_INFINITY, |a, n| a.max(n.position()));
    (
        (lo + hi) * 0.5,
        ((hi - lo).length() * 0.5).max(f32::MIN_POSITIVE),
    )
}

fn camera_path(kind: PathKind, tree: &vtree::VertexTree, seconds: f32) -> vunify::path::CameraPath {
    use vunify::path::CameraPath;
    let (center, radius) = bounds(tree);
    match kind {
        PathKind::Orbit => CameraPath::orbit(center, radius, seconds),
        PathKind::FlyIn => CameraPath::fly_in(center, radius, seconds),
        PathKind::Flythrough => CameraPath::flythrough(center, radius, seconds),
    }
}

fn path(args: PathArgs) -> Result<()> {
    if !(args.seconds > 0.0 && args.seconds.is_finite()) {
        bail!("--seconds must be a positive number, got {}", args.seconds);
    }
    let tree = load_tree(&args.model)?;
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

#[cfg(feature = "render")]
fn render(args: RenderArgs) -> Result<()> {
    use vunify::refine::{Hierarchy, Mode, Settings};
    use vunify::render::{ColorBy, DrawOptions, Gpu, job};
    if !(args.tau > 0.0 && args.tau.is_finite()) {
        bail!(
            "--tau must be a positive number of pixels, got {}",
            args.tau
        );
    }
    if !(args.fps > 0.0 && args.fps.is_finite()) {
        bail!("--fps must be positive, got {}", args.fps);
    }
    let tree = load_tree(&args.model)?;
    let path = match &args.path {
        Some(p) => vunify::path::CameraPath::load(p)?,
        None => camera_path(PathKind::Orbit, &tree, 10.0),
    };
    let gpu = Gpu::headless()?;
    let h = Hierarchy::new(&tree);
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
            ColorChoice::Depth => ColorBy::Depth,
            ColorChoice::Error => ColorBy::Error,
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
        out_dir: args.out.clone(),
    };
    println!(
        "rendering {} on {} at {}x{}",
        args.model.display(),
        gpu.adapter_name(),
        args.size[0],
        args.size[1]
    );
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template("frames [{bar:40}] {pos}/{len} ({eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let summary = job::render_path(&gpu, &h, &path, &job, &mut |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    print_summary(&summary, &args.out);
    Ok(())
}

#[cfg(feature = "render")]
fn print_summary(s: &vunify::render::job::Summary, out: &Path) {
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

fn view(args: ViewCliArgs) -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let model = args
        .model
        .clone()
        .unwrap_or_else(|| root.join(DEFAULT_MODEL));
    if !has_display() {
        println!(
            "vunify: no display (DISPLAY and WAYLAND_DISPLAY are unset); rendering the default camera path \
             headless instead"
        );
        let tree = load_tree(&model)?;
        let file = std::env::temp_dir().join(format!("vunify-view-{}.vtree", std::process::id()));
        vtree::write(&tree, &file)?;
        let result = headless_default_path(&file);
        let _ = std::fs::remove_file(&file);
        return result;
    }
    run_viewer(model, args)
}

#[cfg(not(feature = "render"))]
fn render(_: RenderArgs) -> Result<()> {
    bail!(
        "this vunify was built without the `render` feature: rebuild with default features to render"
    )
}

#[cfg(not(feature = "viewer"))]
fn run_viewer(_: PathBuf, _: ViewCliArgs) -> Result<()> {
    bail!(
        "this vunify was built without the `viewer` feature: rebuild with default features to view"
    )
}

#[cfg(feature = "viewer")]
fn run_viewer(model: PathBuf, args: ViewCliArgs) -> Result<()> {
    let script = match (&args.script, args.frames) {
        (Some(file), _) => {
            Some(vunify::app::script::Script::load(file).map_err(anyhow::Error::msg)?)
        }
        (None, Some(frames)) => Some(vunify::app::script::Script::simple(
            frames,
            args.screenshot.clone(),
        )),
        (None, None) => None,
    };
    vunify::app::run(vunify::app::ViewArgs {
        model,
        script,
        size: args.size,
    })
}

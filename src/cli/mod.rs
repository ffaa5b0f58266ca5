//! The `vunify` command line: one file per command. Each command's clap struct converts into the
//! library's option types (the defaults live there, once); library errors are typed, and here, at
//! the application edge, they become `anyhow` messages for the user.

mod build;
mod cells;
mod default_job;
mod extract;
mod info;
mod measure;
mod path;
mod radiosity;
mod render;
mod simplify;
mod superfaces;
mod view;

use anyhow::Result;
use clap::{Parser, Subcommand};

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
pub struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Build the vertex tree of a mesh (.obj, .ply, .off, optionally .xz; .gltf, .glb) and write it as .vtree.
    Build(build::BuildArgs),
    /// Build one cell of a build planned with `vunify build --cell-triangles N --plan DIR`: reads
    /// DIR/cell-I.in, writes DIR/cell-I.out (docs/DISTRIBUTED.md).
    Cell(cells::CellArgs),
    /// Finish a planned build once its cells are built: the levels above the cells, written as
    /// one .vtree, byte for byte the one-process build's.
    Join(cells::JoinArgs),
    /// Print what a .vtree file holds.
    Info(info::InfoArgs),
    /// Take a static level of detail from a .vtree and write it as OBJ, PLY, OFF or glTF (textures and materials kept).
    Extract(extract::ExtractArgs),
    /// Write a camera path (JSON) around a model: an orbit, a fly-in (far to near, as in Tao et al.'s
    /// Fig. 6) or a flythrough (close past and through the model).
    Path(path::PathArgs),
    /// Render a camera path over a model headless (PNG frames, stats.csv, a contact sheet); with
    /// --compare, measure the LOD against the full mesh frame by frame.
    Render(render::RenderArgs),
    /// Fly through a model in the interactive viewer (winit + egui); with no display, render the
    /// default camera path headless instead.
    View(view::ViewArgs),
    /// Symmetric Hausdorff distance between two meshes (Metro-style dense sampling), or with
    /// --certified, proven lower and upper bounds on it.
    Measure(measure::MeasureArgs),
    /// Simplify a mesh within a distance ε: certified both ways (bounded), or inside Zou, Shen
    /// and Peng's envelopes (offset-patch, single-envelope, cohen).
    Simplify(simplify::SimplifyArgs),
    /// Light a scene (OBJ + MTL) by progressive refinement radiosity and write the lit mesh (PLY
    /// or OBJ with per-vertex radiosity).
    Radiosity(radiosity::RadiosityArgs),
    /// Simplify a lit mesh Liu and Wu's way: superfaces of coplanar patches of similar
    /// radiosity, straightened boundaries, triangulated anew.
    Superfaces(superfaces::SuperfacesArgs),
}

/// Parses the command line and runs the command.
pub fn run() -> Result<()> {
    match Cli::parse().command {
        None => default_job::run(),
        Some(Command::Build(args)) => build::run(args),
        Some(Command::Cell(args)) => cells::run_cell(args),
        Some(Command::Join(args)) => cells::run_join(args),
        Some(Command::Info(args)) => info::run(args),
        Some(Command::Extract(args)) => extract::run(args),
        Some(Command::Path(args)) => path::run(args),
        Some(Command::Render(args)) => render::run(args),
        Some(Command::View(args)) => view::run(args),
        Some(Command::Measure(args)) => measure::run(args),
        Some(Command::Simplify(args)) => simplify::run(args),
        Some(Command::Radiosity(args)) => radiosity::run(args),
        Some(Command::Superfaces(args)) => superfaces::run(args),
    }
}

/// `WIDTHxHEIGHT`, each between 1 and 16384.
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

/// Whether a window can open: `DISPLAY` or `WAYLAND_DISPLAY` is set.
fn has_display() -> bool {
    ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|x| !x.is_empty()))
}

/// A progress bar over `len` steps with `template` around the bar.
fn progress_bar(len: u64, template: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template(template)
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar
}

/// Progress for logs: when standard error is not a terminal (the bar is hidden there), a line every
/// few seconds, so a long job in CI or under `nohup` shows it is alive and how far it got.
struct ProgressLog {
    what: &'static str,
    start: std::time::Instant,
    last: std::time::Instant,
    enabled: bool,
}

impl ProgressLog {
    /// Seconds between lines.
    const EVERY: f64 = 3.0;

    fn new(what: &'static str) -> ProgressLog {
        use std::io::IsTerminal;
        let now = std::time::Instant::now();
        ProgressLog {
            what,
            start: now,
            last: now,
            enabled: !std::io::stderr().is_terminal(),
        }
    }

    fn say(&mut self, message: &str) {
        if self.enabled && self.last.elapsed().as_secs_f64() >= Self::EVERY {
            self.last = std::time::Instant::now();
            eprintln!(
                "{}: {message} ({:.0} s)",
                self.what,
                self.start.elapsed().as_secs_f64()
            );
        }
    }
}

/// Makes Ctrl-C (SIGINT) set `flag` instead of ending the process, so a long job can stop at its
/// next step and still write what it has; a second Ctrl-C ends the process as usual. Written
/// against `libc` directly (already a dependency) rather than a signal crate, for the first
/// compile's sake: a handler that stores one atomic is all it takes.
fn on_interrupt(flag: &'static std::sync::atomic::AtomicBool) {
    #[cfg(unix)]
    {
        use std::sync::atomic::{AtomicPtr, Ordering};
        static FLAG: AtomicPtr<std::sync::atomic::AtomicBool> =
            AtomicPtr::new(std::ptr::null_mut());
        extern "C" fn handler(_: libc::c_int) {
            let flag = FLAG.load(Ordering::SeqCst);
            // SAFETY: FLAG is null or points at a `'static` AtomicBool; both operations are
            // async-signal-safe (an atomic load and store, and `signal`).
            unsafe {
                if let Some(flag) = flag.as_ref() {
                    flag.store(true, Ordering::SeqCst);
                }
                libc::signal(libc::SIGINT, libc::SIG_DFL);
            }
        }
        FLAG.store(
            std::ptr::from_ref(flag).cast_mut(),
            std::sync::atomic::Ordering::SeqCst,
        );
        // SAFETY: `handler` is an `extern "C" fn(c_int)` that only does async-signal-safe work.
        unsafe {
            libc::signal(libc::SIGINT, handler as *const () as libc::sighandler_t);
        }
    }
    #[cfg(not(unix))]
    let _ = flag;
}

/// Bytes a process holds per triangle while it views or renders a tree read whole: measured 184 at
/// 14 M triangles and 178 at 100 M (`vunify render`, 1920 × 1080), 191 for the viewer at 14 M.
const VIEW_BYTES_PER_TRIANGLE: u64 = 190;

/// Warns, before a paged tree is read whole to be viewed or rendered, when that would take more
/// than this machine's memory: a process the kernel stops for want of memory says nothing, after
/// minutes of reading. Nothing for a mesh, an exact tree, or a file that does not open (reading
/// it says why).
fn warn_if_too_large_to_view(model: &std::path::Path) {
    let is_tree = model.extension().and_then(|e| e.to_str()) == Some("vtree");
    let Some(file) = is_tree
        .then(|| vunify::vtree::PagedFile::open(model).ok())
        .flatten()
    else {
        return;
    };
    if let Some(note) = too_large_to_view(
        model,
        file.triangles as u64,
        vunify::memory::physical_bytes(),
    ) {
        eprintln!("{note}");
    }
}

/// The cache a tree that `view` and `render` stream by default may fill (see their `--cache`):
/// `None` when `model` is read whole, that is unless it is a paged tree that can be streamed
/// and reading it whole would take more than half of this machine's memory.
fn stream_by_default(model: &std::path::Path) -> Option<u64> {
    let is_tree = model.extension().and_then(|e| e.to_str()) == Some("vtree");
    let file = is_tree
        .then(|| vunify::vtree::PagedFile::open(model).ok())
        .flatten()?;
    let physical = vunify::memory::physical_bytes()?;
    let need = (file.triangles as u64).saturating_mul(VIEW_BYTES_PER_TRIANGLE);
    let streams = file.leaves_depth_first() && !file.appearance;
    (streams && need > physical / 2).then(|| {
        let size = (physical / 8).clamp(256 << 20, 1 << 30);
        eprintln!(
            "note: {}: reading its {} triangles whole would take about {:.1} GiB; streaming it \
             within {} MiB instead (--cache SIZE to choose)",
            model.display(),
            file.triangles,
            need as f64 / (1u64 << 30) as f64,
            size >> 20
        );
        size
    })
}

/// The warning of [`warn_if_too_large_to_view`] for a tree of `triangles` on a machine of
/// `physical` bytes (unknown: none).
fn too_large_to_view(
    model: &std::path::Path,
    triangles: u64,
    physical: Option<u64>,
) -> Option<String> {
    let need = triangles.saturating_mul(VIEW_BYTES_PER_TRIANGLE);
    let physical = physical?;
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    (need > physical).then(|| {
        format!(
            "warning: {}: its {triangles} triangles are read whole to be viewed, which takes about \
             {:.1} GiB (~{VIEW_BYTES_PER_TRIANGLE} bytes a triangle), more than this machine's \
             {:.1} GiB: it may run out of memory (a tree streamed page by page is not built yet)",
            model.display(),
            gib(need),
            gib(physical)
        )
    })
}

/// A model's tree, read from a .vtree or built from a mesh with the default options, with a progress
/// bar while it builds.
fn load_tree(model: &std::path::Path) -> Result<vunify::vtree::VertexTree> {
    if vunify::radiosity::is_scene(model) {
        // A scene: lit first (as `vunify radiosity` would), then its lit mesh built.
        let lit = std::env::temp_dir().join(format!("vunify-lit-{}.ply", std::process::id()));
        let bar = progress_bar(1000, "lighting the scene [{bar:40}] {msg} ({elapsed})");
        vunify::radiosity::light(model, &lit, &mut |share, what| {
            bar.set_position((share * 1000.0) as u64);
            bar.set_message(what.to_string());
        })
        .map_err(anyhow::Error::msg)?;
        bar.finish_and_clear();
        let tree = load_tree(&lit);
        let _ = std::fs::remove_file(&lit);
        return tree;
    }
    let bar = progress_bar(0, "building the tree [{bar:40}] {pos}/{len} merges");
    let tree = vunify::vtree::load_or_build(
        model,
        &vunify::vtree::BuildOptions::default(),
        &mut |done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        },
    )?;
    bar.finish_and_clear();
    Ok(tree)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The warning comes exactly when the estimate passes the machine's memory, and says how
    /// much it needs; on a machine whose memory is unknown, never.
    #[test]
    fn a_tree_too_large_to_view_is_warned_of() {
        let model = std::path::Path::new("city.vtree");
        let gib = 1u64 << 30;
        let note = too_large_to_view(model, 100_000_000, Some(16 * gib)).expect("17.7 GiB > 16");
        assert!(
            note.contains("city.vtree") && note.contains("17.7 GiB"),
            "{note}"
        );
        assert!(note.contains("16.0 GiB"), "{note}");
        assert_eq!(too_large_to_view(model, 100_000_000, Some(24 * gib)), None);
        assert_eq!(too_large_to_view(model, 100_000_000, None), None);
        let just = 16 * gib / VIEW_BYTES_PER_TRIANGLE;
        assert_eq!(too_large_to_view(model, just, Some(16 * gib)), None);
        assert!(too_large_to_view(model, just + 1, Some(16 * gib)).is_some());
    }
}

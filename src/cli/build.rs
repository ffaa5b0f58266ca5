//! `vunify build`: a mesh's vertex tree, written as `.vtree`.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vunify::mesh::{self, CleanOptions};
use vunify::simplify::Metric;
use vunify::simplify::metric::HybridWeights;
use vunify::vtree::{self, BuildOptions, Schedule};

#[derive(Args)]
#[command(group(clap::ArgGroup::new("cells").args(["cell_triangles", "memory"])))]
pub struct BuildArgs {
    /// Input mesh or scene: .obj (objects and groups become parts), .ply, .off (any may end in .xz),
    /// or glTF 2.0 .gltf / .glb (the default scene flattened; base colour textures and texture
    /// coordinates go through the tree, docs/APPEARANCE.md).
    pub input: PathBuf,
    /// Output .vtree file (written atomically). Default: the input's name with .vtree, in the current directory.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// How merges are priced: qem (quadric error, optimal position), qem-midpoint, edge-length, or
    /// hybrid (Tao et al.'s w1·squared distance + w2·feature error).
    #[arg(long, value_enum, default_value_t = BuildOptions::default().metric)]
    metric: Metric,
    /// Merge order: passes (default; non-overlapping cheapest merges per pass, as meshoptimizer does)
    /// or greedy (strictly the cheapest pair each time, the paper's algorithm; slower).
    #[arg(long, value_enum, default_value_t = BuildOptions::default().schedule)]
    schedule: Schedule,
    /// Vertices without an edge between them are merge candidates when closer than this fraction of
    /// the bounding-box diagonal (0 turns such pairs off until separate parts must be joined).
    #[arg(long, default_value_t = BuildOptions::default().pair_distance)]
    pair_distance: f32,
    /// At most this many nearest non-edge partners per vertex.
    #[arg(long, default_value_t = BuildOptions::default().max_pairs_per_vertex)]
    max_pairs: usize,
    /// The paper's θ, degrees: an edge whose dihedral angle is below it is a sharp feature (180 = flat).
    #[arg(long, default_value_t = BuildOptions::default().sharp_angle_deg)]
    sharp_angle: f32,
    /// Hybrid metric: weight w1 of the squared distance (in mean edge lengths).
    #[arg(long, default_value_t = HybridWeights::default().distance)]
    w_dist: f32,
    /// Hybrid metric: weight w2 of the feature error (Tables 1 and 2).
    #[arg(long, default_value_t = HybridWeights::default().feature)]
    w_feature: f32,
    /// For meshes with vertex colours or textures: a full channel's colour difference counts like a
    /// deviation of this many bounding-box diagonals, in the merge order and in the nodes' errors; a
    /// texture's slide over the surface counts as its length, in the merge order (0: shape only).
    #[arg(long, default_value_t = BuildOptions::default().color_weight)]
    color_weight: f32,
    /// Build in cells of at most this many triangles, split along a kd-tree, every core building
    /// cells at once; each cell's border is locked, then sibling cells are joined and built on,
    /// level by level, to one root (docs/VERTEX_TREE.md). The result is one vertex tree like the
    /// whole build's, of slightly lower quality. Meshes with vertex colours, texture coordinates or
    /// materials, and meshes of at most N triangles, are built whole. Default: the whole mesh at
    /// once while that fits in three quarters of this machine's memory (a whole build peaks at
    /// about 300 bytes a triangle), beyond that in the cells that budget allows, at most
    /// 1,000,000 (a note says so; a huge N builds whole anyway).
    #[arg(long, value_name = "N")]
    cell_triangles: Option<usize>,
    /// Keep the process's peak resident memory within SIZE (bytes, or with K, M, G or T for
    /// powers of 1024: 64M, 8G, 1.5G): whole while a whole build fits, else in the largest cells
    /// that do, chosen after the input is read from a measured model (docs/VERTEX_TREE.md,
    /// "A budget"). A build in cells needs about 135 bytes a triangle however small its cells: a
    /// SIZE below what the input needs is refused, saying how much would do.
    #[arg(long, value_name = "SIZE", value_parser = parse_memory)]
    memory: Option<u64>,
    /// With --cell-triangles or --memory: do not build, but write the plan of a build in separate steps to
    /// the folder DIR (shared by every machine that runs a step): then `vunify cell DIR --index I`
    /// for each cell I (any order, anywhere; a batch system's array index works too), then
    /// `vunify join DIR -o OUT.vtree`, whose tree is byte for byte this command's without --plan
    /// (docs/DISTRIBUTED.md).
    #[arg(long, value_name = "DIR", requires = "cells")]
    plan: Option<PathBuf>,
    /// Keep vertices with identical positions apart (welding is on by default).
    #[arg(long)]
    no_weld: bool,
    /// Write every node exactly as built (84 bytes of f32s, format version 1 to 3) instead of the
    /// default paged file (version 6: pages of a few thousand nodes, each checksummed; positions,
    /// bounds and errors quantised, with every error and bound widened by what quantising moved;
    /// about a third of the size).
    #[arg(long)]
    pub exact: bool,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

impl BuildArgs {
    fn options(&self) -> Result<BuildOptions> {
        if !(self.pair_distance >= 0.0 && self.pair_distance.is_finite()) {
            bail!(
                "--pair-distance must be a non-negative number, got {}",
                self.pair_distance
            );
        }
        if !(self.sharp_angle > 0.0 && self.sharp_angle <= 180.0) {
            bail!(
                "--sharp-angle must be in (0, 180] degrees, got {}",
                self.sharp_angle
            );
        }
        if !(self.color_weight >= 0.0 && self.color_weight.is_finite()) {
            bail!(
                "--color-weight must be a non-negative number, got {}",
                self.color_weight
            );
        }
        Ok(BuildOptions {
            color_weight: self.color_weight,
            metric: self.metric,
            schedule: self.schedule,
            pair_distance: self.pair_distance,
            max_pairs_per_vertex: self.max_pairs,
            sharp_angle_deg: self.sharp_angle,
            hybrid: HybridWeights {
                distance: self.w_dist,
                feature: self.w_feature,
            },
        })
    }
}

pub fn run(args: BuildArgs) -> Result<()> {
    let options = args.options()?;
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.input));
    let clean = CleanOptions {
        weld: !args.no_weld,
    };
    if args.cell_triangles == Some(0) {
        bail!("--cell-triangles must be at least 1");
    }
    if args.cell_triangles.is_some() && options.schedule == Schedule::Greedy {
        bail!("--cell-triangles builds with the passes schedule; drop --schedule greedy");
    }
    let how = match (args.cell_triangles, args.memory) {
        (Some(cells), _) => How::Cells(cells),
        (None, Some(bytes)) => How::Within(bytes),
        (None, None) => How::Whole,
    };
    if let Some(dir) = &args.plan {
        return super::cells::plan(&args.input, &options, &clean, how, dir, args.json);
    }
    let encoding = encoding(args.exact);
    build_and_write(
        &args.input,
        &output,
        &options,
        &clean,
        how,
        encoding,
        args.json,
    )
}

/// The file layout `--exact` asks for.
pub fn encoding(exact: bool) -> vtree::Encoding {
    if exact {
        vtree::Encoding::Exact
    } else {
        vtree::Encoding::Paged
    }
}

/// How `build_and_write` builds the tree.
#[derive(Clone, Copy)]
pub enum How<'a> {
    /// The whole mesh at once.
    Whole,
    /// In cells of at most this many triangles.
    Cells(usize),
    /// Within this many bytes of resident memory: whole, or in the cells that fit.
    Within(u64),
    /// From the cell outputs of a plan in this folder, made with this cell size.
    Join(&'a Path, usize),
}

/// `--memory SIZE`: bytes, or a number with K, M, G or T (powers of 1024; an `iB` or `B` after
/// it is allowed).
pub fn parse_memory(text: &str) -> Result<u64, String> {
    let trimmed = text.trim();
    let lower = trimmed.to_ascii_lowercase();
    let number = lower.trim_end_matches("ib").trim_end_matches('b');
    let (digits, shift) = match number.chars().last() {
        Some('k') => (&number[..number.len() - 1], 10),
        Some('m') => (&number[..number.len() - 1], 20),
        Some('g') => (&number[..number.len() - 1], 30),
        Some('t') => (&number[..number.len() - 1], 40),
        _ => (number, 0),
    };
    let value: f64 = digits.trim().parse().map_err(|_| {
        format!("`{trimmed}` is not a size: give bytes, or a number with K, M, G or T (64M, 8G)")
    })?;
    let bytes = value * (1u64 << shift) as f64;
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("`{trimmed}` is not a size of memory"));
    }
    Ok(bytes as u64)
}

fn mib(bytes: u64) -> String {
    if bytes >= 10 << 30 {
        format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
    } else {
        format!("{} MiB", bytes.div_ceil(1 << 20))
    }
}

/// `--memory`: the cells that keep `mesh`'s build within `budget` bytes (`None`: whole), or why
/// none do.
pub fn cells_within(input: &Path, mesh: &mesh::Mesh, budget: u64) -> Result<Option<usize>> {
    let threads = rayon::current_num_threads();
    match vtree::cells_within(mesh, budget, threads) {
        Ok(cells) => Ok(cells),
        Err(too_small) => {
            let why = if too_small.whole_only {
                "it is built whole (colours, texture coordinates and materials are not built in \
                 cells yet, and a small mesh fits in one), at about 300 bytes a triangle"
                    .to_string()
            } else {
                format!(
                    "a build in cells keeps about {} bytes a triangle however small its cells",
                    vtree::CELLS_FLOOR_BYTES_PER_TRIANGLE
                )
            };
            bail!(
                "--memory {} is too little to build {} ({} triangles): {why}, so it needs \
                 about {}; give --memory {}M or more",
                mib(budget),
                input.display(),
                mesh.triangle_count(),
                mib(too_small.needed),
                too_small.needed.div_ceil(1 << 20)
            )
        }
    }
}

/// What `how` comes to for `mesh`: the default's cells, or a budget's (with a note), or as given.
pub fn resolve<'a>(how: How<'a>, input: &Path, mesh: &mesh::Mesh) -> Result<How<'a>> {
    Ok(match how {
        How::Whole => default_how(input, mesh),
        How::Within(budget) => match cells_within(input, mesh, budget)? {
            Some(cells) => {
                eprintln!(
                    "note: {}: in cells of {cells} triangles to stay within --memory {} \
                     (estimated peak {})",
                    input.display(),
                    mib(budget),
                    mib(vtree::cells_build_bytes(
                        mesh.triangle_count(),
                        cells,
                        rayon::current_num_threads()
                    ))
                );
                How::Cells(cells)
            }
            None => How::Whole,
        },
        how => how,
    })
}

/// How a build that was given no cells goes: whole, unless that would not fit in memory (see
/// [`vtree::default_cells`]); a note says when it is built in cells.
fn default_how(input: &Path, mesh: &mesh::Mesh) -> How<'static> {
    let physical = vunify::memory::physical_bytes();
    match vtree::default_cells(mesh, physical, rayon::current_num_threads()) {
        Some(cells) => {
            let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
            eprintln!(
                "note: {}: built whole, its {} triangles would need about {:.1} GiB, more than \
                 three quarters of this machine's {:.1} GiB: building it in cells of {cells} \
                 triangles (--cell-triangles N to choose, a huge N for whole)",
                input.display(),
                mesh.triangle_count(),
                gib(mesh.triangle_count() as u64 * vtree::WHOLE_BUILD_BYTES_PER_TRIANGLE),
                gib(physical.unwrap_or(0))
            );
            How::Cells(cells)
        }
        None => How::Whole,
    }
}

/// The input's file name with its mesh extension (and any `.xz`) replaced by `.vtree`.
fn default_output(input: &Path) -> PathBuf {
    let name = input
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let stem = name.trim_end_matches(".xz");
    let stem = stem.rsplit_once('.').map_or(stem, |(s, _)| s);
    PathBuf::from(format!("{stem}.vtree"))
}

/// Loads `input`, builds its tree with a progress bar, writes it atomically to `output` and prints
/// a summary (text or JSON).
pub fn build_and_write(
    input: &Path,
    output: &Path,
    options: &BuildOptions,
    clean: &CleanOptions,
    how: How,
    encoding: vtree::Encoding,
    json: bool,
) -> Result<()> {
    let t0 = Instant::now();
    let (mesh, cleaned) = mesh::load(input, clean)?;
    vunify::memory::trace_phase("loading");
    let load_secs = t0.elapsed().as_secs_f64();
    for note in &cleaned.notes {
        eprintln!("note: {}: {note}", input.display());
    }
    let budget = match how {
        How::Within(bytes) => Some(bytes),
        _ => None,
    };
    let how = resolve(how, input, &mesh)?;
    let bar = super::progress_bar(
        mesh.vertex_count().saturating_sub(1) as u64,
        "{msg} [{bar:40}] {pos}/{len} merges ({eta})",
    );
    bar.set_message("building");
    let mut progress = |done: usize, _| bar.set_position(done as u64);
    let (tree, stats, cell_triangles) = match how {
        How::Whole => {
            let (tree, stats) = vtree::build(&mesh, options, &mut progress)?;
            (tree, stats, 0)
        }
        How::Cells(cells) => {
            let folder = output.parent().filter(|p| !p.as_os_str().is_empty());
            let spill = folder.unwrap_or(std::path::Path::new("."));
            let (tree, stats) =
                vtree::build_partitioned(&mesh, options, cells, spill, &mut progress)?;
            (tree, stats, cells)
        }
        How::Join(dir, cells) => {
            let (tree, stats) = vtree::cells::join(&mesh, options, cells, dir, &mut progress)?;
            (tree, stats, cells)
        }
        How::Within(_) => unreachable!("resolved to whole or cells"),
    };
    bar.finish_and_clear();
    // The input is not read again: it goes before the tree is encoded, the build's last peak.
    let (vertices, triangles, parts) =
        (mesh.vertex_count(), mesh.triangle_count(), mesh.parts.len());
    drop(mesh);
    vtree::write_with(&tree, output, encoding)
        .with_context(|| format!("cannot write {}", output.display()))?;
    let file_bytes = std::fs::metadata(output).map_or(0, |m| m.len());
    let peak = vunify::memory::peak_resident_bytes();
    if json {
        let json = serde_json::json!({
            "input": input, "output": output, "metric": options.metric.name(),
            "vertices": vertices, "triangles": triangles, "parts": parts,
            "cleaned": cleaned, "build": stats, "load_seconds": load_secs, "peak_memory_bytes": peak,
            "memory_budget_bytes": budget,
            "file_bytes": file_bytes,
        });
        println!("{}", serde_json::to_string_pretty(&json)?);
        return Ok(());
    }
    println!("input      {}", input.display());
    println!("           {vertices} vertices, {triangles} triangles, {parts} part(s)");
    println!(
        "cleaned    {} welded, {} unused vertices dropped; {} degenerate and {} duplicate faces dropped",
        cleaned.welded_vertices,
        cleaned.unused_vertices,
        cleaned.degenerate_faces,
        cleaned.duplicate_faces
    );
    println!(
        "metric     {}, {:?} schedule ({} rounds, {} pairs priced)",
        options.metric.name(),
        options.schedule,
        stats.rounds,
        stats.pricings
    );
    println!(
        "tree       {} nodes ({} leaves), one root, depth {}",
        stats.nodes, stats.leaves, stats.depth
    );
    if stats.cells > 0 {
        println!(
            "cells      {} of at most {} triangles, {} levels",
            stats.cells, cell_triangles, stats.levels
        );
    }
    println!(
        "pairs      {} feature edges, {} close non-edge pairs, {} flip deferrals, {} widenings",
        stats.feature_edges, stats.proximity_pairs, stats.flip_deferrals, stats.widenings
    );
    println!(
        "time       load {load_secs:.2} s, build {:.2} s",
        stats.seconds
    );
    let layout = match encoding {
        vtree::Encoding::Paged => "paged, quantised",
        vtree::Encoding::Exact => "exact",
    };
    println!(
        "file       {:.1} MB, {:.1} bytes a triangle ({layout})",
        file_bytes as f64 / 1e6,
        file_bytes as f64 / triangles.max(1) as f64
    );
    let p = &stats.phases;
    println!(
        "phases     features {:.2} s, close pairs {:.2} s, leaves {:.2} s, pricing {:.2} s, merging {:.2} s, re-pricing {:.2} s",
        p.features, p.close_pairs, p.leaves, p.pricing, p.merging, p.repricing
    );
    if let Some(p) = peak {
        println!(
            "memory     process peak {:.1} MiB, input included ({:.0} bytes per input triangle){}",
            p as f64 / 1048576.0,
            p as f64 / triangles as f64,
            budget.map_or(String::new(), |b| format!(", --memory {}", mib(b)))
        );
    }
    println!("wrote      {}", output.display());
    Ok(())
}

//! `vunify info`: what a `.vtree` holds.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use vunify::vtree;

#[derive(Args)]
pub struct InfoArgs {
    /// The .vtree file.
    file: PathBuf,
    /// Also replay the build order and check every cut (slower).
    #[arg(long)]
    check: bool,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// What `info` says of a tree: from the whole tree, or (`tree` none) from a paged tree without
/// appearance read a page at a time.
struct Facts {
    leaves: u32,
    nodes: u32,
    triangles: u32,
    depth: u32,
    metric: vunify::simplify::Metric,
    colors: bool,
    normals: bool,
    parts: Vec<vtree::PartInfo>,
    root_error: f32,
    diagonal: f32,
    position_error: f32,
    tree: Option<vtree::VertexTree>,
}

impl Facts {
    fn of_tree(tree: vtree::VertexTree) -> Facts {
        Facts {
            leaves: tree.leaf_count,
            nodes: tree.nodes.len() as u32,
            triangles: tree.triangles.len() as u32,
            depth: tree.depth(),
            metric: tree.metric,
            colors: tree.has_colors,
            normals: tree.has_normals,
            parts: tree.parts.clone(),
            root_error: tree.nodes[tree.root() as usize].error,
            diagonal: tree.diagonal(),
            position_error: tree.position_error,
            tree: Some(tree),
        }
    }

    /// A paged tree without appearance, its pages read in turn (a few in memory at a time: a
    /// 100 M-triangle tree answers without being read whole); `None` for any other file.
    fn of_pages(file: &std::path::Path) -> Result<Option<Facts>> {
        let pages = match vtree::PagedFile::open(file) {
            Ok(pages) if !pages.appearance => pages,
            Ok(_) => return Ok(None),
            Err(e) if matches!(e.kind, vtree::FormatErrorKind::WrongVersion { .. }) => {
                return Ok(None);
            }
            Err(e) => return Err(e.into()),
        };
        let survey = pages.survey()?;
        let (lo, hi) = survey.leaf_box;
        Ok(Some(Facts {
            leaves: pages.leaf_count,
            nodes: pages.node_count,
            triangles: pages.triangles,
            depth: survey.depth,
            metric: pages.metric,
            colors: pages.has_colors,
            normals: pages.has_normals,
            root_error: survey.root.map_or(0.0, |r| r.error),
            diagonal: vunify::mesh::diagonal_of(hi - lo),
            position_error: pages.position_error,
            parts: pages.parts,
            tree: None,
        }))
    }
}

pub fn run(args: InfoArgs) -> Result<()> {
    let InfoArgs { file, check, json } = args;
    // `--check` replays the whole tree: read whole, not surveyed first as well.
    let pages = if check { None } else { Facts::of_pages(&file)? };
    let facts = match pages {
        Some(facts) => facts,
        None => {
            let tree = vtree::read(&file)?;
            if check {
                vtree::check_cut(&tree).map_err(|e| {
                    anyhow::anyhow!("{}: the build order is inconsistent: {e}", file.display())
                })?;
            }
            Facts::of_tree(tree)
        }
    };
    let tree = facts.tree.as_ref();
    let file_bytes = std::fs::metadata(&file).map_or(0, |m| m.len());
    let version = format_version(&file)?;
    let textures = tree
        .and_then(|t| t.appearance.as_ref())
        .map_or(0, |a| a.textures.len());
    let materials: Vec<&vunify::mesh::Material> = tree
        .iter()
        .flat_map(|t| t.materials.iter().flat_map(|m| &m.list))
        .collect();
    let wedges = tree.and_then(|t| t.wedges.as_ref());
    if json {
        let j = serde_json::json!({
            "file": file, "leaves": facts.leaves, "nodes": facts.nodes, "triangles": facts.triangles,
            "depth": facts.depth, "metric": facts.metric.name(), "colors": facts.colors, "normals": facts.normals,
            "parts": facts.parts, "textured": tree.is_some_and(|t| t.appearance.is_some()), "images": textures,
            "materials": materials, "wedges": wedges.map(|w| w.len()),
            "leaf_wedges": wedges.map(|w| w.node.iter().filter(|&&u| u < facts.leaves).count()),
            "root_error": facts.root_error, "diagonal": facts.diagonal, "checked": check,
            "position_error": facts.position_error, "file_bytes": file_bytes, "version": version,
        });
        println!("{}", serde_json::to_string_pretty(&j)?);
        return Ok(());
    }
    println!("file       {}", file.display());
    println!(
        "tree       {} nodes ({} leaves), depth {}, metric {}",
        facts.nodes,
        facts.leaves,
        facts.depth,
        facts.metric.name()
    );
    println!("triangles  {}", facts.triangles);
    let per_triangle = file_bytes as f64 / facts.triangles.max(1) as f64;
    let diagonal = facts.diagonal;
    if facts.position_error > 0.0 {
        println!(
            "stored     paged, {per_triangle:.1} bytes a triangle; positions within {:.3e} ({:.5} % of the diagonal), every error and bound widened by it",
            facts.position_error,
            100.0 * facts.position_error / diagonal.max(f32::MIN_POSITIVE)
        );
    } else {
        println!("stored     exact, {per_triangle:.1} bytes a triangle");
    }
    println!("format     version {version}{}", version_note(version));
    println!(
        "attributes colours: {}, normals: {}",
        facts.colors, facts.normals
    );
    println!(
        "root       error {:.4} ({:.4} % of the diagonal {:.4})",
        facts.root_error,
        100.0 * facts.root_error / diagonal.max(f32::MIN_POSITIVE),
        diagonal
    );
    if tree.is_some_and(|t| t.appearance.is_some()) {
        println!("textures   texture coordinates, {textures} images");
    }
    if let (Some(w), Some(tree)) = (wedges, tree) {
        let leaves = w.node.iter().filter(|&&u| u < tree.leaf_count).count();
        println!(
            "wedges     {} ({leaves} at the leaves: the input's vertices; {} at the {} internal nodes)",
            w.len(),
            w.len() - leaves,
            tree.internal_count()
        );
    }
    if !materials.is_empty() {
        println!("materials  {}", materials.len());
        for m in materials.iter().take(20) {
            let texture = if m.base_color_texture.is_some() {
                ", base colour texture"
            } else {
                ""
            };
            println!(
                "           {}: {:?}{texture}{}",
                m.name,
                m.alpha_mode,
                if m.double_sided { ", double-sided" } else { "" }
            );
        }
    }
    println!("parts      {}", facts.parts.len());
    for p in facts.parts.iter().take(20) {
        println!("           {:>8} triangles  {}", p.triangles, p.name);
    }
    if facts.parts.len() > 20 {
        println!("           ... and {} more", facts.parts.len() - 20);
    }
    if check {
        println!("check      every cut of the build order is a valid mesh");
    }
    Ok(())
}

/// The file's format version, from its header (the reader has checked it).
fn format_version(file: &std::path::Path) -> Result<u32> {
    use std::io::Read;
    let mut head = [0u8; 12];
    std::fs::File::open(file)?.read_exact(&mut head)?;
    Ok(u32::from_le_bytes([head[8], head[9], head[10], head[11]]))
}

/// What `info` says of a file's format version.
fn version_note(version: u32) -> &'static str {
    match version {
        6.. => {
            ": leaves numbered depth-first, each page knows the leaves under its nodes and how far \
             normals turn below them"
        }
        5 => {
            ": leaves numbered depth-first, each page knows the leaves under its nodes (rebuild \
             with `vunify build` for version 6, which a streamed view refines exactly)"
        }
        4 => ": leaves in the input's order (rebuild with `vunify build` for version 6)",
        _ => "",
    }
}

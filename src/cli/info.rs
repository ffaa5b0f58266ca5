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

pub fn run(args: InfoArgs) -> Result<()> {
    let InfoArgs { file, check, json } = args;
    let tree = vtree::read(&file)?;
    if check {
        vtree::check_cut(&tree).map_err(|e| {
            anyhow::anyhow!("{}: the build order is inconsistent: {e}", file.display())
        })?;
    }
    let root = &tree.nodes[tree.root() as usize];
    let file_bytes = std::fs::metadata(&file).map_or(0, |m| m.len());
    let textures = tree.appearance.as_ref().map_or(0, |a| a.textures.len());
    let materials: Vec<&vunify::mesh::Material> =
        tree.materials.iter().flat_map(|m| &m.list).collect();
    if json {
        let j = serde_json::json!({
            "file": file, "leaves": tree.leaf_count, "nodes": tree.nodes.len(), "triangles": tree.triangles.len(),
            "depth": tree.depth(), "metric": tree.metric.name(), "colors": tree.has_colors, "normals": tree.has_normals,
            "parts": tree.parts, "textured": tree.appearance.is_some(), "images": textures,
            "materials": materials, "wedges": tree.wedges.as_ref().map(|w| w.len()),
            "leaf_wedges": tree.wedges.as_ref().map(|w| w.node.iter().filter(|&&u| u < tree.leaf_count).count()),
            "root_error": root.error, "diagonal": tree.diagonal(), "checked": check,
            "position_error": tree.position_error, "file_bytes": file_bytes,
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
    let per_triangle = file_bytes as f64 / tree.triangles.len().max(1) as f64;
    if tree.position_error > 0.0 {
        println!(
            "stored     paged, {per_triangle:.1} bytes a triangle; positions within {:.3e} ({:.5} % of the diagonal), every error and bound widened by it",
            tree.position_error,
            100.0 * tree.position_error / tree.diagonal().max(f32::MIN_POSITIVE)
        );
    } else {
        println!("stored     exact, {per_triangle:.1} bytes a triangle");
    }
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
    if tree.appearance.is_some() {
        println!("textures   texture coordinates, {textures} images");
    }
    if let Some(w) = &tree.wedges {
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

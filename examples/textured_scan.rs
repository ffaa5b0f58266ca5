//! Makes a textured test model from any mesh, as a scanned asset would come: texture charts with
//! seams (each triangle goes to the chart of its normal's dominant axis, six charts packed 3 × 2
//! in one atlas, so every chart border is a UV seam), a generated 1024² texture (a coloured
//! checker with a smooth gradient: stretch, seams and smearing all show), written as `.glb`.
//!
//!   cargo run --release --example textured_scan -- IN.obj[.xz] OUT.glb
//!
//! Also writes `OUT.plain.ply`, the same geometry without any attribute, for comparisons.

use glam::{Vec2, Vec3};
use std::sync::Arc;
use vunify::mesh::{CleanOptions, Material, Mesh};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, output] = args.as_slice() else {
        return Err("usage: textured_scan IN OUT.glb".into());
    };
    let (mesh, _) = vunify::mesh::load(input.as_ref(), &CleanOptions::default())?;
    let plain = Mesh::from_triangles(mesh.positions.clone(), mesh.triangles.clone());
    let plain_path = std::path::Path::new(output).with_extension("plain.ply");
    vunify::export::write_mesh(&plain, &plain_path)?;
    let textured = charted(&mesh);
    vunify::export::write_mesh(&textured, output.as_ref())?;
    println!(
        "wrote {output}: {} vertices ({} at seams), {} triangles; and {}",
        textured.positions.len(),
        textured.positions.len() - mesh.positions.len(),
        textured.triangles.len(),
        plain_path.display()
    );
    Ok(())
}

/// `mesh` with six planar charts: a vertex is split once per chart its triangles fall in.
fn charted(mesh: &Mesh) -> Mesh {
    let (lo, hi) = mesh.bounds();
    let extent = (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
    let mut index = std::collections::HashMap::new();
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    let mut triangles = Vec::with_capacity(mesh.triangles.len());
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
        let n = (b - a).cross(c - a);
        let axis = n.abs().max_position();
        let chart = 2 * axis + usize::from(n[axis] < 0.0);
        let (tile_x, tile_y) = ((chart % 3) as f32, (chart / 3) as f32);
        triangles.push(t.map(|v| {
            *index.entry((v, chart)).or_insert_with(|| {
                let p = (mesh.positions[v as usize] - lo) / extent;
                let (s, r) = match axis {
                    0 => (p.y, p.z),
                    1 => (p.x, p.z),
                    _ => (p.x, p.y),
                };
                // A margin inside each tile so that mipmaps do not bleed between charts.
                let uv = Vec2::new(tile_x + 0.05 + 0.9 * s, tile_y + 0.05 + 0.9 * r);
                positions.push(mesh.positions[v as usize]);
                uvs.push(uv / Vec2::new(3.0, 2.0));
                positions.len() as u32 - 1
            })
        }));
    }
    let count = positions.len();
    let mut out = Mesh::from_triangles(positions, triangles);
    out.uvs = Some(uvs);
    out.texture_of = Some(vec![0; count]);
    out.textures = vec![Arc::new(texture())];
    out.materials = vec![Material {
        name: "scan".into(),
        base_color_texture: Some(0),
        metallic_factor: 0.0,
        ..Material::default()
    }];
    out.material_of = Some(vec![0; count]);
    out
}

/// A 1024² PNG: a 32-cell checker of two tints over a hue gradient.
fn texture() -> Vec<u8> {
    let size = 1024u32;
    let image = image::RgbImage::from_fn(size, size, |x, y| {
        let (u, v) = (x as f32 / size as f32, y as f32 / size as f32);
        let odd = ((x / 32) + (y / 32)) % 2 == 1;
        let shade = if odd { 0.55 } else { 1.0 };
        let rgb = [
            0.35 + 0.6 * u,
            0.3 + 0.5 * (1.0 - v),
            0.4 + 0.5 * (u * v).sqrt(),
        ];
        image::Rgb(rgb.map(|c| (255.0 * c * shade).round() as u8))
    });
    let mut out = std::io::Cursor::new(Vec::new());
    image
        .write_to(&mut out, image::ImageFormat::Png)
        .expect("a PNG encodes into memory");
    out.into_inner()
}

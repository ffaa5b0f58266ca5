//! Hand-built meshes the tests share (unit tests here, integration tests through `tests/common`),
//! each with its picture. Not part of the public interface.

use crate::mesh::{Material, Mesh};
use glam::{Vec2, Vec3};

/// Tao et al.'s Fig. 2: a tetrahedron (vertices 0–3, faces 0–3) beside a separate triangle
/// (vertices 4 5 6, face 4).
/// ```text
///        3                  6
///       /|\                / \
///      / | \              /   \
///     0--|--2            4-----5
///      \ | /
///       \|/
///        1
/// ```
pub fn fig2() -> Mesh {
    let p = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(5.0, 0.0, 0.0),
        Vec3::new(4.5, 0.0, 1.0),
    ];
    Mesh::from_triangles(
        p,
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2], [4, 5, 6]],
    )
}

/// An axis-aligned box from the origin to `size`, 12 triangles facing out. Corner `i` has x, y, z
/// set from bits 0, 1, 2 of `i`:
/// ```text
///       6-------7
///      /|      /|
///     4-------5 |
///     | 2-----|-3
///     |/      |/
///     0-------1
/// ```
pub fn cuboid(size: Vec3) -> Mesh {
    let p = (0..8)
        .map(|i| Vec3::new((i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2 & 1) as f32) * size)
        .collect();
    let t = vec![
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    Mesh::from_triangles(p, t)
}

/// `mesh` textured as a scan would come: six planar charts (each triangle in the chart of its
/// normal's dominant axis, packed 3 × 2 in one atlas with margins, so every chart border is a UV
/// seam and a vertex is split once per chart its triangles fall in), one material, and a generated
/// 1024² texture ([`checker_texture`]).
pub fn textured_scan(mesh: &Mesh) -> Mesh {
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
    out.textures = vec![std::sync::Arc::new(checker_texture())];
    out.materials = vec![Material {
        name: "scan".into(),
        base_color_texture: Some(0),
        metallic_factor: 0.0,
        ..Material::default()
    }];
    out.material_of = Some(vec![0; count]);
    out
}

/// A 1024² PNG: a 32-cell checker of two tints over a hue gradient (stretch, seams and smearing
/// all show).
pub fn checker_texture() -> Vec<u8> {
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

/// A scene of one textured mesh as exporters write them, as GLB bytes: `mesh` instanced three
/// times under nested transforms (a rotated and scaled root; a group moved and scaled again), one
/// instance mirrored (its node scales x by −1, so its triangles must be rewound), and a ground
/// square of a second, untextured and double-sided material.
///
/// ```text
///   root (rotate 30° about y, scale 0.5)
///   ├── A   translate (−1.2 d, 0, 0)              d: the mesh's largest extent
///   ├── group  translate (1.2 d, 0, 0), scale 0.8
///   │   └── B   rotate 90° about y
///   ├── C   translate (0, 0, 1.5 d), scale (−1, 1, 1)     mirrored
///   └── ground  (a square 5 d wide under the mesh, material "ground")
/// ```
pub fn textured_scene_glb(mesh: &Mesh) -> Vec<u8> {
    use serde_json::json;
    let (lo, hi) = mesh.bounds();
    // Offsets in units of the mesh's size, so that the instances stand apart whatever its scale.
    let d = (hi - lo).max_element();
    let ground = {
        let r = 2.5 * d;
        let y = lo.y;
        let mut g = Mesh::from_triangles(
            vec![
                Vec3::new(-r, y, -r),
                Vec3::new(r, y, -r),
                Vec3::new(r, y, r),
                Vec3::new(-r, y, r),
            ],
            vec![[0, 2, 1], [0, 3, 2]],
        );
        g.materials = vec![Material {
            name: "ground".into(),
            base_color_factor: [0.3, 0.5, 0.25, 1.0],
            metallic_factor: 0.0,
            double_sided: true,
            ..Material::default()
        }];
        g.material_of = Some(vec![0; 4]);
        g
    };
    // Both meshes through one document: the chain writer puts each in a mesh of its own.
    let (mut doc, bin) = crate::export::gltf::chain_document(
        &[
            (mesh, serde_json::Value::Null),
            (&ground, serde_json::Value::Null),
        ],
        None,
    );
    // The ground's primitive names material 0 of its own list: the scene's second material.
    let materials = doc["materials"].as_array().cloned().unwrap_or_default();
    let ground_material = materials.len();
    let mut all = materials;
    all.push(
        json!({"name": "ground", "pbrMetallicRoughness": {"baseColorFactor": [0.3, 0.5, 0.25, 1.0],
        "metallicFactor": 0.0}, "doubleSided": true}),
    );
    doc["materials"] = json!(all);
    for p in doc["meshes"][1]["primitives"]
        .as_array_mut()
        .expect("primitives")
    {
        p["material"] = json!(ground_material);
    }
    let turn = |deg: f32| {
        let q = glam::Quat::from_rotation_y(deg.to_radians());
        [q.x, q.y, q.z, q.w]
    };
    doc["nodes"] = json!([
        {"name": "root", "rotation": turn(30.0), "scale": [0.5, 0.5, 0.5], "children": [1, 2, 4, 5]},
        {"name": "A", "mesh": 0, "translation": [-1.2 * d, 0.0, 0.0]},
        {"name": "group", "translation": [1.2 * d, 0.0, 0.0], "scale": [0.8, 0.8, 0.8], "children": [3]},
        {"name": "B", "mesh": 0, "rotation": turn(90.0)},
        {"name": "C (mirrored)", "mesh": 0, "translation": [0.0, 0.0, 1.5 * d], "scale": [-1.0, 1.0, 1.0]},
        {"name": "ground", "mesh": 1},
    ]);
    doc["scenes"] = json!([{"nodes": [0]}]);
    crate::export::gltf::glb(&doc, bin)
}

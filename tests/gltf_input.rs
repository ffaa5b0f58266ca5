//! glTF 2.0 input: node transforms, winding, quantized and sparse accessors, strips, colours from
//! factors and textures, and bad files as errors naming the accessor (never a panic).

mod common;

use common::models_dir;
use glam::Vec3;
use std::path::Path;
use vunify::mesh::{CleanOptions, Format, parse};

/// Standard base64, for data URIs.
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn le_f32(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A glTF JSON document whose one buffer is `bin` as a data URI; `rest` is the JSON after it.
fn gltf(bin: &[u8], rest: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],{rest}}}"#,
        bin.len(),
        base64(bin)
    )
}

fn read(text: &str) -> Result<vunify::mesh::Mesh, vunify::mesh::InputError> {
    parse(text.as_bytes(), Format::Gltf, Path::new("test.gltf"))
}

/// One triangle, corners (0,0,0), (1,0,0), (0,1,0) wound counter-clockwise seen from +z:
///
/// ```text
///   y
///   2
///   | \
///   0--1  x
/// ```
fn triangle_bin() -> Vec<u8> {
    le_f32(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0])
}

const TRIANGLE_ACCESSORS: &str = r#""bufferViews":[{"buffer":0,"byteLength":36}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}]"#;

fn normal(m: &vunify::mesh::Mesh, t: usize) -> Vec3 {
    let [a, b, c] = m.triangles[t].map(|v| m.positions[v as usize]);
    (b - a).cross(c - a).normalize()
}

/// A node chain: the parent translates by (10, 0, 0), the child mirrors x. Positions land where
/// both put them, and the mirrored triangle is rewound so that it still faces +z.
#[test]
fn node_transforms_and_mirroring() {
    let text = gltf(
        &triangle_bin(),
        &format!(
            r#"{TRIANGLE_ACCESSORS},
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"nodes":[{{"translation":[10,0,0],"children":[1]}},{{"scale":[-1,1,1],"mesh":0}}],
"scenes":[{{"nodes":[0]}}],"scene":0"#
        ),
    );
    let m = read(&text).unwrap();
    assert_eq!(
        m.positions,
        vec![
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(9.0, 0.0, 0.0),
            Vec3::new(10.0, 1.0, 0.0)
        ]
    );
    assert!(
        (normal(&m, 0) - Vec3::Z).length() < 1e-6,
        "{}",
        normal(&m, 0)
    );
}

/// `KHR_mesh_quantization`: positions as normalized shorts (32767 is 1), required by the file;
/// and a strip of four indices, two triangles.
#[test]
fn quantized_positions_and_strips() {
    let mut bin: Vec<u8> = [
        0i16, 0, 0, 0, 32767, 0, 0, 0, 0, 32767, 0, 0, 32767, 32767, 0, 0,
    ]
    .iter()
    .flat_map(|v| v.to_le_bytes())
    .collect();
    bin.extend([0u8, 1, 2, 3]);
    let text = gltf(
        &bin,
        r#""extensionsUsed":["KHR_mesh_quantization"],"extensionsRequired":["KHR_mesh_quantization"],
"bufferViews":[{"buffer":0,"byteLength":32,"byteStride":8},{"buffer":0,"byteOffset":32,"byteLength":4}],
"accessors":[{"bufferView":0,"componentType":5122,"normalized":true,"count":4,"type":"VEC3","min":[0,0,0],"max":[32767,32767,0]},
{"bufferView":1,"componentType":5121,"count":4,"type":"SCALAR"}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"mode":5}]}],
"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]"#,
    );
    let m = read(&text).unwrap();
    assert_eq!(m.positions[3], Vec3::new(1.0, 1.0, 0.0));
    assert_eq!(m.triangles, vec![[0, 1, 2], [2, 1, 3]]);
    assert!((normal(&m, 1) - Vec3::Z).length() < 1e-6);
}

/// A sparse accessor moves the third corner from (0, 1, 0) to (0, 2, 0); the material's base
/// colour factor becomes the vertices' colour.
#[test]
fn sparse_accessors_and_colour_factors() {
    let mut bin = triangle_bin();
    bin.extend(2u32.to_le_bytes());
    bin.extend(le_f32(&[0.0, 2.0, 0.0]));
    let text = gltf(
        &bin,
        r#""bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":4},{"buffer":0,"byteOffset":40,"byteLength":12}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,2,0],
"sparse":{"count":1,"indices":{"bufferView":1,"componentType":5125},"values":{"bufferView":2}}}],
"materials":[{"pbrMetallicRoughness":{"baseColorFactor":[0.5,0.25,1,1]}}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0}]}],
"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]"#,
    );
    let m = read(&text).unwrap();
    assert_eq!(m.positions[2], Vec3::new(0.0, 2.0, 0.0));
    assert_eq!(m.colors.unwrap()[0], Vec3::new(0.5, 0.25, 1.0));
}

/// Bad files name the accessor or buffer and never panic: an index past the vertices, an accessor
/// past its buffer view, a buffer shorter than declared, a file of lines only, not JSON at all.
#[test]
fn bad_files_are_clear_errors() {
    let cases: Vec<(String, &str)> = vec![
        (
            gltf(
                &{
                    let mut b = triangle_bin();
                    b.extend([0u8, 1, 7, 0]);
                    b
                },
                r#""bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":3}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5121,"count":3,"type":"SCALAR"}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]"#,
            ),
            "accessor 1 (primitive 0 of mesh 0's indices) holds index 7",
        ),
        (
            gltf(
                &triangle_bin(),
                r#""bufferViews":[{"buffer":0,"byteLength":24}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]"#,
            ),
            "accessor 0 (POSITION) reads 36 bytes of buffer view 0, which holds 24",
        ),
        (
            gltf(
                &triangle_bin(),
                &format!(
                    r#"{TRIANGLE_ACCESSORS},
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"mode":1}}]}}],"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}]"#
                ),
            ),
            "draws Lines, not triangles",
        ),
        (
            gltf(&triangle_bin(), TRIANGLE_ACCESSORS)
                .replace("\"byteLength\":36,\"uri\"", "\"byteLength\":99,\"uri\""),
            "buffer 0 holds 36 bytes, fewer than the 99 the file declares",
        ),
        ("{ not json".into(), "not a valid glTF file"),
        ("glTF\u{2}\0\0\0".into(), "not a valid glTF file"),
    ];
    for (text, expected) in cases {
        let e = read(&text).expect_err(expected);
        let shown = e.to_string();
        assert!(shown.starts_with("test.gltf: "), "{shown}");
        assert!(
            shown.contains(expected),
            "expected “{expected}” in: {shown}"
        );
    }
}

/// A missing texture is a note and the colour factor, not a failure (through `load`, which keeps
/// notes); an absent `.gltf` file is an error naming it.
#[test]
fn missing_images_are_notes() {
    let dir = std::env::temp_dir().join(format!("vunify-gltf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text = gltf(
        &triangle_bin(),
        &format!(
            r#"{TRIANGLE_ACCESSORS},
"images":[{{"uri":"nowhere.png"}}],"textures":[{{"source":0}}],
"materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[1,0,0,1],"baseColorTexture":{{"index":0}}}}}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}]"#
        ),
    );
    let file = dir.join("t.gltf");
    std::fs::write(&file, text).unwrap();
    let (m, report) = vunify::mesh::load(&file, &CleanOptions::default()).unwrap();
    assert_eq!(m.colors.unwrap()[0], Vec3::X);
    assert!(
        report.notes.iter().any(|n| n.contains("image 0 left out")),
        "{:?}",
        report.notes
    );
    let e = vunify::mesh::load(&dir.join("absent.glb"), &CleanOptions::default()).unwrap_err();
    assert!(e.to_string().contains("absent.glb"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The shared textured models (Khronos samples and Deccer cubes) open with their triangles and
/// colours from their textures.
#[test]
fn textured_models_open_in_colour() {
    let Some(dir) = models_dir() else { return };
    for (file, triangles) in [
        ("textured/Avocado/Avocado.gltf", 682),
        ("textured/WaterBottle/WaterBottle.glb", 6886),
        (
            "textured/DeccerCubesTextured/SM_Deccer_Cubes_Textured.glb",
            60,
        ),
    ] {
        let (m, _) = vunify::mesh::load(&dir.join(file), &CleanOptions::default()).unwrap();
        assert_eq!(m.triangle_count(), triangles, "{file}");
        let colors = m.colors.as_ref().expect(file);
        let spread = colors.iter().fold(Vec3::ZERO, |a, c| a.max(*c))
            - colors.iter().fold(Vec3::ONE, |a, c| a.min(*c));
        assert!(
            spread.max_element() > 0.1,
            "{file}: colours from the texture vary"
        );
    }
}

/// A small coloured mesh with normals: two triangles of a unit square, corners red, green, blue,
/// white.
fn square() -> vunify::mesh::Mesh {
    vunify::mesh::Mesh {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
        colors: Some(vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE]),
        normals: Some(vec![Vec3::Z; 4]),
        triangles: vec![[0, 1, 2], [2, 1, 3]],
        ..Default::default()
    }
}

/// A one-colour PNG of 2 × 2 pixels.
fn png(rgb: [u8; 3]) -> std::sync::Arc<Vec<u8>> {
    let mut out = std::io::Cursor::new(Vec::new());
    image::RgbImage::from_pixel(2, 2, image::Rgb(rgb))
        .write_to(&mut out, image::ImageFormat::Png)
        .unwrap();
    std::sync::Arc::new(out.into_inner())
}

/// [`square`] with two materials, one a triangle:
///
/// ```text
///   2----3    lower left (0 1 2): "leaf", a red texture, a normal map, alpha mask at 0.3
///   | \  |    upper right (2 1 3): "paint", blue, double-sided, vertex colours
///   0----1    (corners 1 and 2 are two vertices each: a material border is a seam)
/// ```
fn two_materials() -> vunify::mesh::Mesh {
    use vunify::mesh::{AlphaMode, Material};
    let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
    vunify::mesh::Mesh {
        positions: vec![p[0], p[1], p[2], p[2], p[1], p[3]],
        colors: Some(vec![
            Vec3::X,
            Vec3::X,
            Vec3::X,
            Vec3::Z,
            Vec3::Z * 0.5,
            Vec3::Z,
        ]),
        normals: Some(vec![Vec3::Z; 6]),
        triangles: vec![[0, 1, 2], [3, 4, 5]],
        parts: vec![vunify::mesh::Part {
            name: "square".into(),
            triangles: 0..2,
        }],
        uvs: Some(vec![
            glam::Vec2::ZERO,
            glam::Vec2::X,
            glam::Vec2::Y,
            glam::Vec2::ZERO,
            glam::Vec2::ZERO,
            glam::Vec2::ZERO,
        ]),
        texture_of: Some(vec![0, 0, 0, u32::MAX, u32::MAX, u32::MAX]),
        textures: vec![png([255, 0, 0]), png([128, 128, 255])],
        materials: vec![
            Material {
                name: "leaf".into(),
                base_color_texture: Some(0),
                normal_texture: Some(1),
                alpha_mode: AlphaMode::Mask,
                alpha_cutoff: 0.3,
                ..Material::default()
            },
            Material {
                name: "paint".into(),
                base_color_factor: [0.0, 0.0, 1.0, 1.0],
                double_sided: true,
                vertex_colors: true,
                ..Material::default()
            },
        ],
        material_of: Some(vec![0, 0, 0, 1, 1, 1]),
        ..Default::default()
    }
}

/// Materials, textures and texture coordinates round-trip through `.glb` and `.gltf` (images
/// beside it): each triangle keeps its material, the mask and double-sidedness, the normal map,
/// and the vertex colours of the untextured one.
#[test]
fn materials_and_textures_round_trip() {
    let dir = std::env::temp_dir().join(format!("vunify-gltf-mat-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let m = two_materials();
    for name in ["m.glb", "m.gltf"] {
        let file = dir.join(name);
        vunify::export::write_mesh(&m, &file).unwrap();
        let back = parse(&std::fs::read(&file).unwrap(), Format::Gltf, &file).unwrap();
        assert_eq!(back.materials.len(), 2, "{name}");
        let of = back.material_of.as_ref().unwrap();
        let leaf = &back.materials[of[back.triangles[0][0] as usize] as usize];
        let paint = &back.materials[of[back.triangles[1][0] as usize] as usize];
        assert_eq!(leaf.name, "leaf");
        assert_eq!(leaf.alpha_mode, vunify::mesh::AlphaMode::Mask);
        assert_eq!(leaf.alpha_cutoff, 0.3);
        assert!(leaf.base_color_texture.is_some() && leaf.normal_texture.is_some());
        assert_eq!(paint.name, "paint");
        assert!(paint.double_sided && paint.vertex_colors);
        assert_eq!(back.textures.len(), 2, "{name}");
        assert_eq!(
            back.uvs.as_ref().unwrap()[..3],
            m.uvs.as_ref().unwrap()[..3]
        );
        // The red texture's mean; the paint's colours as they were (factor × COLOR_0).
        let colors = back.colors.as_ref().unwrap();
        for (v, want) in m.colors.as_ref().unwrap().iter().enumerate() {
            assert!(colors[v].distance(*want) < 1e-5, "{name}: vertex {v}");
        }
    }
    assert!(dir.join("m_image0.png").exists() && dir.join("m_image1.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// [`two_materials`] with its textured triangle's `COLOR_0` a tint: (0.25, 1, 0.5) at corner 0,
/// white at 1 and 2 (its colours, the red texture's mean times the tint, say so too).
fn tinted() -> vunify::mesh::Mesh {
    let mut m = two_materials();
    let tint = Vec3::new(0.25, 1.0, 0.5);
    m.tints = Some(vec![
        tint,
        Vec3::ONE,
        Vec3::ONE,
        Vec3::ONE,
        Vec3::ONE,
        Vec3::ONE,
    ]);
    m.colors.as_mut().unwrap()[0] *= tint;
    m.materials[0].vertex_colors = true;
    m
}

/// glTF's `COLOR_0` on a textured primitive tints the texture: it is read as the tint, kept per
/// wedge by the tree (in both encodings of the file), and written back as `COLOR_0` by every
/// level that `extract` makes.
#[test]
fn texture_tints_go_through_the_tree() {
    let dir = std::env::temp_dir().join(format!("vunify-gltf-tint-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let m = tinted();
    let file = dir.join("t.glb");
    vunify::export::write_mesh(&m, &file).unwrap();
    let back = parse(&std::fs::read(&file).unwrap(), Format::Gltf, &file).unwrap();
    let tints = back.tints.as_ref().expect("a tinted texture has tints");
    let of = back.material_of.as_ref().unwrap();
    let leaf = back.triangles[0].map(|v| v as usize);
    assert_eq!(back.materials[of[leaf[0]] as usize].name, "leaf");
    let want = m.tints.as_ref().unwrap();
    for (k, &v) in leaf.iter().enumerate() {
        assert!(
            tints[v].distance(want[k]) < 1e-2,
            "corner {k}: {}",
            tints[v]
        );
    }
    // Untextured vertices are white: their colours have their COLOR_0.
    let paint = back.triangles[1].map(|v| v as usize);
    assert!(paint.iter().all(|&v| tints[v] == Vec3::ONE));

    let (tree, _) = vunify::vtree::build(
        &back,
        &vunify::vtree::BuildOptions::default(),
        &mut |_, _| {},
    )
    .unwrap();
    let w = tree.wedges.as_ref().expect("a textured tree has wedges");
    assert_eq!(w.tint.len(), w.len());
    for bytes in [
        vunify::vtree::to_bytes(&tree),
        vunify::vtree::to_bytes_with(&tree, vunify::vtree::Encoding::Exact),
    ] {
        let read = vunify::vtree::read_bytes(&bytes, Path::new("t.vtree")).unwrap();
        assert_eq!(read.wedges.as_ref().unwrap().tint, w.tint);
    }
    let full = vunify::vtree::cut_at_triangles(&tree, 2).mesh;
    let out = dir.join("full.glb");
    vunify::export::write_mesh(&full, &out).unwrap();
    let again = parse(&std::fs::read(&out).unwrap(), Format::Gltf, &out).unwrap();
    let tints = again.tints.as_ref().expect("the level keeps its tints");
    let darkest = tints.iter().fold(Vec3::ONE, |a, &t| a.min(t));
    assert!(darkest.distance(want[0]) < 1e-2, "{darkest}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `.glb` and `.gltf` (+ `.bin`) written by vunify read back as they were, and `.gltf.xz` is
/// refused rather than half-written.
#[test]
fn gltf_output_round_trips() {
    let dir = std::env::temp_dir().join(format!("vunify-gltf-out-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let m = square();
    for name in ["s.glb", "s.gltf"] {
        let file = dir.join(name);
        vunify::export::write_mesh(&m, &file).unwrap();
        let back = parse(&std::fs::read(&file).unwrap(), Format::Gltf, &file).unwrap();
        assert_eq!(back.positions, m.positions, "{name}");
        assert_eq!(back.triangles, m.triangles, "{name}");
        assert_eq!(back.colors, m.colors, "{name}");
        assert_eq!(back.normals, m.normals, "{name}");
    }
    assert!(dir.join("s.bin").exists());
    assert!(vunify::export::write_mesh(&m, &dir.join("s.gltf.xz")).is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every glTF file vunify writes passes the Khronos glTF Validator with no error and no warning
/// (npm `gltf-validator`, which scripts/test.sh installs into tools/npm; required under CI).
#[test]
fn gltf_output_validates() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let script = root.join("scripts/validate-gltf.js");
    let installed = root.join("tools/npm/node_modules/gltf-validator").is_dir();
    let node = std::process::Command::new("node")
        .arg("--version")
        .output()
        .is_ok();
    if !(installed && node) {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must have node and gltf-validator (scripts/test.sh installs it)"
        );
        eprintln!("skipping: node or tools/npm/node_modules/gltf-validator missing");
        return;
    }
    let dir = std::env::temp_dir().join(format!("vunify-gltf-valid-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut meshes = vec![square()];
    // Without colours or normals, and with a zero normal (left out: glTF's are unit vectors).
    meshes.push(vunify::mesh::Mesh {
        colors: None,
        normals: Some(vec![Vec3::Z, Vec3::ZERO, Vec3::Z, Vec3::Z]),
        ..square()
    });
    meshes.push(two_materials());
    meshes.push(tinted());
    // Static levels of the shared textured models, materials and maps carried.
    if let Some(models) = models_dir() {
        for file in [
            "textured/Avocado/Avocado.gltf",
            "textured/WaterBottle/WaterBottle.glb",
            "textured/DeccerCubesTextured/SM_Deccer_Cubes_Textured.glb",
        ] {
            let (m, _) = vunify::mesh::load(&models.join(file), &CleanOptions::default()).unwrap();
            let (tree, _) =
                vunify::vtree::build(&m, &vunify::vtree::BuildOptions::default(), &mut |_, _| {})
                    .unwrap();
            let keep = m.triangle_count() as u32 / 10;
            let level = vunify::vtree::cut_at_triangles(&tree, keep).mesh;
            assert_eq!(level.materials, m.materials, "{file}");
            meshes.push(level);
        }
    }
    // The last: a chain of levels (`extract --lod-chain`), the first two meshes' materials shared.
    let chain = meshes.len();
    for i in 0..=chain {
        for ext in ["glb", "gltf"] {
            let file = dir.join(format!("m{i}.{ext}"));
            if i < chain {
                vunify::export::write_mesh(&meshes[i], &file).unwrap();
            } else {
                let levels = [&meshes[2], &meshes[2]].map(|m| (m, serde_json::json!({"ratio": 1})));
                vunify::export::write_chain(&levels, &file).unwrap();
            }
            let out = std::process::Command::new("node")
                .arg(&script)
                .arg(&file)
                .output()
                .unwrap();
            let report = String::from_utf8_lossy(&out.stdout);
            assert!(
                out.status.success() && report.contains("\"errors\":0,\"warnings\":0"),
                "{}: {report} {}",
                file.display(),
                String::from_utf8_lossy(&out.stderr)
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A textured OBJ with its MTL library and image beside it:
///
/// ```text
///   3----2    lower right (0 1 2): "red", map_Kd red.png
///   | \  |    upper left (0 2 3): "glass", Kd 0 0 1, d 0.5, no texture
///   0----1    vt v counts from the image's bottom: read as 1 − v
/// ```
#[test]
fn textured_obj_reads_materials_and_coordinates() {
    let dir = std::env::temp_dir().join(format!("vunify-obj-mtl-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("red.png"), &*png([255, 0, 0])).unwrap();
    std::fs::write(
        dir.join("q.mtl"),
        "newmtl red\nKd 1 1 1\nmap_Kd red.png\n\nnewmtl glass\nKd 0 0 1\nd 0.5\n",
    )
    .unwrap();
    let obj = "mtllib q.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n\
               usemtl red\nf 1/1 2/2 3/3\nusemtl glass\nf 1 3 4\n";
    std::fs::write(dir.join("q.obj"), obj).unwrap();
    let (m, report) = vunify::mesh::load(&dir.join("q.obj"), &CleanOptions::default()).unwrap();
    assert!(report.notes.is_empty(), "{:?}", report.notes);
    assert_eq!(m.triangle_count(), 2);
    let of = m.material_of.as_ref().unwrap();
    let red = &m.materials[of[m.triangles[0][0] as usize] as usize];
    let glass = &m.materials[of[m.triangles[1][0] as usize] as usize];
    assert_eq!(red.name, "red");
    assert!(red.base_color_texture.is_some());
    assert_eq!(glass.name, "glass");
    assert_eq!(glass.base_color_factor, [0.0, 0.0, 1.0, 0.5]);
    assert_eq!(glass.alpha_mode, vunify::mesh::AlphaMode::Blend);
    let uvs = m.uvs.as_ref().unwrap();
    let corner = |t: usize, k: usize| m.triangles[t][k] as usize;
    assert_eq!(uvs[corner(0, 0)], glam::Vec2::new(0.0, 1.0));
    assert_eq!(uvs[corner(0, 2)], glam::Vec2::new(1.0, 0.0));
    let colors = m.colors.as_ref().unwrap();
    assert!(colors[corner(0, 1)].distance(Vec3::X) < 1e-5);
    assert!(colors[corner(1, 2)].distance(Vec3::Z) < 1e-5);
    // A missing image is a note; a malformed line still names its line.
    std::fs::remove_file(dir.join("red.png")).unwrap();
    let (_, report) = vunify::mesh::load(&dir.join("q.obj"), &CleanOptions::default()).unwrap();
    assert!(
        report.notes.iter().any(|n| n.contains("red.png")),
        "{:?}",
        report.notes
    );
    std::fs::write(dir.join("bad.obj"), obj.replace("vt 1 0\n", "vt 1 zero\n")).unwrap();
    let e = vunify::mesh::load(&dir.join("bad.obj"), &CleanOptions::default()).unwrap_err();
    assert!(e.to_string().contains("bad.obj:7"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// OBJ output of a mesh with materials writes its MTL library and the images it names; read back,
/// the materials, their textures and the texture coordinates are as they were.
#[test]
fn obj_output_keeps_materials() {
    let dir = std::env::temp_dir().join(format!("vunify-obj-out-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let m = two_materials();
    let file = dir.join("two.obj");
    vunify::export::write_mesh(&m, &file).unwrap();
    let mtl = std::fs::read_to_string(dir.join("two.mtl")).unwrap();
    assert!(mtl.contains("map_Kd two_texture0.png"), "{mtl}");
    assert!(mtl.contains("map_Bump two_texture1.png"), "{mtl}");
    let (back, report) = vunify::mesh::load(&file, &CleanOptions::default()).unwrap();
    assert!(report.notes.is_empty(), "{:?}", report.notes);
    assert_eq!(back.materials.len(), 2);
    assert_eq!(back.textures.len(), 2);
    assert!(back.materials.iter().any(|m| m.normal_texture.is_some()));
    let of = back.material_of.as_ref().unwrap();
    let names: Vec<&str> = back
        .triangles
        .iter()
        .map(|t| back.materials[of[t[0] as usize] as usize].name.as_str())
        .collect();
    assert_eq!(names, ["m0_leaf", "m1_paint"]);
    let uvs = back.uvs.as_ref().unwrap();
    assert_eq!(uvs[back.triangles[0][1] as usize], glam::Vec2::X);
    let _ = std::fs::remove_dir_all(&dir);
}

/// PLY texture coordinates: an ASCII file with `texture_u texture_v` and the image its header
/// names (`comment TextureFile`, as MeshLab writes) reads textured, `v` from the image's bottom;
/// a mesh with one texture is written as binary PLY with `s t` and its image beside, and reads back
/// the same; a missing image is a note.
#[test]
fn ply_texture_coordinates() {
    let dir = std::env::temp_dir().join(format!("vunify-ply-uv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("red.png"), &*png([255, 0, 0])).unwrap();
    let ascii = "ply\nformat ascii 1.0\ncomment TextureFile red.png\nelement vertex 3\n\
                 property float x\nproperty float y\nproperty float z\n\
                 property float texture_u\nproperty float texture_v\n\
                 element face 1\nproperty list uchar int vertex_indices\nend_header\n\
                 0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n3 0 1 2\n";
    std::fs::write(dir.join("t.ply"), ascii).unwrap();
    let (m, report) = vunify::mesh::load(&dir.join("t.ply"), &CleanOptions::default()).unwrap();
    assert!(report.notes.is_empty(), "{:?}", report.notes);
    let uvs = m.uvs.as_ref().unwrap();
    assert_eq!(uvs[..], [glam::Vec2::Y, glam::Vec2::ONE, glam::Vec2::ZERO]);
    assert_eq!(m.textures.len(), 1);
    assert_eq!(m.materials[0].base_color_texture, Some(0));
    assert!(m.colors.as_ref().unwrap()[0].distance(Vec3::X) < 1e-5);
    // Written (binary, `s t`, the image beside) and read back.
    let out = dir.join("back.ply");
    vunify::export::write_mesh(&m, &out).unwrap();
    assert!(dir.join("back_texture0.png").exists());
    let (back, report) = vunify::mesh::load(&out, &CleanOptions::default()).unwrap();
    assert!(report.notes.is_empty(), "{:?}", report.notes);
    assert_eq!(back.uvs, m.uvs);
    assert_eq!(back.textures.len(), 1);
    std::fs::remove_file(dir.join("red.png")).unwrap();
    let (_, report) = vunify::mesh::load(&dir.join("t.ply"), &CleanOptions::default()).unwrap();
    assert!(
        report.notes.iter().any(|n| n.contains("red.png")),
        "{:?}",
        report.notes
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Signed volume of the triangles whose material has a base colour texture (the instances of the
/// scanned box, not the ground).
fn textured_volume(m: &vunify::mesh::Mesh) -> f32 {
    let of = m.material_of.as_ref().unwrap();
    m.triangles
        .iter()
        .filter(|t| {
            m.materials[of[t[0] as usize] as usize]
                .base_color_texture
                .is_some()
        })
        .map(|t| {
            let [a, b, c] = t.map(|v| m.positions[v as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// The generated scene (`vunify::fixtures::textured_scene_glb`: a textured box instanced under
/// nested transforms, one instance mirrored, on a ground of a second material) reads with every
/// instance facing out (their volumes are the box's scaled: 0.5³ twice and 0.4³, none negative, so
/// the mirrored one was rewound), its two materials and the texture; the copy meshoptimizer's
/// gltfpack makes of it (quantized positions and coordinates, `KHR_mesh_quantization` and
/// `KHR_texture_transform`) reads as the same model within its quantization.
#[test]
fn a_generated_scene_and_its_gltfpack_copy() {
    let dir = std::env::temp_dir().join(format!("vunify-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (box_mesh, _) = vunify::mesh::clean(
        common::subdivided(&vunify::fixtures::cuboid(Vec3::ONE), 2),
        &CleanOptions::default(),
    );
    let scan = vunify::fixtures::textured_scan(&box_mesh);
    let file = dir.join("scene.glb");
    std::fs::write(&file, vunify::fixtures::textured_scene_glb(&scan)).unwrap();
    let (m, report) = vunify::mesh::load(&file, &CleanOptions::default()).unwrap();
    assert!(report.notes.is_empty(), "{:?}", report.notes);
    assert_eq!(m.triangle_count(), 3 * box_mesh.triangle_count() + 2);
    assert_eq!(m.materials.len(), 2);
    assert_eq!(m.textures.len(), 1);
    let want = 2.0 * 0.5f32.powi(3) + 0.4f32.powi(3);
    assert!(
        (textured_volume(&m) - want).abs() < 1e-4,
        "{}",
        textured_volume(&m)
    );
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let gltfpack = root.join("tools/npm/node_modules/gltfpack/cli.js");
    if !gltfpack.exists() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must have gltfpack (scripts/test.sh installs it)"
        );
        eprintln!("skipping the gltfpack copy: tools/npm/node_modules/gltfpack missing");
        return;
    }
    let packed = dir.join("scene.packed.glb");
    let out = std::process::Command::new("node")
        .arg(&gltfpack)
        .args([
            "-i".as_ref(),
            file.as_os_str(),
            "-o".as_ref(),
            packed.as_os_str(),
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json = String::from_utf8_lossy(&std::fs::read(&packed).unwrap()).into_owned();
    assert!(
        json.contains("KHR_mesh_quantization"),
        "gltfpack quantized it"
    );
    let (q, report) = vunify::mesh::load(&packed, &CleanOptions::default()).unwrap();
    assert!(report.notes.is_empty(), "{:?}", report.notes);
    assert_eq!(q.triangle_count(), m.triangle_count());
    assert_eq!(q.textures.len(), 1);
    let (lo, hi) = (m.bounds(), q.bounds());
    let d = m.diagonal();
    assert!(lo.0.distance(hi.0) < 1e-3 * d && lo.1.distance(hi.1) < 1e-3 * d);
    assert!(
        (textured_volume(&q) - want).abs() < 0.01 * want,
        "{}",
        textured_volume(&q)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

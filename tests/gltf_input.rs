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
    for (i, m) in meshes.iter().enumerate() {
        for ext in ["glb", "gltf"] {
            let file = dir.join(format!("m{i}.{ext}"));
            vunify::export::write_mesh(m, &file).unwrap();
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

//! Inputs that try to break vunify: lying header counts, huge lines, bad bytes, extreme scales,
//! degenerate and repeated geometry, nonsense camera paths. Each must give a clear error or a correct
//! result: never a panic, a hang or an allocation the file does not justify.

mod common;

use glam::Vec3;
use std::path::Path;
use vunify::camera_path::CameraPath;
use vunify::mesh::{CleanOptions, Format, Mesh, clean, parse};
use vunify::vtree::{self, BuildOptions, VertexTree};

fn parse_as(bytes: &[u8], format: Format) -> Result<Mesh, String> {
    let name = match format {
        Format::Obj => "hostile.obj",
        Format::Ply => "hostile.ply",
        Format::Off => "hostile.off",
        Format::Gltf => "hostile.glb",
    };
    parse(bytes, format, Path::new(name)).map_err(|e| e.to_string())
}

fn error_of(bytes: &[u8], format: Format) -> String {
    let e = parse_as(bytes, format).expect_err("expected a clear error");
    assert!(e.starts_with("hostile."), "names the file: {e}");
    assert_eq!(e.lines().count(), 1, "one line: {e}");
    e
}

/// Builds the mesh's tree (cleaned with the default options) and checks it from scratch (every cut
/// of the build order).
fn build_checked(mesh: Mesh) -> VertexTree {
    let (mesh, _) = clean(mesh, &CleanOptions::default());
    build_checked_as_is(mesh)
}

fn build_checked_as_is(mesh: Mesh) -> VertexTree {
    let (tree, _) = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {}).expect("builds");
    vtree::check_cut(&tree).expect("a valid tree");
    // And what is written reads back.
    let bytes = vtree::to_bytes(&tree);
    let back = vtree::read_bytes(&bytes, Path::new("back.vtree")).expect("reads back");
    assert_eq!(back, tree);
    tree
}

#[test]
fn header_counts_of_a_trillion_records_with_a_short_body() {
    let ply = b"ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n";
    assert!(error_of(ply, Format::Ply).contains("truncated file"));
    let ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0";
    assert!(error_of(ply, Format::Ply).contains("truncated file"));
    let off = b"OFF\n1000000000000 1 0\n0 0 0\n";
    assert!(error_of(off, Format::Off).contains("exceed what a file"));
    let off = b"OFF\n3 1000000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    assert!(error_of(off, Format::Off).contains("exceed what a file"));
}

/// glTF that lies: an accessor of four billion elements and no buffer view (nothing in the file
/// bounds it), a GLB whose header or chunk claims more bytes than there are, a GLB of version 1.
#[test]
fn gltf_that_lies_about_sizes() {
    let json = br#"{"asset":{"version":"2.0"},
"buffers":[{"byteLength":16,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAAAAAA=="}],
"bufferViews":[{"buffer":0,"byteLength":4},{"buffer":0,"byteOffset":4,"byteLength":12}],
"accessors":[{"componentType":5126,"count":4000000000,"type":"VEC3","min":[0,0,0],"max":[0,0,0],
"sparse":{"count":1,"indices":{"bufferView":0,"componentType":5125},"values":{"bufferView":1}}}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]}"#;
    assert!(
        error_of(json, Format::Gltf).contains("declares 4000000000 elements and no buffer view")
    );
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend(1000u32.to_le_bytes());
    assert!(error_of(&glb, Format::Gltf).contains("the GLB header says 1000 bytes"));
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend(24u32.to_le_bytes());
    glb.extend(0xFFFF_FFF0u32.to_le_bytes());
    glb.extend(b"JSON{}  ");
    assert!(error_of(&glb, Format::Gltf).contains("runs past the end of the GLB"));
    let mut glb = b"glTF".to_vec();
    glb.extend(1u32.to_le_bytes());
    glb.extend(12u32.to_le_bytes());
    assert!(error_of(&glb, Format::Gltf).contains("GLB version 1"));
}

/// Found by a probe: an element with no properties takes no bytes, so no file size bounds its
/// count; ply-rs-bw allocated a record each (2.1 GB from a 63-byte file at 3·10⁷, an abort at 4·10⁹).
#[test]
fn an_element_without_properties_cannot_ask_for_memory() {
    let ply = b"ply\nformat binary_little_endian 1.0\nelement extra 4000000000\nend_header\n";
    let e = error_of(ply, Format::Ply);
    assert!(
        e.contains("'extra' has 4000000000 records but no properties"),
        "{e}"
    );
}

#[test]
fn ply_declarations_twice_are_errors_with_their_line() {
    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float y\nproperty float z\nend_header\n";
    let e = error_of(ply, Format::Ply);
    assert!(
        e.contains(":6: property 'y' of element 'vertex' is declared twice"),
        "{e}"
    );
    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement vertex 3\nproperty float x\nend_header\n";
    let e = error_of(ply, Format::Ply);
    assert!(e.contains(":7: element 'vertex' is declared twice"), "{e}");
}

#[test]
fn crate_messages_are_one_line() {
    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty floot x\nend_header\n";
    let e = error_of(ply, Format::Ply);
    assert!(e.contains(":4: bad PLY header"), "{e}");
}

#[test]
fn off_face_counts_say_what_they_mean() {
    let off = b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n1000000000000 0 1 2\n";
    let e = error_of(off, Format::Off);
    assert!(
        e.contains(":6: face: the count says 1000000000000 vertex indices, the line has 3"),
        "{e}"
    );
    let off = b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n";
    assert!(error_of(off, Format::Off).contains("at least 3 vertices"));
}

#[test]
fn a_utf8_byte_order_mark_is_accepted_everywhere() {
    let off = "\u{feff}OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    assert_eq!(
        parse_as(off.as_bytes(), Format::Off)
            .unwrap()
            .triangle_count(),
        1
    );
    let obj = "\u{feff}v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    assert_eq!(
        parse_as(obj.as_bytes(), Format::Obj)
            .unwrap()
            .triangle_count(),
        1
    );
}

#[test]
fn obj_colours_on_some_vertices_only_name_the_line() {
    let obj = b"v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 1 1 1\nf 1 2 3\n";
    let e = error_of(obj, Format::Obj);
    assert!(
        e.contains(":2: vertex: has no colour, but the first vertex (line 1) has one"),
        "{e}"
    );
}

#[test]
fn non_utf8_bytes_name_their_line() {
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 \xff\xfe\nf 1 2 3\n";
    assert!(error_of(obj, Format::Obj).contains(":3:"));
    let off = b"OFF\n3 1 0\n0 0 0\n\xc3\x28 0 0\n0 1 0\n3 0 1 2\n";
    assert!(error_of(off, Format::Off).contains(":4:"));
    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 \xff\n0 1 0\n3 0 1 2\n";
    parse_as(ply, Format::Ply).expect_err("not a number");
}

#[test]
fn ten_megabyte_lines() {
    // A comment line of 10 MB, then a valid triangle: read.
    let mut obj = b"# ".to_vec();
    obj.extend(std::iter::repeat_n(b'x', 10 << 20));
    obj.extend_from_slice(b"\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert_eq!(parse_as(&obj, Format::Obj).unwrap().triangle_count(), 1);
    // A coordinate of 10 MB of digits: a clear error.
    let mut obj = b"v 0 0 ".to_vec();
    obj.extend(std::iter::repeat_n(b'9', 10 << 20));
    obj.extend_from_slice(b"\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert!(error_of(&obj, Format::Obj).contains(":1:"));
    let mut off = b"OFF\n3 1 0\n0 0 ".to_vec();
    off.extend(std::iter::repeat_n(b'1', 10 << 20));
    off.extend_from_slice(b"\n1 0 0\n0 1 0\n3 0 1 2\n");
    assert!(error_of(&off, Format::Off).contains(":3:"));
}

#[test]
fn crlf_files_read_like_lf_files() {
    let obj = "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nv 1 1 0\r\nf 1 2 3\r\nf 2 4 3\r\n";
    let off = "OFF\r\n4 2 0\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n1 1 0\r\n3 0 1 2\r\n3 1 3 2\r\n";
    let ply = "ply\r\nformat ascii 1.0\r\nelement vertex 4\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\nelement face 2\r\nproperty list uchar int vertex_indices\r\nend_header\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n1 1 0\r\n3 0 1 2\r\n3 1 3 2\r\n";
    for (text, format) in [(obj, Format::Obj), (off, Format::Off), (ply, Format::Ply)] {
        let m = parse_as(text.as_bytes(), format).unwrap();
        assert_eq!((m.vertex_count(), m.triangle_count()), (4, 2), "{format:?}");
        assert_eq!(m.positions[3], Vec3::new(1.0, 1.0, 0.0));
    }
}

/// A unit cube's 12 triangles scaled by `s`.
fn cube(s: f32) -> Mesh {
    vunify::fixtures::cuboid(Vec3::splat(s))
}

/// Found by a probe: the cow scaled by 10⁷ built a tree its own reader rejected (infinite quadric
/// costs), and by 10⁻³⁰ a tree whose every error was 0. Every scale a float holds builds a valid tree
/// whose errors scale with it.
#[test]
fn every_scale_a_float_holds_builds_the_same_tree_scaled() {
    let unit = build_checked(common::grid(6, 5, |x, y| (x * 0.7).sin() + (y * 0.4).cos()));
    let unit_error = unit.nodes[unit.root() as usize].error;
    assert!(unit_error > 0.0);
    for exponent in [-30, -25, -10, 7, 10, 20, 30] {
        let s = 10f32.powi(exponent);
        let mesh = common::grid(6, 5, |x, y| (x * 0.7).sin() + (y * 0.4).cos());
        let scaled = Mesh {
            positions: mesh.positions.iter().map(|&p| p * s).collect(),
            ..mesh
        };
        let tree = build_checked(scaled);
        let error = tree.nodes[tree.root() as usize].error;
        let relative = error / tree.diagonal();
        let expected = unit_error / unit.diagonal();
        assert!(
            (relative - expected).abs() <= 0.05 * expected,
            "scale 1e{exponent}: root error {relative} of the diagonal, {expected} at unit scale"
        );
    }
    build_checked(cube(1e-38));
    build_checked(cube(3e37));
}

#[test]
fn models_too_small_or_large_to_view_say_so() {
    for s in [1e-25, 1e20] {
        let (tree, _) = vtree::build(&cube(s), &BuildOptions::default(), &mut |_, _| {}).unwrap();
        let e = tree
            .check_viewable()
            .expect_err("outside the viewable range");
        assert!(e.to_string().contains("scale it into that range"), "{e}");
    }
    let (tree, _) = vtree::build(&cube(1e-6), &BuildOptions::default(), &mut |_, _| {}).unwrap();
    tree.check_viewable().unwrap();
}

/// 100,000 triangles, none sharing a vertex: one tree, one root.
#[test]
fn a_hundred_thousand_disconnected_triangles() {
    let mut p = Vec::new();
    let mut t = Vec::new();
    for i in 0..100_000u32 {
        let o = Vec3::new(
            (i % 317) as f32,
            (i / 317) as f32,
            ((i * 7) % 13) as f32 * 0.1,
        );
        p.extend([o, o + Vec3::X * 0.5, o + Vec3::Y * 0.5]);
        t.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let tree = build_checked(Mesh::from_triangles(p, t));
    assert_eq!(tree.leaf_count, 300_000);
    assert_eq!(tree.triangles.len(), 100_000);
}

/// A fan of 100 triangles around one edge (0–1), a non-manifold book:
/// ```text
///   2  3  4 … 101      every page k is the triangle 0 1 k
///    \ | /
///  0 ——————— 1
/// ```
#[test]
fn a_hundred_triangle_fan_around_one_edge() {
    let mut p = vec![Vec3::ZERO, Vec3::X];
    let mut t = Vec::new();
    for k in 0..100u32 {
        let a = k as f32 / 100.0 * std::f32::consts::TAU;
        p.push(Vec3::new(0.5, a.cos(), a.sin()));
        t.push([0, 1, k + 2]);
    }
    let tree = build_checked(Mesh::from_triangles(p, t));
    assert_eq!(tree.triangles.len(), 100);
}

/// Every vertex at one point: cleaning welds them, every triangle is degenerate, and the build says
/// the mesh has no triangles.
#[test]
fn all_vertices_coincident() {
    let p = vec![Vec3::splat(3.0); 30];
    let t: Vec<[u32; 3]> = (0..10).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    let (mesh, report) = clean(Mesh::from_triangles(p, t), &CleanOptions::default());
    assert_eq!(report.degenerate_faces, 10);
    let e = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {}).unwrap_err();
    assert!(e.to_string().contains("no triangles"), "{e}");
    // Without welding the coincident vertices stay apart: zero-area triangles, which build.
    let p = vec![Vec3::splat(3.0); 6];
    let (mesh, _) = clean(
        Mesh::from_triangles(p, vec![[0, 1, 2], [3, 4, 5]]),
        &CleanOptions { weld: false },
    );
    if let Ok((tree, _)) = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {}) {
        vtree::check_cut(&tree).expect("a valid tree");
    }
}

/// Two identical copies of a model stacked on each other (distinct vertices at the same places):
/// welding makes them one; without welding the tree joins them.
#[test]
fn two_identical_stacked_copies() {
    let a = common::grid(8, 8, |x, y| (x * y).sqrt());
    let n = a.positions.len() as u32;
    let mut p = a.positions.clone();
    p.extend_from_slice(&a.positions);
    let mut t = a.triangles.clone();
    t.extend(a.triangles.iter().map(|tri| tri.map(|v| v + n)));
    let stacked = Mesh::from_triangles(p, t);
    let (welded, report) = clean(stacked.clone(), &CleanOptions::default());
    assert_eq!(welded.triangle_count(), a.triangle_count());
    assert!(report.duplicate_faces > 0);
    build_checked(welded);
    let (apart, _) = clean(stacked, &CleanOptions { weld: false });
    let tree = build_checked_as_is(apart);
    assert_eq!(tree.leaf_count, 2 * n);
}

fn path_error(json: &str) -> String {
    CameraPath::parse(json, Path::new("hostile.json"))
        .expect_err("a clear error")
        .to_string()
}

#[test]
fn camera_paths_that_cannot_be_flown() {
    assert!(path_error(r#"{"keyframes":[]}"#).contains("no keyframes"));
    // JSON has no NaN; the closest a file gets is a number that overflows f32.
    assert!(
        path_error(r#"{"keyframes":[{"time":0,"position":[1e39,0,0],"look_at":[0,0,0]}]}"#)
            .contains("not finite")
    );
    assert!(
        path_error(r#"{"keyframes":[{"time":0,"position":[1e20,0,0],"look_at":[0,0,0]}]}"#)
            .contains("larger than")
    );
    for fov in ["0", "180"] {
        let e = path_error(&format!(
            r#"{{"keyframes":[{{"time":0,"position":[1,0,0],"look_at":[0,0,0],"fov_deg":{fov}}}]}}"#
        ));
        assert!(e.contains("fov_deg"), "{e}");
    }
    let e = path_error(
        r#"{"keyframes":[{"time":0,"position":[1,0,0],"look_at":[0,0,0]},{"time":1e9,"position":[2,0,0],"look_at":[0,0,0]}]}"#,
    );
    assert!(e.contains("at most 86400 s"), "{e}");
    // A look-at point that rounds onto the position, at any scale.
    let e = path_error(
        r#"{"keyframes":[{"time":0,"position":[1e-25,0,0],"look_at":[1.0000001e-25,0,0]}]}"#,
    );
    assert!(e.contains("looks at its own position"), "{e}");
    // NaN made in code (not from JSON) is refused too.
    let mut path = CameraPath::orbit(Vec3::ZERO, 1.0, 4.0);
    path.keyframes[1].position[0] = f32::NAN;
    assert!(path.validate().unwrap_err().contains("not finite"));
}

/// The path generators give paths that validate at every viewable scale.
#[test]
fn generated_paths_validate_at_every_viewable_scale() {
    for exponent in [-15, -10, -3, 0, 3, 10, 14] {
        let r = 10f32.powi(exponent);
        let c = Vec3::new(1.0, -2.0, 3.0) * r;
        for path in [
            CameraPath::orbit(c, r, 10.0),
            CameraPath::fly_in(c, r, 10.0),
            CameraPath::flythrough(c, r, 10.0),
        ] {
            path.validate()
                .unwrap_or_else(|e| panic!("radius {r}: {e}"));
        }
    }
}

#[cfg(feature = "render")]
#[test]
fn render_refuses_more_frames_than_it_makes() {
    use vunify::render::job::{MAX_FRAMES, frame_count};
    assert_eq!(frame_count(10.0, 30.0), Some(301));
    assert_eq!(frame_count(86_400.0, 1000.0), None);
    assert_eq!(frame_count(3e38, 30.0), None);
    assert_eq!(frame_count(f32::NAN, 30.0), None);
    assert!(frame_count(MAX_FRAMES as f32 / 30.0 - 1.0, 30.0).is_some());
}

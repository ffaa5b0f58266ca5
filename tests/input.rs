//! Mesh input: what each reader keeps, and that bad input is an error naming the file and the place,
//! never a panic.

mod common;

use glam::Vec3;
use proptest::prelude::*;
use std::path::Path;
use vunify::mesh::{CleanOptions, Format, InputError, Location, clean, parse};

fn obj(text: &str) -> Result<vunify::mesh::Mesh, InputError> {
    parse(text.as_bytes(), Format::Obj, Path::new("test.obj"))
}

fn err_at(r: Result<vunify::mesh::Mesh, InputError>) -> (Location, String) {
    let e = r.expect_err("expected an error");
    assert_eq!(e.path, Path::new(e.path.to_str().unwrap()));
    let shown = e.to_string();
    assert!(
        shown.starts_with(e.path.to_str().unwrap()),
        "the message names the file: {shown}"
    );
    (e.location, e.message)
}

/// Two objects, a quad (triangulated as a fan) and a triangle, with per-vertex colours.
#[test]
fn obj_objects_polygons_and_colours() {
    let text = "\
# a quad and a triangle
o quad
v 0 0 0 1 0 0
v 1 0 0 0 1 0
v 1 1 0 0 0 1
v 0 1 0 1 1 1
f 1 2 3 4
o tri
v 5 0 0 0.5 0.5 0.5
v 6 0 0 0.5 0.5 0.5
v 5 1 0 0.5 0.5 0.5
f 5/1 6/1 7/1
vt 0 0
";
    let m = obj(text).unwrap();
    assert_eq!(m.parts.len(), 2);
    assert_eq!(m.parts[0].name, "quad");
    assert_eq!(m.parts[0].triangles, 0..2);
    assert_eq!(m.parts[1].triangles, 2..3);
    assert_eq!(m.triangle_count(), 3);
    let colors = m.colors.as_ref().expect("colours kept");
    assert_eq!(colors[0], Vec3::new(1.0, 0.0, 0.0));
    assert_eq!(colors.len(), m.positions.len());
}

#[test]
fn obj_errors_name_the_line() {
    let cases: [(&str, usize, &str); 9] = [
        ("v 0 0 0\nv 1 0 0\nv 0 x 0\nf 1 2 3\n", 3, "not a number"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 nan\nf 1 2 3\n", 3, "not finite"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 inf\nf 1 2 3\n", 3, "not finite"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n", 5, "out of range"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", 4, "index 0"),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
            4,
            "before the first",
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", 4, "at least 3"),
        ("v 0 0\n", 1, "expected 3 to 7"),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n",
            4,
            "texture coordinate index 1 is out of range",
        ),
    ];
    for (text, line, what) in cases {
        let (loc, msg) = err_at(obj(text));
        assert_eq!(loc, Location::Line(line), "{text:?}: {msg}");
        assert!(msg.contains(what), "{text:?}: {msg}");
    }
}

#[test]
fn empty_meshes_are_errors() {
    for text in ["", "# nothing\n", "v 0 0 0\nv 1 1 1\n"] {
        let (_, msg) = err_at(obj(text));
        assert!(msg.contains("no faces"), "{msg}");
    }
    let e = parse(b"OFF\n0 0 0\n", Format::Off, Path::new("e.off")).unwrap_err();
    assert!(e.message.contains("no faces"));
}

#[test]
fn off_reads_and_reports_lines() {
    let text = "OFF\n# square\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
    let m = parse(text.as_bytes(), Format::Off, Path::new("s.off")).unwrap();
    assert_eq!((m.vertex_count(), m.triangle_count()), (4, 2));
    let quad = "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
    assert_eq!(
        parse(quad.as_bytes(), Format::Off, Path::new("q.off"))
            .unwrap()
            .triangle_count(),
        2
    );
    let coff = "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2\n";
    let m = parse(coff.as_bytes(), Format::Off, Path::new("c.off")).unwrap();
    assert_eq!(m.colors.unwrap()[1], Vec3::new(0.0, 1.0, 0.0));
    let bad = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
    let (loc, msg) = err_at(parse(bad.as_bytes(), Format::Off, Path::new("b.off")));
    assert_eq!(loc, Location::Line(6));
    assert!(msg.contains("out of range"));
    let short = "OFF\n3 1 0\n0 0 0\n1 0 0\n";
    assert!(
        parse(short.as_bytes(), Format::Off, Path::new("t.off"))
            .unwrap_err()
            .message
            .contains("end of file")
    );
    let lie = "OFF\n99999999 99999999 0\n";
    assert!(
        parse(lie.as_bytes(), Format::Off, Path::new("l.off"))
            .unwrap_err()
            .message
            .contains("exceed")
    );
}

fn binary_ply(vertices: &[[f32; 3]], faces: &[[i32; 3]]) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len(),
        faces.len()
    )
    .into_bytes();
    for v in vertices {
        for x in v {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    for f in faces {
        out.push(3);
        for i in f {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    out
}

#[test]
fn ply_binary_and_ascii() {
    let v = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    let bytes = binary_ply(&v, &[[0, 1, 2], [1, 3, 2]]);
    let m = parse(&bytes, Format::Ply, Path::new("b.ply")).unwrap();
    assert_eq!((m.vertex_count(), m.triangle_count()), (4, 2));
    assert_eq!(m.positions[3], Vec3::new(1.0, 1.0, 0.0));

    let ascii = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n";
    let m = parse(ascii.as_bytes(), Format::Ply, Path::new("a.ply")).unwrap();
    assert_eq!(m.colors.unwrap()[2], Vec3::new(0.0, 0.0, 1.0));

    // Out-of-range index in ASCII: the face's line (header is 12 lines, then 3 vertices).
    let bad = ascii.replace("3 0 1 2\n", "3 0 1 5\n");
    let (loc, msg) = err_at(parse(bad.as_bytes(), Format::Ply, Path::new("a.ply")));
    assert_eq!(loc, Location::Line(16), "{msg}");
    // NaN in binary: the vertex's byte offset.
    let header_len = bytes.len() - 4 * 12 - 2 * 13;
    let nan = binary_ply(
        &[[0.0, 0.0, 0.0], [1.0, f32::NAN, 0.0], [0.0, 1.0, 0.0]],
        &[[0, 1, 2]],
    );
    let (loc, msg) = err_at(parse(&nan, Format::Ply, Path::new("n.ply")));
    assert_eq!(loc, Location::Byte(header_len as u64 + 12), "{msg}");
    assert!(msg.contains("not finite"));
}

#[test]
fn truncated_binary_ply_names_the_offset() {
    let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let bytes = binary_ply(&v, &[[0, 1, 2]]);
    for cut in [
        bytes.len() - 1,
        bytes.len() - 13,
        bytes.len() - 20,
        bytes.len() - 36,
    ] {
        let e = parse(&bytes[..cut], Format::Ply, Path::new("t.ply")).unwrap_err();
        assert!(matches!(e.location, Location::Byte(_)), "{e}");
        assert!(e.to_string().contains("t.ply"), "{e}");
    }
    let e = parse(&bytes[..30], Format::Ply, Path::new("t.ply")).unwrap_err();
    assert!(e.message.contains("end_header"), "{e}");
}

#[test]
fn welding_is_on_by_default_and_switchable() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 4 6 5\n";
    let raw = obj(text).unwrap();
    let (welded, report) = clean(raw.clone(), &CleanOptions::default());
    assert_eq!((welded.vertex_count(), report.welded_vertices), (4, 2));
    let (apart, report) = clean(raw, &CleanOptions { weld: false });
    assert_eq!((apart.vertex_count(), report.welded_vertices), (6, 0));
}

/// A valid file of each format, for mutation.
fn seeds() -> Vec<(Format, Vec<u8>)> {
    let v = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 1.0],
    ];
    vec![
        (Format::Obj, b"o a\nv 0 0 0\nv 1 0 0\nv 0 1 0 1 0 0\nvn 0 0 1\nf 1//1 2//1 3//1\ng b\nv 1 1 1\nf 2 4 3\n".to_vec()),
        (Format::Off, b"OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 1\n3 0 1 2\n3 1 3 2\n".to_vec()),
        (Format::Ply, binary_ply(&v, &[[0, 1, 2], [1, 3, 2]])),
        (Format::Ply, b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n".to_vec()),
    ]
}

/// Whatever the bytes, the readers return, and never through the panic guard.
fn never_panics(format: Format, bytes: &[u8]) {
    match parse(bytes, format, Path::new("fuzz")) {
        Ok(m) => m.check().unwrap(),
        Err(e) => assert!(
            !e.message.contains("internal error"),
            "a reader panicked on {bytes:?}: {e}"
        ),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300), f in 0usize..3) {
        never_panics([Format::Obj, Format::Ply, Format::Off][f], &bytes);
    }

    #[test]
    fn mutated_files_never_panic(which in 0usize..4, edits in proptest::collection::vec((any::<usize>(), any::<u8>(), 0u8..3), 1..6)) {
        let (format, mut bytes) = seeds().swap_remove(which);
        for (at, byte, kind) in edits {
            if bytes.is_empty() { break; }
            let i = at % bytes.len();
            match kind {
                0 => bytes[i] = byte,
                1 => { bytes.remove(i); }
                _ => bytes.insert(i, byte),
            }
        }
        never_panics(format, &bytes);
    }
}

/// Fixed corpus of inputs that once looked dangerous; kept as regression tests.
#[test]
fn fuzz_corpus() {
    let corpus: [(Format, &[u8]); 8] = [
        (Format::Ply, b"ply\nformat binary_little_endian 1.0\nelement vertex 4294967295\nproperty float x\nend_header\n"),
        (Format::Ply, b"ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n3 0 1 2\n"),
        (Format::Ply, b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n\0\0\0\0\0\0\0\0\0\0\0\0\xff\xff\xff\xff"),
        (Format::Obj, b"f 1 2 3\n"),
        (Format::Obj, b"v 1e39 0 0\nv 0 0 0\nv 0 1 0\nf 1 2 3\n"),
        (Format::Obj, b"v 0 0 0\nv 0 0 0\nv 0 0 0\nf 1 2 3\n"),
        (Format::Off, b"OFF\n3 1\n0 0 0\n1 0 0\n0 1 0\n18446744073709551615 0 1 2\n"),
        (Format::Off, b"\xff\xfe"),
    ];
    for (format, bytes) in corpus {
        never_panics(format, bytes);
    }
}

#[test]
fn load_names_unknown_formats_and_missing_files() {
    let e = vunify::mesh::load(Path::new("model.stl"), &CleanOptions::default()).unwrap_err();
    assert!(e.to_string().contains("model.stl") && e.message.contains("unknown mesh format"));
    let e =
        vunify::mesh::load(Path::new("/nonexistent/x.obj"), &CleanOptions::default()).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/x.obj") && e.message.contains("cannot read"));
    // Everything degenerate after welding: an error, not an empty tree.
    let dir = std::env::temp_dir().join(format!("vunify-input-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("flat.obj");
    std::fs::write(&p, "v 0 0 0\nv 0 0 0\nv 0 0 0\nf 1 2 3\n").unwrap();
    let e = vunify::mesh::load(&p, &CleanOptions::default()).unwrap_err();
    assert!(e.message.contains("degenerate"), "{e}");
}

/// The OBJ reader leaves unreferenced vertices out before the cleaning sees them; they are still
/// counted as unused.
#[test]
fn unused_vertices_are_counted_even_when_the_reader_skips_them() {
    let raw = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nf 1 2 3\n").unwrap();
    let (mesh, report) = clean(raw, &CleanOptions::default());
    assert_eq!((mesh.vertex_count(), report.unused_vertices), (3, 1));
}

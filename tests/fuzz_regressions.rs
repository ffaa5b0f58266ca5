//! Every input a fuzzer flagged (`scripts/fuzz.sh`), kept with what the reader must do with it.
//! The inputs are in `tests/fuzz_inputs/`, named by target and the artifact's hash.

use std::path::Path;
use vunify::mesh::{self, Format};

fn input(name: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fuzz_inputs")
            .join(name),
    )
    .expect("the kept input")
}

/// Flagged as a slow unit by the PLY fuzzer on 2026-12-01 (while the machine paused the fuzzer; a
/// header of repeated, garbled declarations): now refused at its first bad header line, at once.
#[test]
fn ply_slow_unit_6633640a() {
    let bytes = input("ply-slow-unit-6633640a.ply");
    let e = mesh::parse(&bytes, Format::Ply, Path::new("slow.ply")).expect_err("a bad header");
    assert!(e.to_string().contains("bad PLY header"), "{e}");
}

/// Found by the glTF fuzzer on 2026-12-05 (a GLB whose JSON lost its `meshes` while a node still
/// names mesh 0): the `gltf` crate's validation panicked indexing the empty list. Now an error
/// naming the file.
#[test]
fn gltf_crash_43cf39d9() {
    let bytes = input("gltf-crash-43cf39d9.glb");
    let e = mesh::gltf::parse(&bytes, Path::new("crash.glb"))
        .err()
        .expect("a broken file");
    assert!(
        e.to_string()
            .starts_with("crash.glb: not a valid glTF file"),
        "{e}"
    );
}

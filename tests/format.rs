//! The .vtree file: round trips, atomic writes, and a reader that detects every corruption.

mod common;

use common::*;
use proptest::prelude::*;
use std::path::Path;
use vunify::vtree::{self, BuildOptions, VertexTree};

fn small_tree() -> VertexTree {
    let mesh = scene(
        &[grid(2, 2, |x, y| 0.1 * x * y), grid(1, 1, |_, _| 0.0)],
        3.0,
    );
    vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {})
        .unwrap()
        .0
}

#[test]
fn round_trip_is_exact() {
    let tree = small_tree();
    let bytes = vtree::to_bytes(&tree);
    assert_eq!(&bytes[..8], b"VUNIFYVT");
    assert_eq!(
        vtree::read_bytes(&bytes, Path::new("t.vtree")).unwrap(),
        tree
    );
}

#[test]
fn every_single_byte_corruption_is_detected() {
    let bytes = vtree::to_bytes(&small_tree());
    for i in 0..bytes.len() {
        for flip in [0x01u8, 0x80, 0xFF, 0x5A] {
            let mut bad = bytes.clone();
            bad[i] ^= flip;
            let e = vtree::read_bytes(&bad, Path::new("bad.vtree"));
            assert!(e.is_err(), "byte {i} ^ {flip:#x} went unnoticed");
            assert!(e.unwrap_err().to_string().starts_with("bad.vtree"));
        }
    }
}

#[test]
fn every_truncation_and_extension_is_detected() {
    let bytes = vtree::to_bytes(&small_tree());
    for len in 0..bytes.len() {
        assert!(
            vtree::read_bytes(&bytes[..len], Path::new("t.vtree")).is_err(),
            "truncated to {len}"
        );
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(vtree::read_bytes(&longer, Path::new("t.vtree")).is_err());
}

#[test]
fn wrong_version_is_named() {
    let mut bytes = vtree::to_bytes(&small_tree());
    bytes[8] = 7;
    let e = vtree::read_bytes(&bytes, Path::new("v.vtree")).unwrap_err();
    assert_eq!(
        e.kind,
        vunify::vtree::FormatErrorKind::WrongVersion { found: 7 }
    );
    assert!(e.to_string().contains("version 7"), "{e}");
    assert!(e.to_string().contains("newer vunify"), "{e}");
    bytes[8] = 0;
    let e = vtree::read_bytes(&bytes, Path::new("v.vtree")).unwrap_err();
    assert!(
        e.to_string().contains("rebuild it with `vunify build`"),
        "{e}"
    );
}

/// A tree without appearance is written as version 1, which readers from before textures read; a
/// textured one as version 2, and this build reads both.
#[test]
fn appearance_bumps_the_version() {
    let plain = small_tree();
    let bytes = vtree::to_bytes(&plain);
    assert_eq!(bytes[8..12], 1u32.to_le_bytes());
    assert!(vtree::read_bytes(&bytes, Path::new("v1.vtree")).is_ok());
    let mut textured = small_tree();
    let n = textured.nodes.len();
    textured.appearance = Some(vtree::Appearance {
        uvs: vec![[0.25, 0.5]; n],
        texture_of: vec![vunify::mesh::NO_TEXTURE; n],
        textures: Vec::new(),
    });
    let bytes = vtree::to_bytes(&textured);
    assert_eq!(bytes[8..12], 2u32.to_le_bytes());
    let back = vtree::read_bytes(&bytes, Path::new("v2.vtree")).unwrap();
    assert_eq!(back.appearance, textured.appearance);
}

/// A well-formed file (checksums fixed up) whose tree is wrong is still rejected: the reader checks the
/// structure, not just the bytes.
#[test]
fn consistent_checksums_do_not_hide_a_broken_tree() {
    let mut tree = small_tree();
    let root = tree.root() as usize;
    tree.nodes[root - 1].parent = vtree::NONE; // two roots
    let e = vtree::read_bytes(&vtree::to_bytes(&tree), Path::new("two-roots.vtree")).unwrap_err();
    assert!(e.message.contains("inconsistent"), "{e}");
    let mut tree = small_tree();
    tree.triangles[0][1] = tree.leaf_count + 5; // index out of range
    assert!(vtree::read_bytes(&vtree::to_bytes(&tree), Path::new("t")).is_err());
    let mut tree = small_tree();
    let u = tree.leaf_count as usize;
    tree.nodes[u].error = -1.0;
    assert!(vtree::read_bytes(&vtree::to_bytes(&tree), Path::new("t")).is_err());
}

proptest! {
    /// Any one link of the tree pointed elsewhere is caught, although the check reads each link
    /// from one side only (a child's parent, never the parent's list of children; the other side
    /// follows from counting).
    #[test]
    fn every_rewired_link_is_caught(node in 0usize..1000, target in 0u32..1000, side in 0usize..3) {
        let mut tree = small_tree();
        let count = tree.nodes.len();
        let u = node % count;
        let target = target % count as u32;
        let leaves = tree.leaf_count as usize;
        let old = if side == 2 || u < leaves {
            std::mem::replace(&mut tree.nodes[u].parent, target)
        } else {
            std::mem::replace(&mut tree.nodes[u].children[side], target)
        };
        prop_assume!(old != target);
        prop_assert!(vtree::check(&tree).is_err(), "node {u} side {side}: {old} -> {target}");
    }
}

#[test]
fn writes_are_atomic_and_leave_no_temporary_files() {
    let dir = std::env::temp_dir().join(format!("vunify-format-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("tree.vtree");
    std::fs::write(&path, b"old contents").unwrap();
    let tree = small_tree();
    vtree::write(&tree, &path).unwrap();
    assert_eq!(vtree::read(&path).unwrap(), tree);
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("tree.vtree")]);
    // A write that cannot happen leaves the old file as it was.
    assert!(vtree::write(&tree, &dir.join("missing-dir").join("x.vtree")).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn random_bytes_are_errors(mut bytes in proptest::collection::vec(any::<u8>(), 0..2000), magic in any::<bool>()) {
        if magic && bytes.len() >= 12 {
            bytes[..8].copy_from_slice(b"VUNIFYVT");
            bytes[8..12].copy_from_slice(&1u32.to_le_bytes());
        }
        prop_assert!(vtree::read_bytes(&bytes, Path::new("r")).is_err());
    }

    #[test]
    fn random_multi_byte_damage_is_detected(edits in proptest::collection::vec((any::<usize>(), 1u8..=255), 1..8)) {
        let bytes = vtree::to_bytes(&small_tree());
        let mut bad = bytes.clone();
        for (at, x) in edits {
            let i = at % bad.len();
            bad[i] ^= x;
        }
        prop_assume!(bad != bytes);
        prop_assert!(vtree::read_bytes(&bad, Path::new("r")).is_err());
    }
}

/// A tree keeps the input's materials and each node's (a leaf's is its vertex's) through its
/// bytes; every corrupted byte of the MATL section is caught; a tree written without them reads
/// as one without materials.
#[test]
fn materials_round_trip() {
    use vunify::mesh::{AlphaMode, Material};
    let mut mesh = scene(
        &[grid(2, 2, |x, y| 0.1 * x * y), grid(1, 1, |_, _| 0.0)],
        3.0,
    );
    // The second grid's vertices come after the first's: material 1.
    let first_part_vertices = mesh.triangles[..mesh.parts[0].triangles.end as usize]
        .iter()
        .flatten()
        .max()
        .map_or(0, |&v| v + 1);
    mesh.material_of = Some(
        (0..mesh.positions.len() as u32)
            .map(|v| u32::from(v >= first_part_vertices))
            .collect(),
    );
    mesh.materials = vec![
        Material {
            name: "steel".into(),
            metallic_factor: 0.9,
            ..Material::default()
        },
        Material {
            name: "glass".into(),
            alpha_mode: AlphaMode::Blend,
            base_color_factor: [0.8, 0.9, 1.0, 0.3],
            double_sided: true,
            ..Material::default()
        },
    ];
    let tree = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {})
        .unwrap()
        .0;
    let m = tree.materials.as_ref().expect("materials kept");
    assert_eq!(m.list, mesh.materials);
    assert_eq!(m.of.len(), tree.nodes.len());
    assert_eq!(
        &m.of[..mesh.positions.len()],
        &mesh.material_of.as_ref().unwrap()[..]
    );
    let bytes = vtree::to_bytes(&tree);
    assert_eq!(
        vtree::read_bytes(&bytes, Path::new("m.vtree")).unwrap(),
        tree
    );
    let plain = VertexTree {
        materials: None,
        wedges: None,
        ..tree.clone()
    };
    let plain_bytes = vtree::to_bytes(&plain);
    assert_eq!(
        vtree::read_bytes(&plain_bytes, Path::new("p.vtree")).unwrap(),
        plain
    );
    // The MATL section is the last: each of its bytes flipped is an error.
    for i in plain_bytes.len()..bytes.len() {
        let mut bad = bytes.clone();
        bad[i] ^= 0x5A;
        assert!(
            vtree::read_bytes(&bad, Path::new("bad.vtree")).is_err(),
            "byte {i}"
        );
    }
}

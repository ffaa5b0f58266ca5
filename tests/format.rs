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

/// An output that is not a file (a named pipe here; `/dev/null` in use) is written into, never
/// replaced by a renamed file: as root, `-o /dev/null` once replaced the device with a file.
#[cfg(unix)]
#[test]
fn writes_into_a_pipe_or_device_keep_it_what_it_is() {
    use std::os::unix::fs::FileTypeExt;
    let dir = std::env::temp_dir().join(format!("vunify-fifo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let fifo = dir.join("out.vtree");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("no mkfifo here; skipping the named-pipe half");
    } else {
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        let tree = small_tree();
        vtree::write(&tree, &fifo).unwrap();
        let bytes = reader.join().unwrap();
        assert_eq!(vtree::read_bytes(&bytes, &fifo).unwrap(), tree);
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    }
    // The device itself: still a character device afterwards, whoever runs the test.
    vunify::export::write_atomic(Path::new("/dev/null"), b"nothing").unwrap();
    let null = std::fs::metadata("/dev/null").unwrap();
    assert!(null.file_type().is_char_device(), "/dev/null was replaced");
    // A folder is refused, not replaced.
    assert!(vunify::export::write_atomic(&dir, b"x").is_err());
    assert!(dir.is_dir());
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

/// A tree of several pages: a wavy 90 × 90 grid (8,281 leaves, 16,561 nodes) and a loose
/// fan beside it, so that the pages hold separate parts and non-edge merges too.
fn paged_tree() -> VertexTree {
    let mesh = scene(
        &[
            grid(90, 90, |x, y| 3.0 * (0.21 * x).sin() * (0.13 * y).cos()),
            grid(3, 1, |x, _| x * x),
        ],
        4.0,
    );
    vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {})
        .unwrap()
        .0
}

/// The leaves under each node of `tree` as a range of ids, if its leaves are numbered
/// depth-first (`None` otherwise).
fn leaf_ranges(tree: &VertexTree) -> Option<Vec<[u32; 2]>> {
    let mut range = vec![[0u32; 2]; tree.nodes.len()];
    for u in 0..tree.nodes.len() as u32 {
        range[u as usize] = if u < tree.leaf_count {
            [u, u + 1]
        } else {
            let [a, b] = tree.nodes[u as usize].children.map(|c| range[c as usize]);
            if a[1] != b[0] {
                return None;
            }
            [a[0], b[1]]
        };
    }
    Some(range)
}

/// The angle between two vectors, radians.
fn angle(a: glam::Vec3, b: glam::Vec3) -> f32 {
    a.normalize().dot(b.normalize()).clamp(-1.0, 1.0).acos()
}

/// The paged file keeps every link and triangle exactly, and everything it rounds it rounds the
/// safe way: positions within the stated error, each error grown by at least its node's move,
/// each sphere holding the built one, each cone holding the built one.
#[test]
fn paged_round_trip_keeps_links_and_widens_every_bound() {
    let tree = paged_tree();
    let bytes = vtree::to_bytes_with(&tree, vtree::Encoding::Paged);
    assert_eq!(bytes[8..12], 6u32.to_le_bytes());
    let back = vtree::read_bytes(&bytes, Path::new("p.vtree")).unwrap();
    // The leaves depth-first, so that every node's leaves are a range; all else as built.
    assert!(leaf_ranges(&tree).is_none());
    assert!(leaf_ranges(&back).is_some());
    let id = file_ids(&tree);
    let file = |u: u32| if u == vtree::NONE { u } else { id[u as usize] };
    assert_eq!(back.leaf_count, tree.leaf_count);
    let renumbered: Vec<[u32; 3]> = tree.triangles.iter().map(|t| t.map(file)).collect();
    assert_eq!(back.triangles, renumbered);
    assert_eq!(back.vanish_offsets, tree.vanish_offsets);
    assert_eq!(back.parts, tree.parts);
    let diagonal = tree.diagonal();
    assert!(back.position_error > 0.0 && back.position_error < 1e-4 * diagonal);
    for (u, a) in tree.nodes.iter().enumerate() {
        let b = &back.nodes[file(u as u32) as usize];
        assert_eq!(
            (a.children.map(file), file(a.parent)),
            (b.children, b.parent),
            "node {u}"
        );
        let moved = a.position().distance(b.position());
        assert!(moved <= back.position_error, "node {u} moved {moved}");
        assert!(
            b.error >= a.error + moved,
            "node {u}: {} from {}",
            b.error,
            a.error
        );
        let (ca, cb) = (
            glam::Vec3::from_slice(&a.sphere),
            glam::Vec3::from_slice(&b.sphere),
        );
        assert!(
            ca.distance(cb) + a.sphere[3] <= b.sphere[3] * (1.0 + 1e-6),
            "node {u}: sphere {:?} does not hold {:?}",
            b.sphere,
            a.sphere
        );
        if a.cone[3] > -1.0 {
            let (axis_a, axis_b) = (
                glam::Vec3::from_slice(&a.cone),
                glam::Vec3::from_slice(&b.cone),
            );
            let wide = b.cone[3] <= -1.0
                || angle(axis_a, axis_b) + a.cone[3].acos() <= b.cone[3].acos() + 1e-4;
            assert!(
                wide,
                "node {u}: cone {:?} does not hold {:?}",
                b.cone, a.cone
            );
        }
        let n = glam::Vec3::from_array(a.normal);
        if n != glam::Vec3::ZERO {
            assert!(angle(n, glam::Vec3::from_array(b.normal)) < 0.1f32.to_radians());
        }
    }
    // The strict bound still bounds the distance to the input's (the built tree's) leaves, and
    // every stored sphere holds every stored position of its subtree.
    let bounds = back.deviation_bounds();
    for v in 0..tree.leaf_count {
        let (p, stored) = (
            tree.nodes[v as usize].position(),
            back.nodes[file(v) as usize].position(),
        );
        let mut u = file(v);
        while u != vtree::NONE {
            let node = &back.nodes[u as usize];
            let d = p.distance(node.position());
            assert!(d <= bounds[u as usize], "leaf {v} at {d} from node {u}");
            let reach = stored.distance(glam::Vec3::from_slice(&node.sphere));
            assert!(
                reach <= node.sphere[3] * (1.0 + 1e-5),
                "leaf {v} outside node {u}'s sphere"
            );
            u = node.parent;
        }
    }
    // About a third of the exact file.
    let exact = vtree::to_bytes(&tree).len();
    assert!(
        bytes.len() * 5 < exact * 2,
        "{} vs {exact} bytes",
        bytes.len()
    );
}

/// Pages are connected pieces of the tree of at most `PAGE_NODES` nodes, each node in exactly
/// one, each page's root its only node whose parent lies outside it; the root's page is last.
/// A paged file written to disk keeps its coded pages in a temporary file beside it until they
/// are written in page order: the same bytes as in memory, and nothing left in the folder.
#[test]
fn pages_waiting_on_disk_make_the_same_file() {
    let tree = paged_tree();
    let dir = std::env::temp_dir().join(format!("vunify-paged-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("paged.vtree");
    vtree::write_with(&tree, &path, vtree::Encoding::Paged).unwrap();
    assert!(std::fs::read(&path).unwrap() == vtree::to_bytes_with(&tree, vtree::Encoding::Paged));
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("paged.vtree")]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn pages_are_connected_subtrees_of_bounded_size() {
    let tree = vtree::read_bytes(
        &vtree::to_bytes_with(&paged_tree(), vtree::Encoding::Paged),
        Path::new("p.vtree"),
    )
    .unwrap();
    let bytes = vtree::to_bytes_with(&tree, vtree::Encoding::Paged);
    let pages = vtree::read_pages(&bytes, Path::new("p.vtree")).unwrap();
    assert!(pages.len() >= 4, "{} pages", pages.len());
    let mut page_of = vec![usize::MAX; tree.nodes.len()];
    for (p, page) in pages.iter().enumerate() {
        assert!(!page.nodes.is_empty() && page.nodes.len() <= vtree::PAGE_NODES);
        for &u in &page.nodes {
            assert_eq!(page_of[u as usize], usize::MAX, "node {u} in two pages");
            page_of[u as usize] = p;
        }
    }
    assert!(page_of.iter().all(|&p| p != usize::MAX));
    for (p, page) in pages.iter().enumerate() {
        for &u in &page.nodes {
            let parent = tree.nodes[u as usize].parent;
            let outside = parent == vtree::NONE || page_of[parent as usize] != p;
            assert_eq!(outside, u == page.root, "page {p}, node {u}");
        }
    }
    assert_eq!(pages.last().unwrap().root, tree.root());
    // The exact layout has none.
    let exact = vtree::to_bytes(&tree);
    assert!(
        vtree::read_pages(&exact, Path::new("e.vtree"))
            .unwrap()
            .is_empty()
    );
}

/// A changed byte inside a page is caught, named by its page and the page's byte offset; the
/// same bytes come out on any number of threads.
#[test]
fn a_corrupt_page_is_named_and_pages_are_deterministic() {
    let tree = paged_tree();
    let bytes = vtree::to_bytes_with(&tree, vtree::Encoding::Paged);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| vtree::to_bytes_with(&tree, vtree::Encoding::Paged));
    assert_eq!(one, bytes);
    // The last section before PART is PDAT; flip bytes spread over it.
    let pages = vtree::read_pages(&bytes, Path::new("p.vtree")).unwrap();
    assert!(pages.len() > 1);
    let len = bytes.len();
    for i in (len / 3..len - 64).step_by(997) {
        let mut bad = bytes.clone();
        bad[i] ^= 0x21;
        let e = vtree::read_bytes(&bad, Path::new("bad.vtree")).unwrap_err();
        assert!(e.offset.is_some(), "byte {i}: {e}");
    }
    // A page's own checksum catches what the section's would (a reader of single pages relies
    // on it): corrupt one page and fix the section's checksum.
    let mut bad = bytes.clone();
    let table_end = 16 + 32 * u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let pdat = (0..table_end / 32)
        .map(|k| 16 + 32 * k)
        .find(|&at| &bytes[at..at + 4] == b"PDAT")
        .unwrap();
    let offset = u64::from_le_bytes(bytes[pdat + 8..pdat + 16].try_into().unwrap()) as usize;
    let length = u64::from_le_bytes(bytes[pdat + 16..pdat + 24].try_into().unwrap()) as usize;
    bad[offset + length / 2] ^= 0x10;
    let sum = crc32fast::hash(&bad[offset..offset + length]);
    bad[pdat + 24..pdat + 28].copy_from_slice(&sum.to_le_bytes());
    let table_crc = crc32fast::hash(&bad[..table_end]);
    bad[table_end..table_end + 4].copy_from_slice(&table_crc.to_le_bytes());
    let e = vtree::read_bytes(&bad, Path::new("bad.vtree")).unwrap_err();
    assert!(
        e.message.contains("page") && e.message.contains("checksum"),
        "{e}"
    );
    assert!(e.offset.is_some_and(|o| o as usize >= offset), "{e}");
}

/// Sets every checksum of a paged file right again: each page's in the directory, each
/// section's and the table's, so that damage reaches the page decoder itself.
fn fix_checksums(bytes: &mut [u8]) {
    let u32_at = |b: &[u8], at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let u64_at = |b: &[u8], at: usize| u64::from_le_bytes(b[at..at + 8].try_into().unwrap());
    let count = u32_at(bytes, 12) as usize;
    let table_end = 16 + 32 * count;
    let section = |b: &[u8], tag: &[u8; 4]| {
        let at = (0..count)
            .map(|k| 16 + 32 * k)
            .find(|&at| &b[at..at + 4] == tag)?;
        Some((at, u64_at(b, at + 8) as usize, u64_at(b, at + 16) as usize))
    };
    let (Some((_, dir, _)), Some((_, data, _))) =
        (section(bytes, b"PAGE"), section(bytes, b"PDAT"))
    else {
        return;
    };
    // The directory may be damaged too: fix what it still points at.
    for p in 0..(u32_at(bytes, dir) as usize).min(1 << 16) {
        let entry = dir + 12 + 24 * p;
        if entry + 24 > data {
            break;
        }
        let (offset, length) = (
            u64_at(bytes, entry) as usize,
            u32_at(bytes, entry + 8) as usize,
        );
        let Some(body) = data
            .checked_add(offset)
            .and_then(|a| bytes.get(a..a.checked_add(length)?))
        else {
            continue;
        };
        let sum = crc32fast::hash(body);
        bytes[entry + 12..entry + 16].copy_from_slice(&sum.to_le_bytes());
    }
    for k in 0..count {
        let at = 16 + 32 * k;
        let (offset, length) = (
            u64_at(bytes, at + 8) as usize,
            u64_at(bytes, at + 16) as usize,
        );
        let sum = crc32fast::hash(&bytes[offset..offset + length]);
        bytes[at + 24..at + 28].copy_from_slice(&sum.to_le_bytes());
    }
    let sum = crc32fast::hash(&bytes[..table_end]);
    bytes[table_end..table_end + 4].copy_from_slice(&sum.to_le_bytes());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Damage inside the pages that every checksum was made to agree with reaches the decoder,
    /// which answers with an error (or, where the damage only moved a number within range, a
    /// tree that passes the check), never a panic.
    #[test]
    fn damaged_pages_with_good_checksums_are_errors_not_panics(
        damage in proptest::collection::vec((0.0f64..1.0, any::<u8>()), 1..6)
    ) {
        static BYTES: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
        let bytes = BYTES.get_or_init(|| {
            vtree::to_bytes_with(&paged_tree(), vtree::Encoding::Paged)
        });
        let mut bad = bytes.clone();
        // The pages lie in the second half of the file, before PART.
        let start = 16 + 32 * 5;
        for (at, x) in damage {
            let i = start + ((bad.len() - start - 40) as f64 * at) as usize;
            bad[i] ^= x | 1;
        }
        fix_checksums(&mut bad);
        if let Ok(tree) = vtree::read_bytes(&bad, Path::new("damaged.vtree")) {
            prop_assert!(vtree::check(&tree).is_ok());
        }
    }
}

/// Writes `bytes` to a fresh file named `name` in the temporary folder; returns its path.
fn temp_file(name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let path = std::env::temp_dir().join(format!("vunify-{}-{name}", std::process::id()));
    std::fs::write(&path, bytes).unwrap();
    path
}

/// A paged file numbers its leaves depth-first, so a page read alone gives each of its nodes the
/// leaves under it as a range (what a streaming reader places triangles by), the same ranges as
/// the whole tree's.
#[test]
fn each_page_read_alone_knows_the_leaves_under_its_nodes() {
    let bytes = vtree::to_bytes_with(&paged_tree(), vtree::Encoding::Paged);
    let path = temp_file("leaves.vtree", &bytes);
    let file = vtree::PagedFile::open(&path).unwrap();
    assert!(file.leaves_depth_first());
    let whole = vtree::read(&path).unwrap();
    let ranges = leaf_ranges(&whole).expect("the file's leaves are depth-first");
    assert_eq!(ranges[whole.root() as usize], [0, whole.leaf_count]);
    for (p, entry) in file.entries.iter().enumerate() {
        let page = file.read_page(p).unwrap();
        assert_eq!(page.leaves.len(), page.ids.len());
        for (&id, &leaves) in page.ids.iter().zip(&page.leaves) {
            assert_eq!(leaves, ranges[id as usize], "page {p}, node {id}");
        }
        assert_eq!(entry.leaves, Some(ranges[entry.root as usize]));
    }
    std::fs::remove_file(&path).unwrap();
}

/// A directory whose leaves do not match its pages (checksums intact) is refused, naming the
/// page, by both readers; the page-by-page reader refuses only the pages it touches.
#[test]
fn a_directory_that_lies_about_a_pages_leaves_is_refused() {
    let mut bytes = vtree::to_bytes_with(&paged_tree(), vtree::Encoding::Paged);
    let dir = section(&bytes, b"PAGE");
    // Page 0's root: one leaf later than it is (12 bytes of head, then 32 an entry).
    let first = dir.start + 12 + 24;
    let lo = u32::from_le_bytes(bytes[first..first + 4].try_into().unwrap());
    bytes[first..first + 8]
        .copy_from_slice(&[(lo + 1).to_le_bytes(), (lo + 2).to_le_bytes()].concat());
    reseal(&mut bytes);
    let error = vtree::read_bytes(&bytes, Path::new("lies.vtree")).unwrap_err();
    assert!(error.to_string().contains("leaves"), "{error}");
    let path = temp_file("lies.vtree", &bytes);
    let file = vtree::PagedFile::open(&path).unwrap();
    let error = file.read_page(0).err().expect("page 0 refused").to_string();
    assert!(
        error.contains("page 0") && error.contains("leaves"),
        "{error}"
    );
    // Page 0 and the page that holds its root's parent, whose children's leaves no longer
    // follow each other; every other page reads.
    let refused = (0..file.entries.len())
        .filter(|&p| file.read_page(p).is_err())
        .count();
    assert_eq!(refused, 2);
    std::fs::remove_file(&path).unwrap();
}

/// A version 4 file (written by the build before leaves were numbered depth-first; the cessna)
/// still reads whole and page by page, its pages without leaf ranges.
#[test]
fn a_version_4_file_still_reads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/cessna-v4.vtree");
    assert_eq!(std::fs::read(&path).unwrap()[8..12], 4u32.to_le_bytes());
    let tree = vtree::read(&path).unwrap();
    assert_eq!((tree.leaf_count, tree.nodes.len()), (6795, 13589));
    let file = vtree::PagedFile::open(&path).unwrap();
    assert!(!file.leaves_depth_first());
    let page = file.read_page(0).unwrap();
    assert!(page.leaves.is_empty() && !page.ids.is_empty());
    assert_eq!(
        file.survey().unwrap().root,
        Some(tree.nodes[tree.root() as usize])
    );
}

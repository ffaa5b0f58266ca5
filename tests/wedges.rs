//! Wedges: per-corner appearance through the tree (Hoppe, *Efficient implementation of progressive
//! meshes*, 1998). A UV seam is one line of nodes, each with a wedge per side; no cut, static or
//! live, shows one side's texture coordinates on the other side's triangles.

mod common;

use common::{file_ids, reseal, section};
use glam::{Vec2, Vec3};
use proptest::prelude::*;
use vunify::mesh::{Material, Mesh};
use vunify::refine::validation::check_front;
use vunify::refine::{Front, Hierarchy};
use vunify::vtree::{self, BuildOptions, VertexTree};

/// Chart A's texture coordinates at `p` (left half, `u` in 0.05..0.45) and chart B's (right half,
/// `u` in 0.55..0.95): each a linear map of the plane.
fn chart_a(p: Vec3) -> Vec2 {
    Vec2::new(0.05 + 0.4 * p.x / 3.0, 0.05 + 0.9 * p.y / 6.0)
}
fn chart_b(p: Vec3) -> Vec2 {
    Vec2::new(0.55 + 0.4 * (p.x - 3.0) / 3.0, 0.05 + 0.9 * p.y / 6.0)
}

/// A 6 × 6 grid of unit squares in the plane z = 0 (a little bumpy, so that merges have a price),
/// textured as two charts with a seam at x = 3:
///
/// ```text
///   y 6 +--+--+--+--+--+--+
///       |  chart A ‖ chart B |
///     0 +--+--+--+--+--+--+  x
///       0        3        6
/// ```
///
/// The seam's 7 vertices are two each (one per chart): 49 places, 56 vertices.
fn two_charts() -> Mesh {
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    let mut id = std::collections::HashMap::new();
    let mut vertex = |x: u32, y: u32, chart: u32| {
        *id.entry((x, y, chart)).or_insert_with(|| {
            let bump = 0.05 * ((x * 7 + y * 3) % 5) as f32 / 5.0;
            let p = Vec3::new(x as f32, y as f32, bump);
            positions.push(p);
            uvs.push(if chart == 0 { chart_a(p) } else { chart_b(p) });
            positions.len() as u32 - 1
        })
    };
    let mut triangles = Vec::new();
    for y in 0..6 {
        for x in 0..6 {
            let chart = u32::from(x >= 3);
            let [a, b, c, d] =
                [(x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)].map(|(x, y)| vertex(x, y, chart));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    let count = positions.len();
    let mut mesh = Mesh::from_triangles(positions, triangles);
    mesh.uvs = Some(uvs);
    mesh.colors = Some(vec![Vec3::ONE; count]);
    mesh.texture_of = Some(vec![0; count]);
    mesh.textures = vec![std::sync::Arc::new(vunify::fixtures::checker_texture())];
    mesh.materials = vec![Material {
        name: "two charts".into(),
        base_color_texture: Some(0),
        ..Material::default()
    }];
    mesh.material_of = Some(vec![0; count]);
    mesh
}

fn build(mesh: &Mesh) -> VertexTree {
    vtree::build(mesh, &BuildOptions::default(), &mut |_, _| {})
        .expect("build")
        .0
}

/// Which chart a leaf's texture coordinates belong to.
fn chart_of(uv: [f32; 2]) -> u32 {
    u32::from(uv[0] > 0.5)
}

/// Each wedge's chart, from its leaf wedges' (`leaf_chart`, `None` for an internal wedge),
/// carried up its parents (`NONE`/`NIL` is `u32::MAX`); `None` where a wedge joins both charts.
fn charts(parent: &[u32], leaf_chart: impl Fn(usize) -> Option<u32>) -> Vec<Option<u32>> {
    let mut chart: Vec<Option<Option<u32>>> = vec![None; parent.len()];
    for x in 0..parent.len() {
        if let Some(c) = leaf_chart(x) {
            let mut y = x;
            loop {
                chart[y] = match chart[y] {
                    None => Some(Some(c)),
                    Some(Some(d)) if d == c => Some(Some(c)),
                    _ => Some(None),
                };
                y = parent[y] as usize;
                if y == u32::MAX as usize {
                    break;
                }
            }
        }
    }
    chart.into_iter().map(|c| c.flatten()).collect()
}

#[test]
fn a_seam_is_one_line_of_nodes_with_a_wedge_per_side() {
    let mesh = two_charts();
    assert_eq!(mesh.positions.len(), 56);
    let tree = build(&mesh);
    let w = tree.wedges.as_ref().expect("a textured tree has wedges");
    assert_eq!(tree.leaf_count, 49, "one leaf per place");
    assert_eq!(
        w.node.iter().filter(|&&u| u < 49).count(),
        56,
        "a leaf wedge per vertex"
    );
    vtree::check(&tree).expect("consistent");
    // No wedge joins the two charts, and as the charts' maps are linear, every wedge has its
    // chart's coordinates at its node's place, at every level (the attribute quadric's best).
    let leaves = w.node.iter().filter(|&&u| u < tree.leaf_count).count();
    let chart = charts(&w.parent, |x| (x < leaves).then(|| chart_of(w.uv[x])));
    for (x, &c) in chart.iter().enumerate() {
        let Some(c) = c else {
            panic!("wedge {x} joins both charts");
        };
        let p = tree.nodes[w.node[x] as usize].position();
        let uv = Vec2::from_array(w.uv[x]);
        let want = if c == 0 { chart_a(p) } else { chart_b(p) };
        assert!(
            uv.distance(want) < 1e-3,
            "wedge {x}: {uv} at {p}, its chart says {want}"
        );
    }
}

#[test]
fn every_static_level_keeps_each_side_of_the_seam_its_own() {
    let tree = build(&two_charts());
    let w = tree.wedges.as_ref().unwrap();
    for merges in 0..tree.leaf_count {
        let cut = vtree::cut_at_merges(&tree, merges);
        let m = &cut.mesh;
        let uvs = m.uvs.as_ref().expect("coordinates");
        // Each triangle's corners show coordinates of one chart's map at their places.
        for t in &m.triangles {
            let fits = |map: fn(Vec3) -> Vec2| {
                t.iter()
                    .all(|&v| uvs[v as usize].distance(map(m.positions[v as usize])) < 1e-3)
            };
            assert!(
                fits(chart_a) || fits(chart_b),
                "after {merges} merges a triangle spans both charts"
            );
        }
        // One place per node: the two sides of the seam stand at the same nodes (no crack).
        let mut places: Vec<u32> = cut.nodes.clone();
        places.sort_unstable();
        places.dedup();
        let distinct: std::collections::HashSet<[u32; 3]> = m
            .positions
            .iter()
            .map(|p| p.to_array().map(f32::to_bits))
            .collect();
        assert_eq!(distinct.len(), places.len(), "after {merges} merges");
        assert!(m.positions.len() <= places.len() + w.len());
    }
}

#[test]
fn the_file_keeps_the_wedges_and_says_version_3() {
    let tree = build(&two_charts());
    let bytes = vtree::to_bytes(&tree);
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 3);
    let back = vtree::read_bytes(&bytes, std::path::Path::new("t.vtree")).expect("reads");
    assert_eq!(back, tree);
    // A wedge naming a node of the wrong level is caught by the check after reading.
    let mut bad = tree.clone();
    let w = bad.wedges.as_mut().unwrap();
    w.parent[0] = w.parent[0].wrapping_sub(1).min(w.len() as u32 - 1);
    if bad != tree {
        let err = vtree::check(&bad).expect_err("a wrong parent is caught");
        assert!(err.to_string().contains("wedge 0"), "{err}");
    }
}

/// A paged file numbers its leaves depth-first, and names them so everywhere: each node's texture
/// coordinates, texture and material, each wedge's node, each triangle's corners; the rest of
/// the wedges as built.
#[test]
fn a_paged_file_keeps_the_wedges_under_its_own_numbering() {
    let tree = build(&two_charts());
    let bytes = vtree::to_bytes_with(&tree, vtree::Encoding::Paged);
    let back = vtree::read_bytes(&bytes, std::path::Path::new("t.vtree")).expect("reads");
    let id = file_ids(&tree);
    assert_ne!(id, (0..tree.nodes.len() as u32).collect::<Vec<_>>());
    let file = |u: u32| id[u as usize] as usize;
    let (a, b) = (
        tree.appearance.as_ref().unwrap(),
        back.appearance.as_ref().unwrap(),
    );
    let (ma, mb) = (
        tree.materials.as_ref().unwrap(),
        back.materials.as_ref().unwrap(),
    );
    for u in 0..tree.nodes.len() as u32 {
        assert_eq!(a.uvs[u as usize], b.uvs[file(u)], "node {u}");
        assert_eq!(a.texture_of[u as usize], b.texture_of[file(u)], "node {u}");
        assert_eq!(ma.of[u as usize], mb.of[file(u)], "node {u}");
    }
    let (wa, wb) = (tree.wedges.as_ref().unwrap(), back.wedges.as_ref().unwrap());
    let nodes: Vec<u32> = wa.node.iter().map(|&u| file(u) as u32).collect();
    assert_eq!(wb.node, nodes);
    assert_eq!(
        (&wb.parent, &wb.uv, &wb.corners, &wb.texture, &wb.material),
        (&wa.parent, &wa.uv, &wa.corners, &wa.texture, &wa.material)
    );
    // Colours as sRGB bytes (within half a step), normals as the pages store them.
    for (k, (ca, cb)) in wa.color.iter().zip(&wb.color).enumerate() {
        let (a, b) = (Vec3::from_array(*ca), Vec3::from_array(*cb));
        assert!(a.distance(b) < 0.01, "wedge {k}: {a} against {b}");
    }
    for (k, (na, nb)) in wa.normal.iter().zip(&wb.normal).enumerate() {
        let (a, b) = (Vec3::from_array(*na), Vec3::from_array(*nb));
        assert!(
            a == b || a.angle_between(b) < 1e-3,
            "wedge {k}: {a} against {b}"
        );
    }
    // Coded small: the wedges take a third of the exact layout's bytes or less.
    let exact = vtree::to_bytes(&tree);
    let sizes = [&bytes, &exact].map(|b| section(b, b"WEDG").len());
    assert!(sizes[0] * 3 <= sizes[1], "{sizes:?}");
    let corners: Vec<[u32; 3]> = tree
        .triangles
        .iter()
        .map(|t| t.map(|c| file(c) as u32))
        .collect();
    assert_eq!(back.triangles, corners);
}

/// A paged file's wedges damaged where their checksum still holds (each byte in turn changed
/// three ways) are a clear error naming the file or a tree that passes the check, never a panic.
#[test]
fn damaged_wedges_are_errors_not_panics() {
    let bytes = vtree::to_bytes_with(&build(&two_charts()), vtree::Encoding::Paged);
    let wedg = section(&bytes, b"WEDG");
    for i in wedg.clone() {
        for flip in [0x01, 0x80, 0xff] {
            let mut bad = bytes.clone();
            bad[i] ^= flip;
            reseal(&mut bad);
            if let Err(e) = vtree::read_bytes(&bad, std::path::Path::new("w.vtree")) {
                assert!(e.to_string().contains("w.vtree"), "{e}");
            }
        }
    }
}

#[test]
fn a_mesh_without_appearance_has_no_wedges() {
    let mut mesh = two_charts();
    (mesh.uvs, mesh.texture_of, mesh.material_of) = (None, None, None);
    let tree = build(&mesh);
    assert!(tree.wedges.is_none());
    assert_eq!(
        tree.leaf_count, 56,
        "split vertices stay apart without wedges"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Fronts split and unified in random order show, at every corner, the wedge of the corner's
    /// node that its leaf wedge has become, and never the other chart's coordinates.
    #[test]
    fn live_fronts_show_each_corner_its_wedge(ops in prop::collection::vec(any::<u32>(), 1..200)) {
        let tree = build(&two_charts());
        let h = Hierarchy::new(&tree);
        let w = h.wedges.as_ref().expect("wedges");
        let chart = charts(&w.parent, |x| {
            h.is_leaf(w.node[x]).then(|| chart_of([h.uv_texture[x][0], 0.0]))
        });
        let mut front = Front::new(&h);
        for op in ops {
            let u = op % h.node_count();
            if front.can_split(&h, u) {
                front.split(&h, u);
            } else if !h.is_leaf(u) && front.can_unify(&h, u) {
                front.unify(&h, u);
            } else {
                continue;
            }
            check_front(&h, &front).map_err(TestCaseError::fail)?;
            for (t, v) in front.all_vertices(&h).iter().enumerate() {
                let c = v.map(|x| chart[x as usize]);
                prop_assert!(c[0].is_some() && c[0] == c[1] && c[1] == c[2], "triangle {t}: {c:?}");
                prop_assert!(v.iter().all(|&x| (x as usize) < w.len()));
            }
        }
    }
}

/// The wedges of the root node.
fn root_wedges(tree: &VertexTree) -> usize {
    let w = tree.wedges.as_ref().unwrap();
    w.node.iter().filter(|&&u| u == tree.root()).count()
}

#[test]
fn charts_stay_apart_to_the_root_and_one_chart_across_a_gap_joins() {
    // Two charts: their maps disagree everywhere (u differs by 0.5), so the root has two wedges.
    assert_eq!(root_wedges(&build(&two_charts())), 2);
    // One chart (A's map on both halves) cut in two along x = 3 with a hairline gap: no triangle
    // joins the halves' wedges, but their maps agree where the non-edge merges put them.
    let mut mesh = two_charts();
    let uvs = mesh.uvs.as_mut().unwrap();
    // The right half's copies of the seam vertices move by a hair.
    for (uv, p) in uvs.iter_mut().zip(&mut mesh.positions) {
        if p.x == 3.0 && uv.x > 0.5 {
            p.x += 1e-4;
        }
        *uv = chart_a(*p);
    }
    let tree = build(&mesh);
    assert_eq!(tree.leaf_count, 56, "the halves share no place");
    assert_eq!(root_wedges(&tree), 1);
}

/// A unit cube as exporters write a hard-edged one: 24 vertices, four per face with its face's
/// normal, one material.
fn hard_cube() -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            let (u, v) = n.any_orthonormal_pair();
            let (u, v) = if u.cross(v).dot(n) > 0.0 {
                (u, v)
            } else {
                (v, u)
            };
            let base = positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                positions.push(0.5 * (n + a * u + b * v));
                normals.push(n);
            }
            triangles.push([base, base + 1, base + 2]);
            triangles.push([base, base + 2, base + 3]);
        }
    }
    let count = positions.len();
    let mut mesh = Mesh::from_triangles(positions, triangles);
    mesh.normals = Some(normals);
    mesh.colors = Some(vec![Vec3::new(0.2, 0.8, 0.3); count]);
    mesh.materials = vec![Material::default()];
    mesh.material_of = Some(vec![0; count]);
    mesh
}

#[test]
fn a_hard_edge_stays_hard_at_every_level() {
    let mesh = hard_cube();
    let tree = build(&mesh);
    let w = tree
        .wedges
        .as_ref()
        .expect("a mesh with materials has wedges");
    assert_eq!(tree.leaf_count, 8, "one leaf per corner of the cube");
    assert_eq!(
        w.node.iter().filter(|&&u| u < 8).count(),
        24,
        "three wedges a corner"
    );
    // Every triangle of every level that is still a face of the cube is drawn with its face's
    // normal at all three corners: no join smooths a crease.
    for merges in 0..tree.leaf_count {
        let m = vtree::cut_at_merges(&tree, merges).mesh;
        let normals = m.normals.as_ref().expect("normals");
        for t in &m.triangles {
            let [a, b, c] = t.map(|v| m.positions[v as usize]);
            let face = (b - a).cross(c - a).normalize();
            for &v in t {
                let n = normals[v as usize];
                assert!(
                    n.dot(face) > 0.999 || face.abs().max_element() < 0.999,
                    "after {merges} merges: corner normal {n} on face {face}"
                );
            }
        }
    }
}

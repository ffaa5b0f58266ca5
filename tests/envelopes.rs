//! Zou, Shen and Peng's envelope methods (`simplify --method offset-patch | single-envelope | cohen`):
//! exact outcomes on hand-built meshes, the invariants of a triangle collapse on closed random
//! meshes, and Cohen's promise (output → input within ε) checked by the certified meter.

mod common;

use glam::Vec3;
use std::collections::HashMap;
use vunify::measure::{CertifyOptions, certified_hausdorff};
use vunify::mesh::{CleanOptions, Mesh, clean, load};
use vunify::simplify::DistanceError;
use vunify::simplify::envelope::{EnvelopeOptions, EnvelopeStats, Method, simplify_envelope};

const METHODS: [Method; 3] = [Method::OffsetPatch, Method::SingleEnvelope, Method::Cohen];

fn run(mesh: &Mesh, method: Method, epsilon: f64) -> (Mesh, EnvelopeStats) {
    let options = EnvelopeOptions {
        method,
        epsilon,
        target_triangles: 0,
    };
    simplify_envelope(mesh, &options, &mut |_| {}).unwrap()
}

/// How many faces use each undirected edge, and whether any directed edge is used twice.
fn edges(mesh: &Mesh) -> (HashMap<(Vec3Key, Vec3Key), usize>, bool) {
    let key = |v: u32| Vec3Key(mesh.positions[v as usize].to_array().map(f32::to_bits));
    let mut undirected = HashMap::new();
    let mut directed = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (key(t[k]), key(t[(k + 1) % 3]));
            *undirected.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            *directed.entry((a, b)).or_insert(0) += 1;
        }
    }
    let twice = directed.values().any(|&n| n > 1);
    (undirected, twice)
}

#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
struct Vec3Key([u32; 3]);

/// Every edge in exactly two faces, each way once: a closed, consistently oriented manifold.
fn assert_closed(mesh: &Mesh, what: &str) {
    let (undirected, twice) = edges(mesh);
    assert!(!twice, "{what}: a directed edge is used twice");
    assert!(
        undirected.values().all(|&n| n == 2),
        "{what}: an edge is not in exactly two faces"
    );
}

fn boundary(mesh: &Mesh) -> Vec<(Vec3Key, Vec3Key)> {
    let mut b: Vec<_> = edges(mesh)
        .0
        .into_iter()
        .filter(|&(_, n)| n == 1)
        .map(|(e, _)| e)
        .collect();
    b.sort_unstable();
    b
}

fn area(mesh: &Mesh) -> f64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize].as_dvec3());
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// A lone triangle: every corner is on a boundary edge, so nothing moves.
/// ```text
///   2
///   | \
///   0--1
/// ```
#[test]
fn a_single_triangle_is_kept() {
    let tri = Mesh::from_triangles(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
    for method in METHODS {
        let (out, stats) = run(&tri, method, 0.1);
        assert_eq!(out.positions, tri.positions, "{method:?}");
        assert_eq!(out.triangles, tri.triangles, "{method:?}");
        assert_eq!(stats.refused_frozen, 1, "{method:?}");
    }
}

/// A tetrahedron: collapsing any face would kill all four (the face and its three neighbours) and
/// leave nothing around the merged vertex, so every try is refused on topology.
#[test]
fn a_tetrahedron_is_kept() {
    let tetra = Mesh::from_triangles(
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
    );
    for method in METHODS {
        let (out, stats) = run(&tetra, method, 0.5);
        assert_eq!(out.triangle_count(), 4, "{method:?}");
        assert_eq!(stats.refused_topology, 4, "{method:?}");
        assert_eq!(stats.collapses_accepted, 0, "{method:?}");
    }
}

/// A flat 8 × 8 grid (128 triangles): its outline is frozen, its inside collapses in the plane. The
/// outline stays edge for edge, every vertex stays at z = 0 and the area is exactly the grid's.
#[test]
fn a_flat_grid_keeps_its_outline_and_its_plane() {
    let grid = common::grid(8, 8, |_, _| 0.0);
    for method in METHODS {
        let (out, stats) = run(&grid, method, 0.05);
        assert!(out.triangle_count() < 128, "{method:?}");
        assert_eq!(
            out.triangle_count(),
            128 - 4 * stats.collapses_accepted,
            "{method:?}"
        );
        assert!(out.positions.iter().all(|p| p.z == 0.0), "{method:?}");
        assert_eq!(boundary(&out), boundary(&grid), "{method:?}");
        assert!(
            (area(&out) - 64.0).abs() < 1e-9,
            "{method:?}: {}",
            area(&out)
        );
    }
}

/// A box 2 × 1 × 1 with each face split into 64 triangles (768 in all): every method leaves a
/// closed, consistently oriented box with fewer triangles, and Cohen's stays inside its envelope —
/// within ε of the box, certified.
#[test]
fn a_subdivided_box_stays_closed() {
    let cuboid = common::subdivided(&vunify::fixtures::cuboid(Vec3::new(2.0, 1.0, 1.0)), 3);
    let (cuboid, _) = clean(cuboid, &CleanOptions::default());
    assert_closed(&cuboid, "input");
    for method in METHODS {
        let (out, _) = run(&cuboid, method, 0.02);
        assert!(
            out.triangle_count() < cuboid.triangle_count() / 2,
            "{method:?}: {}",
            out.triangle_count()
        );
        assert_closed(&out, method.name());
    }
    let (out, _) = run(&cuboid, Method::Cohen, 0.02);
    assert_output_within(&cuboid, &out, 0.02, "box");
}

/// Cohen's promise: every point of the output within ε of the input.
fn assert_output_within(input: &Mesh, output: &Mesh, epsilon: f64, what: &str) {
    let options = CertifyOptions {
        relative: 1e-3,
        absolute: 1e-7,
        max_splits: 1_000_000,
        epsilon: None,
    };
    let c = certified_hausdorff(input, output, &options).unwrap();
    assert!(
        c.backward.upper <= epsilon,
        "{what}: output → input certified only below {} (ε {epsilon})",
        c.backward.upper
    );
}

/// A closed slab 0.05 thick (10 × 10 × 0.05), far thinner than 2ε: the whole envelopes shrink where
/// they would cross the other side, so Cohen's output keeps both faces apart — it stays closed and
/// within ε — and the local patches, which may not cross the original either, keep it closed.
#[test]
fn a_thin_slab_is_not_eroded_through() {
    let slab = common::subdivided(&vunify::fixtures::cuboid(Vec3::new(10.0, 10.0, 0.05)), 3);
    let (slab, _) = clean(slab, &CleanOptions::default());
    for method in METHODS {
        let (out, _) = run(&slab, method, 0.01);
        assert_closed(&out, method.name());
        // No vertex left the slab's thickness.
        assert!(
            out.positions
                .iter()
                .all(|p| (-1e-6..=0.05 + 1e-6).contains(&p.z)),
            "{method:?}"
        );
    }
    let (out, _) = run(&slab, Method::Cohen, 0.01);
    assert_output_within(&slab, &out, 0.01, "slab");
}

/// Random closed meshes — boxes of random proportions, subdivided and jittered, several at once
/// (separate components): every method keeps each a closed oriented manifold, four triangles per
/// accepted collapse, and Cohen's output within ε of the input.
#[test]
fn random_closed_meshes_keep_the_invariants() {
    let mut rng = common::Rng(11);
    for case in 0..6 {
        let boxes: Vec<Mesh> = (0..3)
            .map(|_| {
                let size = Vec3::new(0.5 + rng.f32(), 0.5 + rng.f32(), 0.2 + rng.f32());
                let mut m = common::subdivided(&vunify::fixtures::cuboid(size), 2);
                for p in &mut m.positions {
                    *p += Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 0.02;
                }
                clean(m, &CleanOptions::default()).0
            })
            .collect();
        let scene = common::scene(&boxes, 3.0);
        for method in METHODS {
            for epsilon in [0.005, 0.02] {
                let (out, stats) = run(&scene, method, epsilon);
                let what = format!("case {case}, {} at {epsilon}", method.name());
                assert_closed(&out, &what);
                assert_eq!(
                    out.triangle_count(),
                    scene.triangle_count() - 4 * stats.collapses_accepted,
                    "{what}"
                );
                if method == Method::Cohen {
                    assert_output_within(&scene, &out, epsilon, &what);
                }
            }
        }
    }
}

#[test]
fn bad_input_is_a_clear_error() {
    let tri = Mesh::from_triangles(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
    for method in METHODS {
        for epsilon in [0.0, -0.1, 1.0, f64::NAN] {
            let options = EnvelopeOptions {
                method,
                epsilon,
                target_triangles: 0,
            };
            let e = simplify_envelope(&tri, &options, &mut |_| {}).unwrap_err();
            assert!(matches!(e, DistanceError::Epsilon(_)), "{e}");
        }
        let options = EnvelopeOptions {
            method,
            epsilon: 0.01,
            target_triangles: 0,
        };
        let e = simplify_envelope(&Mesh::default(), &options, &mut |_| {}).unwrap_err();
        assert_eq!(e, DistanceError::Empty);
    }
}

/// The real models with boundaries (beetle: holes and non-manifold edges), inward-facing triangles
/// (horse) and thin parts (cessna): every method gives a valid mesh, and Cohen's is within ε.
#[test]
fn the_methods_work_on_the_real_models() {
    let Some(dir) = common::models_dir() else {
        return;
    };
    for name in [
        "cow.obj",
        "beetle.obj",
        "fandisk.obj",
        "cessna.obj",
        "horse.obj",
    ] {
        let (mesh, _) = load(&dir.join(name), &CleanOptions::default()).unwrap();
        let (mesh, _) = clean(mesh, &CleanOptions::default());
        for method in METHODS {
            let (out, stats) = run(&mesh, method, 0.01);
            out.check().unwrap();
            assert!(
                out.triangle_count() < mesh.triangle_count(),
                "{name} {method:?}"
            );
            eprintln!(
                "{name} {}: {} → {} triangles",
                method.name(),
                mesh.triangle_count(),
                stats.triangles
            );
            if method == Method::Cohen {
                assert_output_within(&mesh, &out, 0.01, name);
            }
        }
    }
}

//! The seed paper's simplification of lit meshes (`vunify superfaces`): superfaces, boundary
//! chains and the bridged ear clipping, on hand-built lit meshes with known answers.

mod common;

use glam::Vec3;
use vunify::mesh::Mesh;
use vunify::radiosity::superfaces::{SuperfaceOptions, simplify_superfaces, superfaces};

/// A flat `n × n` grid in z = 0 coloured by `colour(x, y)`.
fn lit_grid(n: u32, colour: impl Fn(f32, f32) -> Vec3) -> Mesh {
    let mut m = common::grid(n, n, |_, _| 0.0);
    m.colors = Some(m.positions.iter().map(|p| colour(p.x, p.y)).collect());
    m
}

fn area(m: &Mesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| m.positions[v as usize].as_dvec3());
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// No vertex of the mesh lies inside an edge of it (a T-junction).
fn assert_no_t_junctions(m: &Mesh) {
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (
                m.positions[t[k] as usize],
                m.positions[t[(k + 1) % 3] as usize],
            );
            for p in &m.positions {
                if *p == a || *p == b {
                    continue;
                }
                let (ab, ap) = (b - a, *p - a);
                let s = ap.dot(ab) / ab.length_squared();
                if s > 1e-6 && s < 1.0 - 1e-6 && (ap - ab * s).length() < 1e-6 {
                    panic!("{p} lies inside the edge {a}–{b}");
                }
            }
        }
    }
}

fn options(epsilon: f64, delta: f64) -> SuperfaceOptions {
    SuperfaceOptions {
        epsilon,
        delta,
        distance: 0.0,
    }
}

/// A uniformly lit 8 × 8 grid is one superface, and that is a square: 2 triangles, area 64.
#[test]
fn a_uniform_square_is_two_triangles() {
    let grid = lit_grid(8, |_, _| Vec3::splat(0.5));
    let (out, stats) = simplify_superfaces(&grid, &options(0.1, 2.0)).unwrap();
    assert_eq!(stats.superfaces, 1);
    assert_eq!(out.triangle_count(), 2);
    assert!((area(&out) - 64.0).abs() < 1e-9);
}

/// At ε = 0 no patch joins another: as many superfaces as triangles.
#[test]
fn epsilon_zero_merges_nothing() {
    let grid = lit_grid(4, |x, y| Vec3::splat(0.2 + 0.05 * (x + y)));
    let owner = superfaces(&grid, 0.0).unwrap();
    let mut distinct = owner.clone();
    distinct.sort_unstable();
    distinct.dedup();
    assert_eq!(distinct.len(), grid.triangle_count());
}

/// A shadow's edge across a 16 × 16 grid (dark for x < 6, bright beyond): the two sides become
/// separate superfaces, the edge between them stays where it was, the area is kept exactly and no
/// T-junction appears; every superface is planar (all of them lie in z = 0).
#[test]
fn a_shadow_edge_is_kept() {
    let grid = lit_grid(16, |x, _| Vec3::splat(if x < 6.0 { 0.1 } else { 0.8 }));
    let (out, stats) = simplify_superfaces(&grid, &options(0.5, 2.0)).unwrap();
    assert!(stats.superfaces >= 2, "{stats:?}");
    assert!(
        out.triangle_count() < grid.triangle_count() / 4,
        "{stats:?}"
    );
    assert!((area(&out) - 256.0).abs() < 1e-9 * 256.0, "{}", area(&out));
    assert_no_t_junctions(&out);
    // The shadow's edge: vertices at x = 5 and x = 6 (the ramp between them) are still there, at
    // both ends of the edge.
    for (x, y) in [(5.0, 0.0), (5.0, 16.0), (6.0, 0.0), (6.0, 16.0)] {
        assert!(
            out.positions.iter().any(|p| *p == Vec3::new(x, y, 0.0)),
            "({x}, {y}) is gone"
        );
    }
}

/// Colours are kept: every output vertex is an input vertex with its own colour.
#[test]
fn output_vertices_keep_their_colours() {
    let grid = lit_grid(10, |x, y| Vec3::new(x / 10.0, y / 10.0, 0.5));
    let (out, _) = simplify_superfaces(&grid, &options(0.3, 8.0)).unwrap();
    let colours = out.colors.as_ref().unwrap();
    for (p, c) in out.positions.iter().zip(colours) {
        assert_eq!(*c, Vec3::new(p.x / 10.0, p.y / 10.0, 0.5));
    }
    assert!((area(&out) - 100.0).abs() < 1e-9 * 100.0);
    assert_no_t_junctions(&out);
}

#[test]
fn bad_input_is_a_clear_error() {
    let grey = common::grid(2, 2, |_, _| 0.0);
    let e = simplify_superfaces(&grey, &options(0.1, 2.0)).unwrap_err();
    assert!(e.to_string().contains("no vertex colours"), "{e}");
    let lit = lit_grid(2, |_, _| Vec3::ONE);
    let e = simplify_superfaces(&lit, &options(-1.0, 2.0)).unwrap_err();
    assert!(e.to_string().contains("epsilon"), "{e}");
}

/// The same input gives the same output, run after run (no hash-map order leaks into the growth).
#[test]
fn runs_are_repeatable() {
    let grid = lit_grid(12, |x, y| {
        Vec3::new((x * 0.37).sin().abs(), (y * 0.21).cos().abs(), 0.4)
    });
    let (a, _) = simplify_superfaces(&grid, &options(0.3, 3.0)).unwrap();
    for _ in 0..5 {
        let (b, _) = simplify_superfaces(&grid, &options(0.3, 3.0)).unwrap();
        assert_eq!(a.triangles, b.triangles);
        assert_eq!(a.positions, b.positions);
    }
}

//! `simplify --method bounded`: its results are certified within ε of the input both ways, checked
//! by the independent certified meter, on hand-built meshes with known answers, random meshes and
//! the real models.

mod common;

use glam::Vec3;
use vunify::measure::{CertifyOptions, certified_hausdorff};
use vunify::mesh::{CleanOptions, Mesh, clean, load};
use vunify::simplify::DistanceError;
use vunify::simplify::bounded::{BoundedOptions, simplify_bounded};

/// The referee: tight enough to tell 0.999 ε from ε.
fn referee() -> CertifyOptions {
    CertifyOptions {
        relative: 2e-4,
        absolute: 1e-9,
        max_splits: 2_000_000,
        epsilon: None,
    }
}

fn bounded(mesh: &Mesh, epsilon: f64) -> Mesh {
    let options = BoundedOptions {
        epsilon,
        target_triangles: 0,
    };
    simplify_bounded(mesh, &options, &mut |_| {}).unwrap().0
}

/// Simplifies at ε and has the meter confirm both directions at most ε.
fn certified_within(mesh: &Mesh, epsilon: f64, what: &str) -> Mesh {
    let out = bounded(mesh, epsilon);
    let c = certified_hausdorff(mesh, &out, &referee()).unwrap();
    for (side, b) in [
        ("input → output", c.forward),
        ("output → input", c.backward),
    ] {
        assert!(
            b.upper <= epsilon,
            "{what} at ε = {epsilon}: {side} certified only below {} ({b:?})",
            b.upper
        );
    }
    out
}

/// A flat 20 × 20 grid (800 triangles) is its own two-triangle square, at any ε: its points are at
/// distance 0 from it, which the checks prove exactly by cutting each large triangle along the
/// prisms of the grid's triangles beneath it. Also with the grid's vertices in a shuffled order (a
/// different collapse order).
/// ```text
///   +--+--+-- … --+        +-------------+
///   |\ |\ |        |        |           / |
///   | \| \|   …    |   →    |     /       |
///   +--+--+-- … --+        +-------------+
/// ```
#[test]
fn a_flat_grid_collapses_to_two_triangles() {
    let grid = common::grid(20, 20, |_, _| 0.0);
    let shuffled = {
        // A fixed permutation of the vertices: i ↦ 173·i mod 441 (173 is prime to 441 = 21²).
        let n = grid.positions.len() as u32;
        let new = |v: u32| (v * 173) % n;
        let mut positions = grid.positions.clone();
        for (v, &p) in grid.positions.iter().enumerate() {
            positions[new(v as u32) as usize] = p;
        }
        let triangles = grid.triangles.iter().map(|t| t.map(new)).collect();
        Mesh::from_triangles(positions, triangles)
    };
    for epsilon in [0.001, 0.01, 0.2] {
        for (mesh, order) in [(&grid, "row order"), (&shuffled, "shuffled")] {
            let out = certified_within(mesh, epsilon, "flat grid");
            if std::env::var("DBG").is_ok() {
                let mut t = String::new();
                for tr in &out.triangles {
                    let c = tr.map(|v| out.positions[v as usize]);
                    t += &format!(
                        "{} {} {} {} {} {}\n",
                        c[0].x, c[0].y, c[1].x, c[1].y, c[2].x, c[2].y
                    );
                }
                std::fs::write("/tmp/b21/tri.txt", t).unwrap();
            }
            assert_eq!(out.triangle_count(), 2, "ε = {epsilon}, {order}");
        }
    }
}

/// A sheet bent at 90° along x = 10:
/// ```text
///   z
///   |      ________
///   |     /
///   |    /   (the crease at x = 10, the second half rising at 45° from each side: 90° between)
///   |___/
///   +------------- x
/// ```
/// At an ε far below the bend's size the crease stays: no output point leaves it by more than ε.
#[test]
fn a_sheet_bent_at_ninety_degrees_keeps_its_crease() {
    let sheet = common::grid(20, 8, |x, _| if x <= 10.0 { 0.0 } else { x - 10.0 });
    let out = certified_within(&sheet, 0.005, "bent sheet");
    // The crease's points are still on the output (certified above), and its two flat halves are
    // a few triangles each (12 or 13 of the 320, depending on the order in which the greedy
    // collapses happen to pass their checks).
    assert!(
        out.triangle_count() <= 14,
        "{} triangles",
        out.triangle_count()
    );
    let on_crease = out
        .positions
        .iter()
        .filter(|p| (p.x - 10.0).abs() < 1e-4 && p.z.abs() < 1e-4)
        .count();
    assert!(on_crease >= 2, "the crease has {on_crease} vertices");
}

/// A closed slab 0.01 thick (a box 10 × 10 × 0.01) at ε = 1 % of its diagonal (0.14): each face is
/// within ε of the opposite one, but the slab may not erode through — both directions hold, so it
/// stays a closed box (12 triangles at most).
#[test]
fn a_slab_thinner_than_epsilon_does_not_erode_through() {
    let cuboid = vunify::fixtures::cuboid(Vec3::new(10.0, 10.0, 0.01));
    // Subdivided so there is something to simplify: each face of the box split into a fan.
    let slab = common::subdivided(&cuboid, 3);
    let out = certified_within(&slab, 0.01, "slab");
    assert!(
        out.triangle_count() >= 4,
        "{} triangles",
        out.triangle_count()
    );
}

#[test]
fn a_single_triangle_and_a_tetrahedron() {
    let tri = Mesh::from_triangles(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
    assert_eq!(certified_within(&tri, 0.01, "triangle").triangle_count(), 1);
    let tetra = Mesh::from_triangles(
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
    );
    // Any collapse moves a corner by far more than 1 % of the diagonal.
    assert_eq!(
        certified_within(&tetra, 0.01, "tetrahedron").triangle_count(),
        4
    );
}

#[test]
fn random_meshes_stay_certified() {
    for seed in 0..10 {
        let mesh = common::random_scene(seed);
        for epsilon in [0.01, 0.05] {
            certified_within(&mesh, epsilon, &format!("random scene {seed}"));
        }
    }
}

#[test]
fn bad_input_is_a_clear_error() {
    let tri = Mesh::from_triangles(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
    for epsilon in [0.0, -0.1, 1.0, f64::NAN] {
        let options = BoundedOptions {
            epsilon,
            target_triangles: 0,
        };
        let e = simplify_bounded(&tri, &options, &mut |_| {}).unwrap_err();
        assert!(matches!(e, DistanceError::Epsilon(_)), "{e}");
    }
    let options = BoundedOptions {
        epsilon: 0.01,
        target_triangles: 0,
    };
    assert_eq!(
        simplify_bounded(&Mesh::default(), &options, &mut |_| {}).unwrap_err(),
        DistanceError::Empty
    );
}

/// The guarantee on the small real models, at ε = 0.5, 1, 2 and 3 % of the diagonal: every result
/// certified within ε both ways by the independent meter. (Fandisk, whose fillets make the checks
/// slow, takes most of this test's minute and a half.)
#[test]
fn the_guarantee_holds_on_the_small_real_models() {
    let Some(dir) = common::models_dir() else {
        return;
    };
    for (name, epsilons) in [
        ("cow.obj", &[0.005, 0.01, 0.02, 0.03][..]),
        ("beetle.obj", &[0.005, 0.01, 0.02, 0.03][..]),
        ("fandisk.obj", &[0.005, 0.01, 0.02, 0.03][..]),
        ("cessna.obj", &[0.005, 0.01, 0.02, 0.03][..]),
    ] {
        let (mesh, _) = load(&dir.join(name), &CleanOptions::default()).unwrap();
        let (mesh, _) = clean(mesh, &CleanOptions::default());
        for &epsilon in epsilons {
            let out = certified_within(&mesh, epsilon, name);
            eprintln!(
                "{name} at ε = {epsilon}: {} → {} triangles",
                mesh.triangle_count(),
                out.triangle_count()
            );
        }
    }
}

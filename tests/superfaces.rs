//! Liu and Wu's simplification of lit meshes (`vunify superfaces`): superfaces, boundary
//! chains and the bridged ear clipping, on hand-built lit meshes with known answers.

mod common;

use glam::Vec3;
use vunify::mesh::Mesh;
use vunify::radiosity::superfaces::{
    SuperfaceOptions, simplify_superfaces, simplify_superfaces_owned, superfaces,
};

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
        discs: false,
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

/// The Cornell box lit coarsely (a few seconds), as `vunify radiosity` writes it and reads it back.
fn lit_cornell() -> Mesh {
    use vunify::radiosity::{RadiosityOptions, Scene, solve};
    let dir = std::env::temp_dir().join(format!("vunify-superfaces-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = Scene::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes/cornell.obj"),
    )
    .unwrap();
    let options = RadiosityOptions {
        unshot: 0.02,
        element_size: 0.05,
        min_element_size: 0.01,
        ..Default::default()
    };
    let solution = solve(&scene, &options, &mut |_, _| {});
    let emitting: Vec<bool> = scene.polygons.iter().map(|p| scene.emits(p)).collect();
    let path = dir.join("cornell.ply");
    vunify::radiosity::output::write(&solution, &emitting, &path).unwrap();
    let mesh = vunify::mesh::load(&path, &Default::default()).unwrap().0;
    let _ = std::fs::remove_dir_all(&dir);
    mesh
}

/// On a real lit mesh (the Cornell box) at the paper's settings: every superface is planar (its
/// triangles' normals agree and its corners lie on one plane, within the merge's tolerances); the
/// output's area is the input's to 10⁻⁹ (it was 10 % more on the right wall before ear clipping took
/// exact orientations and cut slivers last); no T-junction and no triangle without area; some
/// superfaces have holes; and every vertex that left a superface's boundary lies on an output edge
/// whose ends' colours, interpolated to it, are within δ (0–255) of its own.
#[test]
fn the_lit_cornell_box_keeps_the_papers_promises() {
    let mesh = lit_cornell();
    let colours = mesh.colors.as_ref().unwrap();
    let diagonal = mesh.diagonal() as f64;
    for (epsilon, delta) in [(0.1, 2.0), (0.8, 50.0)] {
        assert_no_t_junctions(&mesh);
        let owner = superfaces(&mesh, epsilon).unwrap();
        let count = owner.iter().max().map_or(0, |&s| s as usize + 1);
        let normal = |t: [u32; 3]| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize].as_dvec3());
            (b - a).cross(c - a).normalize()
        };
        let mut first = vec![None; count];
        for (t, &s) in mesh.triangles.iter().zip(&owner) {
            let (n, p) = (normal(*t), mesh.positions[t[0] as usize].as_dvec3());
            let &mut (n0, p0) = first[s as usize].get_or_insert((n, p));
            assert!(n.dot(n0) > 1.0 - 1e-5, "superface {s} is not planar");
            for v in t {
                let off = (mesh.positions[*v as usize].as_dvec3() - p0).dot(n0).abs();
                assert!(
                    off <= 1e-5 * diagonal,
                    "superface {s}: a corner {off} off its plane"
                );
            }
        }

        let (out, stats, owner) =
            simplify_superfaces_owned(&mesh, &options(epsilon, delta)).unwrap();
        assert!(stats.triangles_out < stats.triangles_in, "{stats:?}");
        assert!(stats.color_error_max <= epsilon, "{stats:?}");
        // Superfaces close round others (the ceiling round the light's shadow edge, the floor
        // round the boxes' shadows), and their holes are bridged.
        assert!(stats.holes > 0, "{stats:?}");
        // Measured: 8e-14 and 1e-12 of it.
        assert!(
            (area(&out) - area(&mesh)).abs() <= 1e-9 * area(&mesh),
            "(ε, δ) = ({epsilon}, {delta}): area {} of {}",
            area(&out),
            area(&mesh)
        );
        assert_no_t_junctions(&out);
        // No output triangle without area: a straight corner cut as an ear (the last corners of a
        // straight run of a long ring on the tilted left wall) is flipped with its neighbour.
        let slivers: Vec<_> = out
            .triangles
            .iter()
            .filter(|t| {
                let [a, b, c] = t.map(|v| out.positions[v as usize].as_dvec3());
                let longest = (b - a)
                    .length_squared()
                    .max((c - b).length_squared())
                    .max((a - c).length_squared());
                (b - a).cross(c - a).length() <= 1e-6 * longest
            })
            .collect();
        assert!(
            slivers.is_empty(),
            "(ε, δ) = ({epsilon}, {delta}): triangles without area {slivers:?}"
        );

        // Boundary vertices: on a border edge or between two superfaces.
        let mut owners: Vec<Vec<u32>> = vec![Vec::new(); mesh.positions.len()];
        for (t, &s) in mesh.triangles.iter().zip(&owner) {
            for v in t {
                owners[*v as usize].push(s);
            }
        }
        let kept: std::collections::HashSet<[u32; 3]> = out
            .positions
            .iter()
            .map(|p| p.to_array().map(f32::to_bits))
            .collect();
        let out_colours = out.colors.as_ref().unwrap();
        let mut checked = 0;
        for (v, p) in mesh.positions.iter().enumerate() {
            let on_boundary = owners[v].iter().any(|&s| s != owners[v][0]);
            if !on_boundary || kept.contains(&p.to_array().map(f32::to_bits)) {
                continue;
            }
            // The output edge it lies on, and the colour interpolated there.
            let mut best = f32::INFINITY;
            for t in &out.triangles {
                for k in 0..3 {
                    let (i, j) = (t[k] as usize, t[(k + 1) % 3] as usize);
                    let (a, b) = (out.positions[i], out.positions[j]);
                    let s = (*p - a).dot(b - a) / (b - a).length_squared();
                    if !(0.0..=1.0).contains(&s)
                        || (*p - a - (b - a) * s).length() > 1e-5 * diagonal as f32
                    {
                        continue;
                    }
                    let c = out_colours[i].lerp(out_colours[j], s);
                    best = best.min((c - colours[v]).abs().max_element() * 255.0);
                }
            }
            assert!(
                best <= delta as f32 + 0.5,
                "(ε, δ) = ({epsilon}, {delta}): removed boundary vertex {v} at {p} (superfaces {:?}) is {best} from its edge's colour",
                owners[v]
            );
            checked += 1;
        }
        eprintln!(
            "(ε, δ) = ({epsilon}, {delta}): {count} superfaces, {stats:?}, {checked} removed boundary vertices checked"
        );
        assert!(checked > 0);
    }
}

/// The colour of `out` drawn at each vertex of the flat lit grid `lit` (z = 0), against the lit
/// colour: the largest relative error (largest channel), found by brute force — each lit vertex
/// located in the output triangle that holds it, colours interpolated there.
fn drawn_error(lit: &Mesh, out: &Mesh) -> f64 {
    let (lc, oc) = (lit.colors.as_ref().unwrap(), out.colors.as_ref().unwrap());
    let mut worst = 0.0f64;
    for (v, p) in lit.positions.iter().enumerate() {
        let mut best = f64::INFINITY;
        for t in &out.triangles {
            let [a, b, c] = t.map(|u| out.positions[u as usize].truncate().as_dvec2());
            let q = p.truncate().as_dvec2();
            let d = (b - a).perp_dot(c - a);
            let (wb, wc) = ((q - a).perp_dot(c - a) / d, (b - a).perp_dot(q - a) / d);
            let wa = 1.0 - wb - wc;
            if wa < -1e-9 || wb < -1e-9 || wc < -1e-9 {
                continue;
            }
            let at = t.map(|u| oc[u as usize].as_dvec3());
            let drawn = (at[0] * wa + at[1] * wb + at[2] * wc) * 255.0;
            let own = lc[v].as_dvec3() * 255.0;
            let e = ((drawn - own).abs() / own.max(glam::DVec3::ONE)).max_element();
            best = best.min(e);
        }
        worst = worst.max(best);
    }
    worst
}

/// A smooth light pool: a flat 60 × 60 grid, grey 60 in the corners rising smoothly to 220 in the
/// middle. The paper's test bounds only the change between neighbours, which is small everywhere, so
/// it made the whole grid one superface of 6 triangles (153 of 255 off in the middle). Each
/// superface now keeps every value on it within its window, so what is drawn stays within ε of the
/// lit colour, relative, at every vertex — checked here by brute force, and as reported.
#[test]
fn a_smooth_light_pool_stays_within_epsilon() {
    let lit = lit_grid(60, |x, y| {
        let r2 = (x - 29.5).powi(2) + (y - 29.5).powi(2);
        Vec3::splat((60.0 + 160.0 * (-r2 / 200.0).exp()) / 255.0)
    });
    for epsilon in [0.05, 0.1, 0.2] {
        let (out, stats) = simplify_superfaces(&lit, &options(epsilon, 2.0)).unwrap();
        let worst = drawn_error(&lit, &out);
        eprintln!("ε = {epsilon}: {stats:?}, drawn error {worst}");
        assert!(worst <= epsilon + 1e-6, "ε = {epsilon}: drawn {worst} off");
        assert!(
            (stats.color_error_max - worst).abs() <= 1e-6,
            "{stats:?} vs {worst}"
        );
        assert!(stats.triangles_out < stats.triangles_in, "{stats:?}");
    }
}

/// Every bundled scene, lit coarsely, keeps the superfaces' promise at the paper's settings: the
/// colour error against the lit mesh (on linear radiosity, which the lit PLY carries and the output
/// keeps) is at most ε; the output carries the radiosity beside the display colours.
#[test]
fn every_bundled_scene_stays_within_epsilon() {
    use vunify::radiosity::{RadiosityOptions, Scene, solve};
    let dir = std::env::temp_dir().join(format!("vunify-superfaces-all-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["cornell", "room", "office"] {
        let scene = Scene::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join(format!("assets/scenes/{name}.obj")),
        )
        .unwrap();
        let lighting = RadiosityOptions {
            unshot: 0.05,
            element_size: 0.05,
            min_element_size: 0.02,
            rounds: 1,
            ..Default::default()
        };
        let solution = solve(&scene, &lighting, &mut |_, _| {});
        let emitting: Vec<bool> = scene.polygons.iter().map(|p| scene.emits(p)).collect();
        let path = dir.join(format!("{name}.ply"));
        vunify::radiosity::output::write(&solution, &emitting, &path).unwrap();
        let mesh = vunify::mesh::load(&path, &Default::default()).unwrap().0;
        assert!(
            mesh.radiosity.is_some(),
            "{name}: the lit PLY's radiosity is read"
        );
        for (epsilon, delta) in [(0.06, 1.0), (0.1, 2.0), (0.8, 50.0)] {
            let (out, stats) = simplify_superfaces(&mesh, &options(epsilon, delta)).unwrap();
            eprintln!("{name} (ε, δ) = ({epsilon}, {delta}): {stats:?}");
            assert!(stats.color_error_max <= epsilon, "{name}: {stats:?}");
            assert!(out.radiosity.is_some());
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

//! The certified Hausdorff meter against the sampled one, on random and real meshes: every sampled
//! distance is a distance at a real point, so it can never exceed the certified upper bound, and
//! with dense sampling it comes close to the certified lower bound.

mod common;

use vunify::measure::{CertifyOptions, certified_hausdorff, hausdorff};
use vunify::mesh::{CleanOptions, Mesh, load};
use vunify::vtree::{self, BuildOptions};

/// The tree's cut at `share` of the triangles, against the mesh, both ways. With `converge`, the
/// bounds must also meet the default tolerance within the default split budget (along sharp creases,
/// such as fandisk's, they close slowly: the budget ends the search with bounds that still hold).
fn compare(mesh: &Mesh, share: f64, what: &str, converge: bool) {
    let (tree, _) = vtree::build(mesh, &BuildOptions::default(), &mut |_, _| {}).unwrap();
    let n = (mesh.triangle_count() as f64 * share).round().max(2.0) as u32;
    let cut = vtree::cut_at_triangles(&tree, n).mesh;
    if cut.triangles.is_empty() {
        return;
    }
    let c = certified_hausdorff(mesh, &cut, &CertifyOptions::default()).unwrap();
    let h = hausdorff(mesh, &cut, 100_000);
    for (bounds, sampled, side) in [
        (c.forward, h.forward.max, "forward"),
        (c.backward, h.backward.max, "backward"),
    ] {
        assert!(bounds.converged || !converge, "{what} {side}: {bounds:?}");
        assert!(bounds.lower <= bounds.upper, "{what} {side}: {bounds:?}");
        assert!(
            // (The sampled meter works in f32: 1e-7 of the diagonal is its rounding.)
            sampled <= bounds.upper * (1.0 + 1e-6) + 1e-6,
            "{what} {side}: sampled {sampled} above the certified upper bound {bounds:?}"
        );
        // Sampling finds at least nearly the maximum (within a tenth, or a speck of the diagonal).
        assert!(
            sampled >= 0.9 * bounds.lower - 1e-4,
            "{what} {side}: sampled {sampled} far below the certified lower bound {bounds:?}"
        );
    }
}

#[test]
fn certified_bounds_hold_the_sampled_distances_of_random_meshes() {
    for seed in 0..12 {
        let mesh = common::random_scene(seed);
        compare(&mesh, 0.2, &format!("random scene {seed}"), true);
    }
    compare(
        &common::grid(20, 14, |x, y| (x * 0.4).sin() * (y * 0.3).cos() * 2.0),
        0.1,
        "wavy grid",
        true,
    );
}

#[test]
fn certified_bounds_agree_with_sampling_on_real_models() {
    let Some(dir) = common::models_dir() else {
        return;
    };
    for name in [
        "cow.obj",
        "fandisk.obj",
        "cessna.obj",
        "beetle.obj",
        "stanford-bunny.obj",
    ] {
        let (mesh, _) = load(&dir.join(name), &CleanOptions::default()).unwrap();
        for share in [0.1, 0.01] {
            compare(
                &mesh,
                share,
                &format!("{name} at {share}"),
                name != "fandisk.obj",
            );
        }
    }
}

//! The vertex-tree builder: exact results on hand-built meshes, invariants on random and real ones.

mod common;

use common::*;
use glam::Vec3;
use proptest::prelude::*;
use vunify::mesh::{CleanOptions, Mesh};
use vunify::simplify::Metric;
use vunify::vtree::{self, BuildOptions, Schedule, VertexTree};

fn build(mesh: &Mesh, metric: Metric) -> VertexTree {
    build_with(mesh, metric, Schedule::Passes)
}

fn build_with(mesh: &Mesh, metric: Metric, schedule: Schedule) -> VertexTree {
    let options = BuildOptions {
        metric,
        schedule,
        ..Default::default()
    };
    vtree::build(mesh, &options, &mut |_, _| {})
        .expect("build")
        .0
}

fn sorted_keys(tris: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut v: Vec<[u32; 3]> = tris
        .iter()
        .map(|t| {
            let mut k = *t;
            k.sort_unstable();
            k
        })
        .collect();
    v.sort_unstable();
    v
}

/// The deviation bound holds on fronts at three levels: every input vertex lies within the bound of
/// the front node standing for it, and every point of every input triangle (three barycentric
/// samples each) within the front's level of where the front draws it — the argument of
/// [`VertexTree::deviation_bounds`], checked point by point. The bounds never decrease upwards.
fn assert_deviation_bound(mesh: &Mesh, tree: &VertexTree) {
    let bound = tree.deviation_bounds();
    for (u, node) in tree.nodes.iter().enumerate().skip(tree.leaf_count as usize) {
        for c in node.children {
            assert!(
                bound[u] >= bound[c as usize],
                "bound of {u} below its child {c}'s"
            );
        }
    }
    let root = bound[tree.root() as usize];
    for level in [0.05 * root, 0.3 * root, root] {
        let cut = vtree::cut_at_bound(tree, level);
        let mut on_front = vec![false; tree.nodes.len()];
        for &u in &cut.nodes {
            assert!(bound[u as usize] <= level);
            on_front[u as usize] = true;
        }
        // g(v): the front node above each leaf.
        let g: Vec<u32> = (0..tree.leaf_count)
            .map(|v| {
                let mut u = v;
                while !on_front[u as usize] {
                    u = tree.nodes[u as usize].parent;
                }
                u
            })
            .collect();
        let drawn = |v: u32| tree.nodes[g[v as usize] as usize].position();
        let slack = 1e-4 * level + 1e-6 * mesh.diagonal();
        for (v, &p) in mesh.positions.iter().enumerate() {
            let d = p.distance(drawn(v as u32));
            assert!(
                d <= bound[g[v] as usize] + slack,
                "vertex {v}: {d} > its node's bound"
            );
        }
        for t in &mesh.triangles {
            for beta in [[1.0 / 3.0; 3], [0.6, 0.3, 0.1], [0.05, 0.15, 0.8]] {
                let (mut p, mut q) = (Vec3::ZERO, Vec3::ZERO);
                for k in 0..3 {
                    p += beta[k] * mesh.positions[t[k] as usize];
                    q += beta[k] * drawn(t[k]);
                }
                assert!(
                    p.distance(q) <= level + slack,
                    "{t:?} {beta:?}: {} > {level}",
                    p.distance(q)
                );
            }
        }
    }
}

/// Every invariant the issue names, on one tree built from `mesh`.
fn assert_tree_invariants(mesh: &Mesh, tree: &VertexTree) {
    assert_deviation_bound(mesh, tree);
    // One binary tree, one root; errors monotone; spheres nested; links consistent.
    vtree::check(tree).unwrap();
    // Collapsing it reaches the one root, and every cut in build order is a mesh without degenerate or
    // duplicate triangles.
    vtree::check_cut(tree).unwrap();
    assert_eq!(tree.nodes.len(), 2 * mesh.vertex_count() - 1);
    assert_eq!(tree.nodes[tree.root() as usize].parent, vtree::NONE);
    // Splitting the whole tree gives back the input triangle set exactly (orientation included).
    let full = vtree::cut_at_merges(tree, 0);
    assert_eq!(full.mesh.positions, mesh.positions);
    let mut a = full.mesh.triangles.clone();
    let mut b = mesh.triangles.clone();
    a.sort_unstable();
    b.sort_unstable();
    assert_eq!(a, b);
    assert_eq!(sorted_keys(&tree.triangles), sorted_keys(&mesh.triangles));
    // Bounding spheres contain every vertex of their subtree.
    for (u, node) in tree.nodes.iter().enumerate() {
        let mut stack = vec![u as u32];
        let c = Vec3::from_slice(&node.sphere);
        while let Some(v) = stack.pop() {
            let n = &tree.nodes[v as usize];
            assert!(
                c.distance(n.position()) <= node.sphere[3] * (1.0 + 1e-5) + 1e-5,
                "node {v} outside the sphere of {u}"
            );
            if !n.is_leaf() {
                stack.extend(n.children);
            }
        }
    }
    // The root's cut is one vertex and no triangle.
    let root = vtree::cut_at_merges(tree, tree.internal_count());
    assert_eq!(
        (root.mesh.vertex_count(), root.mesh.triangle_count()),
        (1, 0)
    );
}

/// Tao et al.'s Fig. 2: a tetrahedron beside a separate triangle (see `collapse.rs` for the single merge).
/// ```text
///        3                  6
///       /|\                / \
///      0-|-2              4---5
///       \|/
///        1
/// ```
/// The whole build joins the two parts (one root), and every cut is valid.
#[test]
fn fig2_tetrahedron_and_triangle_build_to_one_root() {
    let mesh = fig2();
    for metric in [
        Metric::Qem,
        Metric::QemMidpoint,
        Metric::EdgeLength,
        Metric::Hybrid,
    ] {
        for schedule in [Schedule::Passes, Schedule::Greedy] {
            let tree = build_with(&mesh, metric, schedule);
            assert_tree_invariants(&mesh, &tree);
            assert_eq!(tree.nodes.len(), 13);
            // Five triangles in all vanish along the way; the tetrahedron's 4 before the parts are joined.
            assert_eq!(tree.triangles.len(), 5);
        }
    }
}

/// A flat strip of two squares:
/// ```text
///   3 --- 4 --- 5
///   |   / |   / |
///   | /   | /   |
///   0 --- 1 --- 2
/// ```
/// 0, 2, 3, 5 are corners. 1 and 4 sit on straight boundaries: merging either into a neighbouring
/// corner along the boundary moves no surface (the face plane z = 0 and the boundary planes y = 0 or
/// y = 1 all still hold), so the first merge is one of those four, costs exactly zero, puts the merged
/// vertex exactly on the corner, and removes exactly one triangle. Any other merge costs more.
#[test]
fn strip_first_merge_is_a_free_boundary_slide() {
    let mesh = grid(2, 1, |_, _| 0.0);
    for schedule in [Schedule::Passes, Schedule::Greedy] {
        let tree = build_with(&mesh, Metric::Qem, schedule);
        assert_tree_invariants(&mesh, &tree);
        assert_eq!((tree.leaf_count, tree.internal_count()), (6, 5));
        let first = &tree.nodes[6];
        let mut kids = first.children;
        kids.sort_unstable();
        assert!([[0, 1], [1, 2], [3, 4], [4, 5]].contains(&kids), "{kids:?}");
        assert_eq!(first.error, 0.0);
        let corner = if kids.contains(&1) {
            kids[0] + kids[1] - 1
        } else {
            kids[0] + kids[1] - 4
        };
        assert_eq!(first.position(), mesh.positions[corner as usize]);
        assert_eq!(tree.vanishing(6).len(), 1);
        // All four triangles are gone by the root, and errors only grow.
        assert_eq!(tree.triangles.len(), 4);
    }
}

/// Two separate triangles far apart, nothing to pair at the default radius: the queue runs dry with two
/// roots, the radius widens, and they are joined into one tree anyway.
#[test]
fn separate_parts_are_joined_by_widening() {
    let a = Mesh::from_triangles(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
    let mesh = scene(&[a.clone(), a], 100.0);
    let (tree, stats) = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {}).unwrap();
    assert_tree_invariants(&mesh, &tree);
    assert!(stats.widenings >= 1);
    assert_eq!(tree.parts.len(), 2);
    // The last merge joins the parts: it removes no triangle, and its error is at least half the gap.
    let last = tree.root();
    assert!(tree.vanishing(last).is_empty());
    assert!(tree.nodes[last as usize].error >= 49.0);
}

/// The tree does not depend on how many threads build it, nor on their timing: a 160 × 160 grid (its
/// first passes hand their nodes to the finishing thread, which the merging thread helps when it falls
/// behind) gives the same nodes, vanishing sets and errors, bit for bit, with one pricing thread and
/// with four.
/// `f` run on a pool of `threads` threads.
fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn builds_are_identical_on_any_number_of_threads() {
    let mesh = grid(160, 160, |x, y| {
        (x * 0.11).sin() * (y * 0.07).cos() * 3.0 + 0.01 * x * y
    });
    assert_same_on_one_and_four_threads(&mesh, || build(&mesh, Metric::Qem));
}

/// `build` on one thread and on four gives the same valid tree, bit for bit.
fn assert_same_on_one_and_four_threads(mesh: &Mesh, build: impl Fn() -> VertexTree + Sync) {
    let (one, four) = (on_threads(1, &build), on_threads(4, &build));
    assert_tree_invariants(mesh, &one);
    assert_eq!(one.nodes, four.nodes);
    assert_eq!(one.triangles, four.triangles);
    assert_eq!(one.vanish_offsets, four.vanish_offsets);
}

#[test]
fn colours_are_carried_to_merged_vertices() {
    let mut mesh = grid(3, 3, |_, _| 0.0);
    mesh.colors = Some(
        mesh.positions
            .iter()
            .map(|p| Vec3::new(p.x / 3.0, p.y / 3.0, 0.5))
            .collect(),
    );
    let tree = build(&mesh, Metric::Qem);
    assert!(tree.has_colors);
    for node in &tree.nodes {
        let c = Vec3::from_array(node.color);
        assert!(c.min_element() >= -1e-6 && c.max_element() <= 1.0 + 1e-6);
        assert!(
            (c.z - 0.5).abs() < 1e-5,
            "a constant channel stays constant: {c}"
        );
    }
    // Every node's colour is the ramp's at its own position (the colour quadrics' best colour).
    for node in &tree.nodes {
        let (p, c) = (
            Vec3::from_array(node.position),
            Vec3::from_array(node.color),
        );
        assert!(
            (c.x - p.x / 3.0).abs() < 1e-5 && (c.y - p.y / 3.0).abs() < 1e-5,
            "{c} at {p}"
        );
    }
}

/// A colour far out of range (a float PLY may hold 1e30) is read as its nearest in [0, 1], in the
/// leaves as in the merges: a flat 4 × 4 grid, white but for one vertex at (1e30, -1e30, 0.5),
/// builds a tree whose every colour is in range and whose root error stays within the grid's size
/// and one full colour difference (read raw, the colour term alone would be 1e30 times that).
#[test]
fn colours_out_of_range_are_read_as_their_nearest() {
    let mut mesh = grid(4, 4, |_, _| 0.0);
    let mut colors = vec![Vec3::ONE; mesh.positions.len()];
    colors[6] = Vec3::new(1e30, -1e30, 0.5);
    mesh.colors = Some(colors);
    let weight = BuildOptions::default().color_weight;
    let tree = build(&mesh, Metric::Qem);
    assert_colour_bound(&mesh, &tree, weight);
    assert_eq!(tree.nodes[6].color, [1.0, 0.0, 0.5]);
    let root = tree.nodes.last().unwrap();
    assert!(
        root.error.is_finite() && root.error <= mesh.diagonal() * (1.0 + weight),
        "root error {}",
        root.error
    );
}

#[test]
fn extract_hits_its_targets() {
    let mesh = grid(10, 10, |x, y| (x * 0.5).sin() + (y * 0.3).cos());
    let tree = build(&mesh, Metric::Qem);
    for target in [0, 1, 7, 50, 100, 199, 200, 1000] {
        let cut = vtree::cut_at_triangles(&tree, target);
        assert!(cut.mesh.triangle_count() as u32 <= target, "{target}");
        assert_eq!(cut.dropped, 0, "build-order cuts never need cleaning");
        cut.mesh.check().unwrap();
    }
    assert_eq!(
        vtree::cut_at_triangles(&tree, 200).mesh.triangle_count(),
        200
    );
    // Error cuts: zero error keeps the flat-free input, a huge error gives the root.
    assert_eq!(vtree::cut_at_error(&tree, f32::MAX).mesh.vertex_count(), 1);
    let fine = vtree::cut_at_error(&tree, 0.0);
    assert!(fine.mesh.triangle_count() <= 200);
    let mid = vtree::cut_at_error(&tree, 0.05);
    for &u in &mid.nodes {
        assert!(tree.nodes[u as usize].error <= 0.05);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Random scenes of bumpy grids: all invariants, every metric.
    #[test]
    fn random_scenes_keep_every_invariant(seed in any::<u64>(), metric in 0u32..4, greedy in any::<bool>()) {
        let mesh = random_scene(seed);
        let schedule = if greedy { Schedule::Greedy } else { Schedule::Passes };
        let tree = build_with(&mesh, Metric::from_code(metric).unwrap(), schedule);
        assert_tree_invariants(&mesh, &tree);
    }

    /// Random scenes and soups with random colours: all invariants, and every colour bound.
    #[test]
    fn random_coloured_meshes_keep_every_invariant(seed in any::<u64>(), soup in any::<bool>(), greedy in any::<bool>()) {
        let mut mesh = if soup { random_soup(seed, 30, 80) } else { random_scene(seed) };
        prop_assume!(!mesh.triangles.is_empty());
        random_colours(&mut mesh, seed);
        let schedule = if greedy { Schedule::Greedy } else { Schedule::Passes };
        let tree = build_with(&mesh, Metric::Qem, schedule);
        assert_tree_invariants(&mesh, &tree);
        assert_colour_bound(&mesh, &tree, BuildOptions::default().color_weight);
    }

    /// Random soups: non-manifold edges, fans, isolated triangles, coincident merges everywhere.
    #[test]
    fn random_soups_keep_every_invariant(seed in any::<u64>(), vertices in 3u32..40, triangles in 1u32..120, metric in 0u32..4, greedy in any::<bool>()) {
        let mesh = random_soup(seed, vertices, triangles);
        prop_assume!(!mesh.triangles.is_empty());
        let schedule = if greedy { Schedule::Greedy } else { Schedule::Passes };
        let tree = build_with(&mesh, Metric::from_code(metric).unwrap(), schedule);
        assert_tree_invariants(&mesh, &tree);
    }
}

/// The real models in `$VUNIFY_MODELS` all build to one root and pass every check.
#[test]
fn real_models_build_to_one_root() {
    let Some(dir) = models_dir() else { return };
    for name in MODELS {
        let (mesh, _) = vunify::mesh::load(&dir.join(name), &CleanOptions::default())
            .unwrap_or_else(|e| panic!("{e}"));
        let (tree, stats) = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {}).unwrap();
        eprintln!(
            "{name}: {} leaves, depth {}, {} widenings",
            stats.leaves, stats.depth, stats.widenings
        );
        assert_tree_invariants(&mesh, &tree);
        let bytes = vtree::to_bytes(&tree);
        assert_eq!(
            vtree::read_bytes(&bytes, std::path::Path::new(name)).unwrap(),
            tree
        );
    }
}

/// Every node's colour, the leaves' too, lies in [0, 1], and each inner node's error covers how far that colour strays from each
/// leaf's below it (`weight · diagonal · largest channel difference`). Returns each node's leaves.
fn assert_colour_bound(mesh: &Mesh, tree: &VertexTree, color_weight: f32) -> Vec<Vec<usize>> {
    let scale = color_weight * mesh.diagonal();
    let n = tree.leaf_count as usize;
    for (u, node) in tree.nodes.iter().enumerate() {
        let c = Vec3::from_array(node.color);
        assert!(
            c.min_element() >= 0.0 && c.max_element() <= 1.0,
            "node {u}: colour {c}"
        );
    }
    // Each node's leaves, bottom-up (children come before parents).
    let mut leaves: Vec<Vec<usize>> = (0..tree.nodes.len())
        .map(|u| if u < n { vec![u] } else { Vec::new() })
        .collect();
    for u in n..tree.nodes.len() {
        let [a, b] = tree.nodes[u].children;
        let joined = [leaves[a as usize].clone(), leaves[b as usize].clone()].concat();
        let c = Vec3::from_array(tree.nodes[u].color);
        let worst = joined
            .iter()
            .map(|&l| {
                (Vec3::from_array(tree.nodes[l].color) - c)
                    .abs()
                    .max_element()
            })
            .fold(0.0f32, f32::max);
        assert!(
            tree.nodes[u].error >= scale * worst * (1.0 - 1e-5),
            "node {u}: error {} below its colour deviation {}",
            tree.nodes[u].error,
            scale * worst
        );
        leaves[u] = joined;
    }
    leaves
}

/// Random colours over a mesh's vertices, some beyond [0, 1] (a float PLY may hold any finite
/// value; the builder keeps them as their nearest in range).
fn random_colours(mesh: &mut Mesh, seed: u64) {
    let mut state = seed | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32 * 1.4 - 0.2
    };
    mesh.colors = Some(
        (0..mesh.positions.len())
            .map(|_| Vec3::new(next(), next(), next()))
            .collect(),
    );
}

/// Colours through the threaded finisher (passes of over a thousand merges, so more than
/// `TAIL_LIVE` vertices): random colours on a 160 × 160 bumpy grid build the same tree on one
/// thread and on four, with every colour bound.
#[test]
fn coloured_builds_are_identical_on_any_number_of_threads() {
    let mut mesh = grid(160, 160, |x, y| (x * 0.11).sin() * (y * 0.07).cos() * 3.0);
    random_colours(&mut mesh, 7);
    let on = |threads: usize| on_threads(threads, || build(&mesh, Metric::Qem));
    let (one, four) = (on(1), on(4));
    assert_tree_invariants(&mesh, &one);
    assert_colour_bound(&mesh, &one, BuildOptions::default().color_weight);
    assert_eq!(one.nodes, four.nodes);
    assert_eq!(one.triangles, four.triangles);
}

/// Colour in the error (lit meshes): a flat 8 × 8 grid, black where x < 4 and white from x = 4 on,
///
/// ```text
///   y ┌───────┬───────┐
///     │ black │ white │   flat: inside the square every merge is free in shape
///     └───────┴───────┘ x
///     0       4       8
/// ```
///
/// With the default colour weight, each node's error covers the colour of every leaf below it
/// (`weight · diagonal · largest channel difference`), so the runtime refines wherever the colours
/// it would blend differ; and the halves merge within themselves before across the edge (the colour
/// quadric in the price), where from shape alone many merges cross it.
#[test]
fn colour_counts_in_the_error() {
    let mut mesh = grid(8, 8, |_, _| 0.0);
    mesh.colors = Some(
        mesh.positions
            .iter()
            .map(|p| if p.x < 4.0 { Vec3::ZERO } else { Vec3::ONE })
            .collect(),
    );
    // Merges that join black and white leaves; checks each node's error against its leaves' colours.
    let crossings = |color_weight: f32| {
        let options = BuildOptions {
            color_weight,
            ..Default::default()
        };
        let tree = vtree::build(&mesh, &options, &mut |_, _| {}).unwrap().0;
        let leaves = assert_colour_bound(&mesh, &tree, color_weight);
        (tree.leaf_count as usize..tree.nodes.len())
            .filter(|&u| {
                let black = leaves[u]
                    .iter()
                    .filter(|&&l| tree.nodes[l].color[0] == 0.0)
                    .count();
                black > 0 && black < leaves[u].len()
            })
            .count()
    };
    let (with, without) = (
        crossings(BuildOptions::default().color_weight),
        crossings(0.0),
    );
    // 81 leaves, 80 merges: with colour only the last few, near the root, join black and white.
    assert!(
        with <= 8 && without > 2 * with,
        "{with} merges across the colour edge, {without} from shape alone"
    );
}

/// A shading ramp: a flat 8 × 8 grid whose red runs linearly from 0 at x = 0 to 1 at x = 8 (green
/// and blue likewise along y, and constant):
///
/// ```text
///   y ┌───────────────┐
///     │ ░░▒▒▓▓██ red →│   flat, and every channel linear over the whole square
///     └───────────────┘ x
///     0               8
/// ```
///
/// One linear function spans every triangle, so the colour quadrics price no merge for colour and
/// the order is shape's alone (the same tree as with `--color-weight 0`, colours aside), and every
/// node, wherever it is placed, is drawn in the ramp's colour at its own position.
#[test]
fn a_colour_ramp_merges_for_free_and_keeps_its_colours() {
    let mut mesh = grid(8, 8, |_, _| 0.0);
    let ramp = |p: Vec3| Vec3::new(p.x / 8.0, 1.0 - p.y / 8.0, 0.25);
    mesh.colors = Some(mesh.positions.iter().map(|&p| ramp(p)).collect());
    let build = |color_weight| {
        let options = BuildOptions {
            color_weight,
            ..Default::default()
        };
        vtree::build(&mesh, &options, &mut |_, _| {}).unwrap().0
    };
    let (with, without) = (build(BuildOptions::default().color_weight), build(0.0));
    let children = |t: &VertexTree| t.nodes.iter().map(|n| n.children).collect::<Vec<_>>();
    assert_eq!(
        children(&with),
        children(&without),
        "colour changed the order"
    );
    for (u, node) in with.nodes.iter().enumerate() {
        let want = ramp(Vec3::from_array(node.position));
        let got = Vec3::from_array(node.color);
        assert!(
            (got - want).abs().max_element() < 1e-5,
            "node {u} at {:?}: colour {got}, the ramp has {want}",
            node.position
        );
    }
}

/// Texture coordinates in the merge order: on a flat, one-coloured 8 × 8 grid, coordinates that
/// are a linear map of the grid cost nothing (the same order as shape alone), while a map
/// squeezed towards one side (u = (x/8)², the texture sliding over the surface wherever a merge
/// averages it) changes the order; `color_weight` 0 turns appearance off altogether.
///
/// ```text
///   u: linear  0 ─────────── 1        squeezed  0 ── ─ ─ ─ ─ ── 1  (texels crowd to the left)
/// ```
#[test]
fn texture_coordinates_price_merges_by_their_slide() {
    let with_uvs = |uv: &dyn Fn(Vec3) -> glam::Vec2| {
        let mut mesh = grid(8, 8, |_, _| 0.0);
        mesh.colors = Some(vec![Vec3::ONE; mesh.positions.len()]);
        mesh.uvs = Some(mesh.positions.iter().map(|&p| uv(p)).collect());
        mesh.texture_of = Some(vec![0; mesh.positions.len()]);
        mesh.textures = vec![std::sync::Arc::new(Vec::new())];
        mesh
    };
    let build = |mesh: &vunify::mesh::Mesh, color_weight| {
        let options = BuildOptions {
            color_weight,
            ..Default::default()
        };
        vtree::build(mesh, &options, &mut |_, _| {}).unwrap().0
    };
    let children = |t: &VertexTree| t.nodes.iter().map(|n| n.children).collect::<Vec<_>>();
    let shape_alone = children(&build(&grid(8, 8, |_, _| 0.0), 0.0));
    let linear = with_uvs(&|p| glam::Vec2::new(p.x / 8.0, p.y / 8.0));
    let squeezed = with_uvs(&|p| glam::Vec2::new((p.x / 8.0).powi(2), p.y / 8.0));
    let weight = BuildOptions::default().color_weight;
    assert_eq!(
        children(&build(&linear, weight)),
        shape_alone,
        "a linear map is free"
    );
    assert_ne!(
        children(&build(&squeezed, weight)),
        shape_alone,
        "a squeezed map is priced"
    );
    assert_eq!(
        children(&build(&squeezed, 0.0)),
        shape_alone,
        "weight 0: shape alone"
    );
}

/// A node's texture coordinates are where it stands on the chart, as its colour is the colour
/// there: on the 8 × 8 grid mapped linearly (u = x/8, v = y/8), every node, wherever its merge
/// put it (often at one end, where the mean of its leaves' coordinates is not), has the map's
/// coordinates at its own position, so a coarse level draws the texture where the input has it.
#[test]
fn nodes_take_the_texture_coordinates_of_their_place() {
    let mut mesh = grid(8, 8, |_, _| 0.0);
    mesh.colors = Some(vec![Vec3::ONE; mesh.positions.len()]);
    let map = |p: Vec3| glam::Vec2::new(p.x / 8.0, p.y / 8.0);
    mesh.uvs = Some(mesh.positions.iter().map(|&p| map(p)).collect());
    mesh.texture_of = Some(vec![0; mesh.positions.len()]);
    mesh.textures = vec![std::sync::Arc::new(Vec::new())];
    let tree = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {})
        .unwrap()
        .0;
    let appearance = tree.appearance.as_ref().unwrap();
    for (u, node) in tree.nodes.iter().enumerate() {
        let want = map(Vec3::from_array(node.position));
        let got = glam::Vec2::from_array(appearance.uvs[u]);
        assert!(
            got.distance(want) < 1e-4,
            "node {u} at {:?}: coordinates {got}, the map has {want}",
            node.position
        );
    }
}

/// `vtree::build_partitioned` with no progress report, its levels' nodes waiting in a fresh
/// folder, which is empty again afterwards.
fn build_in_cells(mesh: &Mesh, cell_triangles: usize) -> (VertexTree, vtree::BuildStats) {
    let spill = tempfile::tempdir().unwrap();
    let built = vtree::build_partitioned(
        mesh,
        &BuildOptions::default(),
        cell_triangles,
        spill.path(),
        &mut |_, _| {},
    )
    .unwrap();
    let left: Vec<_> = std::fs::read_dir(spill.path()).unwrap().collect();
    assert!(left.is_empty(), "the build left {left:?} behind");
    built
}

/// A partitioned build whose temporary folder cannot be made fails with the folder's name, not a
/// panic.
#[test]
fn partitioned_build_without_room_for_its_levels_says_where() {
    let mesh = grid(64, 8, |_, _| 0.0);
    let missing = std::env::temp_dir().join("vunify-no-such-folder/inside");
    let Err(err) = vtree::build_partitioned(
        &mesh,
        &BuildOptions::default(),
        512,
        &missing,
        &mut |_, _| {},
    ) else {
        panic!("built with no folder to spill into");
    };
    let message = err.to_string();
    assert!(
        message.contains("vunify-no-such-folder") && message.contains("temporary"),
        "{message}"
    );
}

/// A 64 × 8 grid in cells of at most 512 triangles: the kd-tree splits its 1024 triangles at their
/// median centroid, the column x = 32, whose 9 vertices have triangles in both cells.
/// ```text
///   y = 8  +-------------+-------------+
///          |   cell 0    |   cell 1    |
///   y = 0  +-------------+-------------+
///        x = 0        x = 32        x = 64
/// ```
/// Each cell builds to half of its 288 free vertices with the column locked, so the first
/// 2 × 144 merges neither move a column vertex nor join the two sides; the root's level, numbered
/// after them, does. (The whole build, with nothing locked, merges across the column much sooner.)
#[test]
fn cells_lock_their_border_until_the_level_that_joins_them() {
    let mesh = grid(64, 8, |x, y| {
        0.3 * (x * 0.9).sin() * (y * 1.3).cos() + 0.01 * x
    });
    let (tree, stats) = build_in_cells(&mesh, 512);
    assert_eq!((stats.cells, stats.levels), (2, 2));
    assert_tree_invariants(&mesh, &tree);
    // The sides each node's leaves lie on: 1 left of the column, 2 right of it, 4 on it.
    let first_across = |tree: &VertexTree| {
        let mut sides = vec![0u8; tree.nodes.len()];
        for v in 0..tree.leaf_count {
            sides[v as usize] = match (v % 65).cmp(&32) {
                std::cmp::Ordering::Less => 1,
                std::cmp::Ordering::Greater => 2,
                std::cmp::Ordering::Equal => 4,
            };
        }
        (tree.leaf_count as usize..tree.nodes.len())
            .find(|&u| {
                let [a, b] = tree.nodes[u].children;
                sides[u] = sides[a as usize] | sides[b as usize];
                sides[u] != 1 && sides[u] != 2
            })
            .unwrap()
            - tree.leaf_count as usize
    };
    assert!(
        first_across(&tree) >= 288,
        "merge {} crosses the border",
        first_across(&tree)
    );
    assert!(first_across(&build(&mesh, Metric::Qem)) < 288);
}

/// Random scenes (separate bumpy grids, so the root level joins parts no cell holds together)
/// and random soups (non-manifold, repeated edges) in cells of 1 to 7 triangles, many levels: one
/// root, every cut valid, the deviation bound, the input back at the leaves.
#[test]
fn cells_build_one_valid_tree_on_random_meshes() {
    for seed in 0..48u64 {
        let cell = 1 + (seed % 7) as usize;
        let mesh = random_scene(seed);
        let (tree, stats) = build_in_cells(&mesh, cell);
        if mesh.triangle_count() > cell {
            assert!(stats.cells >= 2, "seed {seed}");
        }
        assert_tree_invariants(&mesh, &tree);
        let soup = random_soup(seed, 24, 40);
        if soup.triangle_count() > 0 {
            let (tree, _) = build_in_cells(&soup, cell);
            assert_tree_invariants(&soup, &tree);
        }
    }
}

/// Cells far apart (a gap no close pair spans) still end in one root: the root level widens.
#[test]
fn cells_of_separate_parts_join_at_the_root() {
    let part = grid(12, 12, |x, y| (x * 0.5).sin() * (y * 0.4).cos());
    let mesh = scene(&[part.clone(), part.clone(), part], 100.0);
    let (tree, stats) = build_in_cells(&mesh, 100);
    assert!(
        stats.cells >= 6 && stats.levels >= 3,
        "{} cells",
        stats.cells
    );
    assert!(stats.widenings >= 1);
    assert_tree_invariants(&mesh, &tree);
    assert_eq!(tree.parts.len(), 3);
}

/// The cells build at once, yet the tree is the same bit for bit on one thread and on four.
#[test]
fn cell_builds_are_identical_on_any_number_of_threads() {
    let mesh = grid(120, 120, |x, y| {
        (x * 0.11).sin() * (y * 0.07).cos() * 3.0 + 0.01 * x * y
    });
    assert_same_on_one_and_four_threads(&mesh, || build_in_cells(&mesh, 2000).0);
}

/// A mesh that fits in one cell is built whole: the same tree as `vtree::build`.
#[test]
fn a_mesh_within_one_cell_is_built_whole() {
    let mesh = grid(10, 10, |x, y| (x * 0.5).sin() * y * 0.1);
    let (cells, stats) = build_in_cells(&mesh, 200);
    assert_eq!(stats.cells, 0);
    assert_eq!(cells.nodes, build(&mesh, Metric::Qem).nodes);
}

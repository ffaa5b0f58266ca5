//! The huge-model generators (`vunify::generate`), at small sizes: what they write is a PLY that
//! vunify reads back with the counts its header states, the terrain one connected height field
//! facing up, the city rigid scaled copies on a grid, both the same for a seed.

use glam::Vec3;
use vunify::generate::{City, Terrain, write_city, write_terrain};
use vunify::mesh::{self, CleanOptions, Mesh};

fn read(bytes: &[u8], name: &str) -> Mesh {
    let dir = std::env::temp_dir().join(format!("vunify-generate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    mesh::load(&path, &CleanOptions::default())
        .expect("reads back")
        .0
}

fn terrain_bytes(seed: u64) -> (Terrain, Vec<u8>) {
    let t = Terrain::with_triangles(2000, seed);
    let mut out = Vec::new();
    write_terrain(&mut out, &t, &mut |_, _| {}).unwrap();
    (t, out)
}

/// Components of a mesh's triangles joined by shared vertices.
fn components(m: &Mesh) -> usize {
    let mut parent: Vec<usize> = (0..m.positions.len()).collect();
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for t in &m.triangles {
        for k in 1..3 {
            let (a, b) = (
                root(&mut parent, t[0] as usize),
                root(&mut parent, t[k] as usize),
            );
            parent[a] = b;
        }
    }
    let mut roots: Vec<usize> = (0..m.positions.len())
        .map(|i| root(&mut parent, i))
        .collect();
    roots.sort_unstable();
    roots.dedup();
    roots.len()
}

#[test]
fn the_terrain_is_one_height_field_facing_up() {
    let (t, bytes) = terrain_bytes(7);
    let (vertices, triangles) = t.counts();
    assert_eq!(
        t.cells, 32,
        "32 × 32 cells make the 2,000 triangles asked for (2,048)"
    );
    let m = read(&bytes, "terrain.ply");
    assert_eq!(
        (m.positions.len() as u64, m.triangles.len() as u64),
        (vertices, triangles)
    );
    assert_eq!(components(&m), 1);
    for tri in &m.triangles {
        let [a, b, c] = tri.map(|v| m.positions[v as usize]);
        assert!((b - a).cross(c - a).y > 0.0, "every face looks up");
    }
    // Detail at every scale: the relief spans more than a cell, and neighbouring heights differ.
    let (lo, hi) = m
        .positions
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.y), hi.max(p.y))
        });
    assert!(hi - lo > t.size / t.cells as f32, "relief {}", hi - lo);
    assert_eq!(terrain_bytes(7).1, bytes, "the same for a seed");
    assert_ne!(terrain_bytes(8).1, bytes, "another for another seed");
}

#[test]
fn the_city_is_rigid_scaled_copies_on_a_grid() {
    let models = [
        vunify::fixtures::fig2(),
        vunify::fixtures::cuboid(Vec3::new(1.0, 2.0, 0.5)),
    ];
    let city = City {
        models: &models,
        copies: 7,
        seed: 3,
    };
    let mut bytes = Vec::new();
    write_city(&mut bytes, &city, &mut |_, _| {}).unwrap();
    let m = read(&bytes, "city.ply");
    let (vertices, triangles) = city.counts();
    assert_eq!(
        (m.positions.len() as u64, m.triangles.len() as u64),
        (vertices, triangles)
    );
    let parts: usize = (0..7).map(|i| components(&models[i % 2])).sum();
    assert_eq!(components(&m), parts, "copies apart");
    let mut start = 0;
    let mut footprints = Vec::new();
    for i in 0..7usize {
        let model = &models[i % 2];
        let copy = &m.positions[start..start + model.positions.len()];
        // Every distance scaled by one factor in [0.6, 1.4]: a rigid motion and a scale.
        let d = |p: &[Vec3], a: usize, b: usize| p[a].distance(p[b]);
        let factor = d(copy, 0, 1) / d(&model.positions, 0, 1);
        assert!((0.6..=1.4).contains(&factor), "copy {i}: scale {factor}");
        for a in 0..model.positions.len() {
            for b in a + 1..model.positions.len() {
                let want = d(&model.positions, a, b) * factor;
                assert!(
                    (d(copy, a, b) - want).abs() <= 1e-4 * want.max(1.0),
                    "copy {i}"
                );
            }
        }
        // Standing on the ground.
        let floor = copy.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
        assert!(floor.abs() < 1e-4, "copy {i} stands at {floor}");
        let (lo, hi) = copy
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            });
        footprints.push((lo, hi));
        start += model.positions.len();
    }
    // No two copies overlap.
    for (i, a) in footprints.iter().enumerate() {
        for b in &footprints[i + 1..] {
            let apart = a.1.x < b.0.x || b.1.x < a.0.x || a.1.z < b.0.z || b.1.z < a.0.z;
            assert!(apart, "{a:?} and {b:?} overlap");
        }
    }
}

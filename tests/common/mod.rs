//! Shared helpers for the integration tests: hand-built and random meshes, and the real models.
#![allow(dead_code)]

use glam::Vec3;
use std::path::PathBuf;
use vunify::mesh::{CleanOptions, Mesh, Part, clean};

/// A `w × h` grid of quads split into triangles, lifted by `height(x, y)`.
pub fn grid(w: u32, h: u32, height: impl Fn(f32, f32) -> f32) -> Mesh {
    let mut p = Vec::new();
    for y in 0..=h {
        for x in 0..=w {
            p.push(Vec3::new(x as f32, y as f32, height(x as f32, y as f32)));
        }
    }
    let idx = |x: u32, y: u32| y * (w + 1) + x;
    let mut t = Vec::new();
    for y in 0..h {
        for x in 0..w {
            t.push([idx(x, y), idx(x + 1, y), idx(x + 1, y + 1)]);
            t.push([idx(x, y), idx(x + 1, y + 1), idx(x, y + 1)]);
        }
    }
    Mesh::from_triangles(p, t)
}

#[allow(unused_imports)]
pub use vunify::fixtures::fig2;

/// Several meshes side by side as one scene, one part each.
pub fn scene(meshes: &[Mesh], spacing: f32) -> Mesh {
    let mut out = Mesh::default();
    for (i, m) in meshes.iter().enumerate() {
        let base = out.positions.len() as u32;
        let start = out.triangles.len() as u32;
        out.positions.extend(
            m.positions
                .iter()
                .map(|p| *p + Vec3::X * spacing * i as f32),
        );
        out.triangles
            .extend(m.triangles.iter().map(|t| t.map(|v| v + base)));
        out.parts.push(Part {
            name: format!("part{i}"),
            triangles: start..out.triangles.len() as u32,
        });
    }
    out
}

/// A deterministic generator for building random cases by hand (proptest drives the seeds).
pub struct Rng(pub u64);
impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn f32(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn below(&mut self, n: u32) -> u32 {
        (self.next() % n as u64) as u32
    }
}

/// Random triangle soup over few vertices (so edges are shared, non-manifold and repeated), cleaned.
pub fn random_soup(seed: u64, vertices: u32, triangles: u32) -> Mesh {
    let mut r = Rng(seed);
    let p: Vec<Vec3> = (0..vertices)
        .map(|_| Vec3::new(r.f32(), r.f32(), r.f32()))
        .collect();
    let t: Vec<[u32; 3]> = (0..triangles)
        .map(|_| [r.below(vertices), r.below(vertices), r.below(vertices)])
        .collect();
    clean(Mesh::from_triangles(p, t), &CleanOptions::default()).0
}

/// A random bumpy grid, possibly several of them as a scene.
pub fn random_scene(seed: u64) -> Mesh {
    let mut r = Rng(seed);
    let parts = 1 + r.below(3);
    let meshes: Vec<Mesh> = (0..parts)
        .map(|_| {
            let (w, h) = (1 + r.below(6), 1 + r.below(6));
            let amp = r.f32();
            let phase = r.f32() * 6.0;
            grid(w, h, |x, y| amp * (x * 1.3 + phase).sin() * (y * 0.7).cos())
        })
        .collect();
    scene(&meshes, 8.0 * r.f32())
}

/// `$VUNIFY_MODELS`, when set: the real models are tested only then (CI sets it).
pub fn models_dir() -> Option<PathBuf> {
    match std::env::var_os("VUNIFY_MODELS") {
        Some(d) => {
            let d = PathBuf::from(d);
            assert!(
                d.is_dir(),
                "VUNIFY_MODELS={} is not a directory",
                d.display()
            );
            Some(d)
        }
        None => {
            eprintln!("VUNIFY_MODELS is not set: skipping the tests on real models");
            None
        }
    }
}

pub const MODELS: [&str; 8] = [
    "cow.obj",
    "fandisk.obj",
    "cessna.obj",
    "beetle.obj",
    "laurana50k-vcolor.obj",
    "stanford-bunny.obj",
    "horse.obj",
    "stanford-dragon.obj.xz",
];

/// Each triangle split `levels` times into four at its edge midpoints (shared midpoints welded).
pub fn subdivided(mesh: &Mesh, levels: u32) -> Mesh {
    let mut m = mesh.clone();
    for _ in 0..levels {
        let mut p = m.positions.clone();
        let mut mid = std::collections::HashMap::new();
        let mut t = Vec::new();
        for tri in &m.triangles {
            let mut m3 = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                m3[k] = *mid.entry(key).or_insert_with(|| {
                    p.push((p[a as usize] + p[b as usize]) * 0.5);
                    p.len() as u32 - 1
                });
            }
            let [a, b, c] = *tri;
            let [ab, bc, ca] = m3;
            t.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        m = Mesh::from_triangles(p, t);
    }
    m
}

/// A command's stdout, asserting that it succeeded (both streams shown when it did not).
pub fn ok(out: &std::process::Output) -> String {
    assert!(
        out.status.success(),
        "stdout: {}\nstderr: {}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout.clone()).unwrap()
}

/// Each node's id in a paged file: the leaves numbered depth-first (a node's first child's
/// leaves before its second's), internal nodes as built.
pub fn file_ids(tree: &vunify::vtree::VertexTree) -> Vec<u32> {
    let mut id: Vec<u32> = (0..tree.nodes.len() as u32).collect();
    let (mut next, mut stack) = (0, vec![tree.root()]);
    while let Some(u) = stack.pop() {
        if u < tree.leaf_count {
            id[u as usize] = next;
            next += 1;
        } else {
            let [a, b] = tree.nodes[u as usize].children;
            stack.extend([b, a]);
        }
    }
    id
}

/// Recomputes every section's checksum in the table, and the table's: a file whose numbers lie
/// while its checksums hold, as a writer with a bug would make it.
pub fn reseal(bytes: &mut [u8]) {
    let count = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let u64_at = |b: &[u8], i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap()) as usize;
    for i in 0..count {
        let at = 16 + 32 * i;
        let (offset, len) = (u64_at(bytes, at + 8), u64_at(bytes, at + 16));
        let sum = crc32fast::hash(&bytes[offset..offset + len]);
        bytes[at + 24..at + 28].copy_from_slice(&sum.to_le_bytes());
    }
    let end = 16 + 32 * count;
    let sum = crc32fast::hash(&bytes[..end]);
    bytes[end..end + 4].copy_from_slice(&sum.to_le_bytes());
}

/// Where section `tag`'s body lies in a file.
pub fn section(bytes: &[u8], tag: &[u8; 4]) -> std::ops::Range<usize> {
    let count = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let u64_at = |i: usize| u64::from_le_bytes(bytes[i..i + 8].try_into().unwrap()) as usize;
    (0..count)
        .map(|i| 16 + 32 * i)
        .find(|&at| &bytes[at..at + 4] == tag)
        .map(|at| u64_at(at + 8)..u64_at(at + 8) + u64_at(at + 16))
        .unwrap()
}

//! A model of tens of millions of triangles for the scaling benchmarks: a mesh subdivided `LEVELS`
//! times (each triangle into four at its edge midpoints), the new vertices pushed along the surface
//! normal by a few octaves of smooth noise, so that the result has scan-like detail at every level
//! rather than flat facets. Written as binary PLY, atomically.
//!
//!     cargo run --release --example subdivide -- $VUNIFY_MODELS/stanford-dragon.obj.xz big.ply [LEVELS]
//!
//! The dragon (871,306 triangles) twice subdivided is 13.9 million triangles, 7 million vertices.

use glam::Vec3;
use std::collections::HashMap;
use std::path::Path;
use vunify::mesh::{self, CleanOptions, Mesh};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, output, rest @ ..] = &args[..] else {
        eprintln!("usage: subdivide INPUT OUTPUT.ply [LEVELS (default 2)]");
        std::process::exit(2);
    };
    let levels: u32 = rest
        .first()
        .map_or(2, |l| l.parse().expect("LEVELS: a number"));
    let (mut mesh, _) =
        mesh::load(Path::new(input), &CleanOptions::default()).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(1)
        });
    let diagonal = mesh.diagonal();
    for level in 0..levels {
        // Detail a little smaller than the new edges: each level adds its own octave.
        let amplitude = 0.0006 * diagonal / 2f32.powi(level as i32);
        let frequency = 180.0 * 2f32.powi(level as i32) / diagonal;
        mesh = subdivide(&mesh, amplitude, frequency);
        eprintln!("level {}: {} triangles", level + 1, mesh.triangle_count());
    }
    let bytes = vunify::export::ply_bytes(&mesh);
    vunify::export::write_atomic(Path::new(output), &bytes).expect("write");
    eprintln!(
        "wrote {output}: {} triangles, {} MB",
        mesh.triangle_count(),
        bytes.len() >> 20
    );
}

/// Each triangle into four; the midpoints displaced along the mean normal of their edge's ends.
fn subdivide(mesh: &Mesh, amplitude: f32, frequency: f32) -> Mesh {
    let normals = vertex_normals(mesh);
    let mut positions = mesh.positions.clone();
    let mut midpoint: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.triangles.len() * 2);
    let mut triangles = Vec::with_capacity(mesh.triangles.len() * 4);
    for t in &mesh.triangles {
        let mut m = [0u32; 3];
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            m[k] = *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let p = (mesh.positions[a as usize] + mesh.positions[b as usize]) * 0.5;
                let n = (normals[a as usize] + normals[b as usize]).normalize_or_zero();
                positions.push(p + n * amplitude * noise(p * frequency));
                positions.len() as u32 - 1
            });
        }
        let [a, b, c] = *t;
        triangles.extend([
            [a, m[0], m[2]],
            [m[0], b, m[1]],
            [m[2], m[1], c],
            [m[0], m[1], m[2]],
        ]);
    }
    Mesh {
        parts: vec![mesh::Part {
            name: "subdivided".into(),
            triangles: 0..triangles.len() as u32,
        }],
        positions,
        triangles,
        colors: None,
        normals: None,
        ..Mesh::default()
    }
}

fn vertex_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; mesh.positions.len()];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
        let n = (b - a).cross(c - a);
        for v in t {
            normals[*v as usize] += n;
        }
    }
    normals.iter().map(|n| n.normalize_or_zero()).collect()
}

/// Smooth noise in [-1, 1]: three octaves of products of sines at incommensurate frequencies.
fn noise(p: Vec3) -> f32 {
    let mut sum = 0.0;
    let mut scale = 1.0;
    for octave in 0..3 {
        let q = p * scale;
        sum += (q.x * 1.3 + 0.7 * octave as f32).sin()
            * (q.y * 1.7 + 1.1).sin()
            * (q.z * 1.1 + 0.3).sin()
            / scale;
        scale *= 2.1;
    }
    sum / 1.6
}

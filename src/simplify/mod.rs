//! Simplification machinery shared by the vertex-tree builder and the static simplifiers: the working
//! mesh and its merge operation, quadrics, candidate pairs, feature classification and merge pricing.

pub mod attribute_quadric;
pub mod bounded;
pub mod bounds;
pub mod collapse;
pub mod envelope;
pub mod features;
pub mod geometry;
pub mod intersect;
pub mod metric;
pub mod pairs;
pub mod quadric;

pub use metric::Metric;

/// Why a simplification within a distance (`bounded` or an envelope method) cannot run.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum DistanceError {
    #[error("the mesh has no triangles")]
    Empty,
    #[error("epsilon must be between 0 and 1 (a fraction of the diagonal), got {0}")]
    Epsilon(f64),
}

/// The live faces of a working mesh as a compact [`Mesh`] (unused vertices dropped, positions
/// rounded to `f32`). A working vertex is the input vertex of its index, moved: it keeps that
/// vertex's attributes (colour, normal, texture coordinates, material) from `input`.
pub(crate) fn live_mesh(
    positions: &[glam::DVec3],
    faces: &[[u32; 3]],
    alive: &[bool],
    input: &crate::mesh::Mesh,
) -> crate::mesh::Mesh {
    let mut index = vec![u32::MAX; positions.len()];
    let mut out = Vec::new();
    let mut kept = Vec::new();
    let mut triangles = Vec::new();
    for (t, _) in faces.iter().zip(alive).filter(|(_, a)| **a) {
        triangles.push(t.map(|v| {
            if index[v as usize] == u32::MAX {
                index[v as usize] = out.len() as u32;
                out.push(positions[v as usize].as_vec3());
                kept.push(v);
            }
            index[v as usize]
        }));
    }
    let mut mesh = crate::mesh::Mesh::from_triangles(out, triangles);
    mesh.carry_attributes(input, &kept);
    mesh
}

/// A small deterministic generator for the unit tests: uniform in [0, 1).
#[cfg(test)]
pub(crate) fn test_random(mut seed: u64) -> impl FnMut() -> f32 {
    move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 40) as f32 / (1u64 << 24) as f32
    }
}

//! Hand-built meshes the tests share (unit tests here, integration tests through `tests/common`),
//! each with its picture. Not part of the public interface.

use crate::mesh::Mesh;
use glam::Vec3;

/// Tao et al.'s Fig. 2: a tetrahedron (vertices 0–3, faces 0–3) beside a separate triangle
/// (vertices 4 5 6, face 4).
/// ```text
///        3                  6
///       /|\                / \
///      / | \              /   \
///     0--|--2            4-----5
///      \ | /
///       \|/
///        1
/// ```
pub fn fig2() -> Mesh {
    let p = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(5.0, 0.0, 0.0),
        Vec3::new(4.5, 0.0, 1.0),
    ];
    Mesh::from_triangles(
        p,
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2], [4, 5, 6]],
    )
}

/// An axis-aligned box from the origin to `size`, 12 triangles facing out. Corner `i` has x, y, z
/// set from bits 0, 1, 2 of `i`:
/// ```text
///       6-------7
///      /|      /|
///     4-------5 |
///     | 2-----|-3
///     |/      |/
///     0-------1
/// ```
pub fn cuboid(size: Vec3) -> Mesh {
    let p = (0..8)
        .map(|i| Vec3::new((i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2 & 1) as f32) * size)
        .collect();
    let t = vec![
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    Mesh::from_triangles(p, t)
}

//! Whether a build that is given no cell size goes in cells: whole while a whole build fits in
//! memory (the best tree), in cells where it would have the machine swap or the kernel stop it.

use crate::mesh::Mesh;

/// What a whole build's process peaks at, a triangle of its input, rounded up (265 on the 14 M
/// model, 287 on the dragon: BENCHMARKS.md).
pub const WHOLE_BUILD_BYTES_PER_TRIANGLE: u64 = 300;

/// The cell size a build uses when it is not given one.
pub const DEFAULT_CELL_TRIANGLES: usize = 1_000_000;

/// The cells to build `mesh` in on a machine with `physical` bytes of memory when asked for
/// none: `None` (whole) while a whole build needs at most three quarters of the memory, or when
/// the mesh would be built whole in cells anyway (it fits in one, or it carries colours, texture
/// coordinates or materials); [`DEFAULT_CELL_TRIANGLES`] otherwise (a partitioned build peaks at
/// about two thirds of a whole one's, BENCHMARKS.md). Unknown memory: whole.
pub fn default_cells(mesh: &Mesh, physical: Option<u64>) -> Option<usize> {
    if crate::vtree::build::builds_whole(mesh, DEFAULT_CELL_TRIANGLES) {
        return None;
    }
    cells_for(mesh.triangles.len(), physical?)
}

/// [`default_cells`] of a mesh of `triangles` triangles with no appearance.
fn cells_for(triangles: usize, physical: u64) -> Option<usize> {
    let whole = triangles as u64 * WHOLE_BUILD_BYTES_PER_TRIANGLE;
    (whole > physical / 4 * 3 && triangles > DEFAULT_CELL_TRIANGLES)
        .then_some(DEFAULT_CELL_TRIANGLES)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_build_is_whole_while_it_fits_in_three_quarters_of_memory() {
        const GIB: u64 = 1 << 30;
        // 24 GiB: whole up to 18 GiB / 300 B ≈ 64 M triangles, in cells beyond.
        assert_eq!(cells_for(14_000_000, 24 * GIB), None);
        assert_eq!(cells_for(64_000_000, 24 * GIB), None);
        assert_eq!(
            cells_for(66_000_000, 24 * GIB),
            Some(DEFAULT_CELL_TRIANGLES)
        );
        assert_eq!(
            cells_for(100_000_000, 24 * GIB),
            Some(DEFAULT_CELL_TRIANGLES)
        );
        // A small machine: 2 M triangles in cells on 256 MiB, but never a mesh that fits in one
        // cell (the dragon).
        assert_eq!(cells_for(871_306, 256 << 20), None);
        assert_eq!(
            cells_for(2_000_000, 256 << 20),
            Some(DEFAULT_CELL_TRIANGLES)
        );
    }

    /// A mesh the cells would build whole anyway (one cell's worth, or with colours) stays whole
    /// whatever the memory; unknown memory builds whole.
    #[test]
    fn meshes_the_cells_build_whole_are_never_given_cells() {
        let tiny = 1u64 << 10;
        let mut mesh = Mesh::from_triangles(
            vec![glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y],
            vec![[0, 1, 2]],
        );
        assert_eq!(default_cells(&mesh, Some(tiny)), None);
        mesh.colors = Some(vec![glam::Vec3::ONE; 3]);
        assert_eq!(default_cells(&mesh, Some(tiny)), None);
        assert_eq!(default_cells(&mesh, None), None);
    }
}

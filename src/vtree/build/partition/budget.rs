//! How much memory a build takes, and the cells that keep it within a budget: whole while a
//! whole build fits (the best tree), in cells as large as the budget allows beyond.
//!
//! The model is measured, not derived (BENCHMARKS.md, "Memory"): a whole build peaks at about
//! [`WHOLE_BUILD_BYTES_PER_TRIANGLE`]; a build in cells holds what its levels share
//! ([`SHARED_BYTES_PER_TRIANGLE`] of the whole input) plus, for each cell being built at once
//! (one a thread), [`CELL_BYTES_PER_TRIANGLE`] of the cell; and whatever its cells, it never
//! peaks below [`CELLS_FLOOR_BYTES_PER_TRIANGLE`], where the edges are classified and the tree
//! is numbered and encoded whole.

use crate::mesh::Mesh;

/// What a whole build's process peaks at, a triangle of its input, rounded up (265 on the 14 M
/// model, 287 on the dragon: BENCHMARKS.md).
pub const WHOLE_BUILD_BYTES_PER_TRIANGLE: u64 = 300;

/// What a build in cells peaks at, a triangle of its input, however small its cells (124 on the
/// 14 M model where its edges are classified, 126 where its whole tree is numbered; rounded up).
pub const CELLS_FLOOR_BYTES_PER_TRIANGLE: u64 = 135;

/// What the levels of a build in cells share, a triangle of its input (125 on the 14 M model).
pub const SHARED_BYTES_PER_TRIANGLE: u64 = 130;

/// What a cell holds while it is built, a triangle of the cell (445 on the 14 M model in cells
/// of 1,000,000, two at once).
pub const CELL_BYTES_PER_TRIANGLE: u64 = 500;

/// What any build's process holds besides its data: the program, its threads and its
/// allocator's reserve (about 30 MiB on the smallest models).
pub const BASE_BYTES: u64 = 40 << 20;

/// The smallest cells a budget chooses: smaller ones cost quality (more borders locked) and
/// time (more levels) and save little memory, which the floor then holds.
pub const MIN_CELL_TRIANGLES: usize = 20_000;

/// The cell size a build uses when it is not given one and memory allows it.
pub const DEFAULT_CELL_TRIANGLES: usize = 1_000_000;

/// A budget no build of the mesh fits in: `needed` bytes at least; `whole_only` when the mesh
/// can only be built whole (it carries colours, texture coordinates or materials).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BudgetTooSmall {
    pub needed: u64,
    pub whole_only: bool,
}

/// The estimated peak of a whole build of `triangles` triangles.
pub fn whole_build_bytes(triangles: usize) -> u64 {
    BASE_BYTES + triangles as u64 * WHOLE_BUILD_BYTES_PER_TRIANGLE
}

/// The estimated peak of a build of `triangles` triangles in cells of `cell_triangles`, `threads`
/// of them built at once.
pub fn cells_build_bytes(triangles: usize, cell_triangles: usize, threads: usize) -> u64 {
    let t = triangles as u64;
    let levels = t * SHARED_BYTES_PER_TRIANGLE
        + (cell_triangles.min(triangles) * threads.max(1)) as u64 * CELL_BYTES_PER_TRIANGLE;
    BASE_BYTES + levels.max(t * CELLS_FLOOR_BYTES_PER_TRIANGLE)
}

/// How to build `mesh` within `budget` bytes of resident memory with `threads` threads: `None`
/// for whole, else the largest cells that fit (the fewer borders, the better the tree).
pub fn cells_within(
    mesh: &Mesh,
    budget: u64,
    threads: usize,
) -> Result<Option<usize>, BudgetTooSmall> {
    let appearance = crate::vtree::build::builds_whole(mesh, 0);
    cells_for(mesh.triangles.len(), appearance, budget, threads)
}

fn cells_for(
    triangles: usize,
    appearance: bool,
    budget: u64,
    threads: usize,
) -> Result<Option<usize>, BudgetTooSmall> {
    let whole = whole_build_bytes(triangles);
    if whole <= budget {
        return Ok(None);
    }
    if appearance || triangles <= MIN_CELL_TRIANGLES {
        return Err(BudgetTooSmall {
            needed: whole,
            whole_only: true,
        });
    }
    let threads = threads.max(1) as u64;
    let t = triangles as u64;
    let shared = BASE_BYTES + t * SHARED_BYTES_PER_TRIANGLE;
    let cells = budget.saturating_sub(shared) / (threads * CELL_BYTES_PER_TRIANGLE);
    let cells = (cells as usize).min(triangles.div_ceil(2));
    if cells < MIN_CELL_TRIANGLES || cells_build_bytes(triangles, cells, threads as usize) > budget
    {
        return Err(BudgetTooSmall {
            needed: cells_build_bytes(triangles, MIN_CELL_TRIANGLES, threads as usize),
            whole_only: false,
        });
    }
    Ok(Some(cells))
}

/// The cells to build `mesh` in on a machine with `physical` bytes of memory when asked for
/// none: within three quarters of the memory (see [`cells_within`]), in cells of at most
/// [`DEFAULT_CELL_TRIANGLES`]; when nothing fits, in cells of that size anyway (the build may
/// swap). `None` (whole) for a mesh the cells would build whole anyway (it fits in one, or it
/// carries colours, texture coordinates or materials), or when the memory is unknown.
pub fn default_cells(mesh: &Mesh, physical: Option<u64>, threads: usize) -> Option<usize> {
    if crate::vtree::build::builds_whole(mesh, DEFAULT_CELL_TRIANGLES) {
        return None;
    }
    default_cells_for(mesh.triangles.len(), physical?, threads)
}

fn default_cells_for(triangles: usize, physical: u64, threads: usize) -> Option<usize> {
    if triangles <= DEFAULT_CELL_TRIANGLES {
        return None;
    }
    match cells_for(triangles, false, physical / 4 * 3, threads) {
        Ok(cells) => cells.map(|c| c.min(DEFAULT_CELL_TRIANGLES)),
        Err(_) => Some(DEFAULT_CELL_TRIANGLES),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MIB: u64 = 1 << 20;
    const GIB: u64 = 1 << 30;

    #[test]
    fn a_build_is_whole_while_it_fits_in_three_quarters_of_memory() {
        // 24 GiB: whole up to 18 GiB / 300 B ≈ 64 M triangles, in cells beyond.
        assert_eq!(default_cells_for(14_000_000, 24 * GIB, 2), None);
        assert_eq!(default_cells_for(64_000_000, 24 * GIB, 2), None);
        assert_eq!(
            default_cells_for(66_000_000, 24 * GIB, 2),
            Some(DEFAULT_CELL_TRIANGLES)
        );
        assert_eq!(
            default_cells_for(100_000_000, 24 * GIB, 2),
            Some(DEFAULT_CELL_TRIANGLES)
        );
        // A small machine: 2 M triangles in cells on 256 MiB (which nothing fits), but never a
        // mesh that fits in one cell (the dragon).
        assert_eq!(default_cells_for(871_306, 256 * MIB, 2), None);
        assert_eq!(
            default_cells_for(2_000_000, 256 * MIB, 2),
            Some(DEFAULT_CELL_TRIANGLES)
        );
        // 4 GiB and 14 M triangles: 3 GiB leaves room for two cells of ~1.4 M, so 1 M.
        assert_eq!(
            default_cells_for(14_000_000, 4 * GIB, 2),
            Some(DEFAULT_CELL_TRIANGLES)
        );
        // 3.25 GiB: 2.44 GiB less the shared 1.86 GB leaves two cells of ~0.75 M.
        let cells = default_cells_for(14_000_000, 13 * GIB / 4, 2).unwrap();
        assert!((600_000..900_000).contains(&cells), "{cells}");
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
        assert_eq!(default_cells(&mesh, Some(tiny), 2), None);
        mesh.colors = Some(vec![glam::Vec3::ONE; 3]);
        assert_eq!(default_cells(&mesh, Some(tiny), 2), None);
        assert_eq!(default_cells(&mesh, None, 2), None);
    }

    /// A budget gets the largest cells whose estimated peak fits it, whole when a whole build
    /// does; and a budget below the floor is refused with what would do.
    #[test]
    fn a_budget_gets_the_largest_cells_that_fit_it_or_says_what_would() {
        let dragon = 871_306;
        // Whole: 40 MiB + 261 MB fits in 512 MiB.
        assert_eq!(cells_for(dragon, false, 512 * MIB, 2), Ok(None));
        // 200 MiB: in cells, the largest that fit, and within the budget by the model.
        let cells = cells_for(dragon, false, 200 * MIB, 2).unwrap().unwrap();
        assert!(cells >= MIN_CELL_TRIANGLES && cells < dragon, "{cells}");
        assert!(cells_build_bytes(dragon, cells, 2) <= 200 * MIB);
        assert!(cells_build_bytes(dragon, cells + 1000, 2) > 200 * MIB);
        // One thread builds one cell at a time: larger cells in the same budget.
        let alone = cells_for(dragon, false, 200 * MIB, 1).unwrap().unwrap();
        assert!(alone > cells, "{alone} {cells}");
        // 64 MiB is below the floor (135 B a triangle): refused, saying how much would do, and
        // that much does.
        let refused = cells_for(dragon, false, 64 * MIB, 2).unwrap_err();
        assert!(!refused.whole_only);
        assert!(refused.needed > 135 * dragon as u64, "{refused:?}");
        assert!(cells_for(dragon, false, refused.needed, 2).is_ok());
        // With colours or textures only a whole build will do.
        assert_eq!(
            cells_for(dragon, true, 200 * MIB, 2),
            Err(BudgetTooSmall {
                needed: whole_build_bytes(dragon),
                whole_only: true
            })
        );
        // 100 M triangles in 8 GiB: below the floor of ~13.5 GB.
        let huge = cells_for(100_000_000, false, 8 * GIB, 2).unwrap_err();
        assert!(huge.needed > 13_500_000_000, "{huge:?}");
        // ... and in 20 GiB, cells of a few million.
        let cells = cells_for(100_000_000, false, 20 * GIB, 2).unwrap().unwrap();
        assert!((1_000_000..10_000_000).contains(&cells), "{cells}");
    }
}

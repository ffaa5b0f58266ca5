//! Simplification machinery shared by the vertex-tree builder and the static simplifiers: the working
//! mesh and its merge operation, quadrics, candidate pairs, feature classification and merge pricing.

pub mod bounded;
pub mod bounds;
pub mod collapse;
pub mod features;
pub mod geometry;
pub mod metric;
pub mod pairs;
pub mod quadric;

pub use metric::Metric;

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

//! Simplification machinery shared by the vertex-tree builder and the static simplifiers: the working
//! mesh and its merge operation, quadrics, candidate pairs, feature classification and merge pricing.

pub mod bounds;
pub mod collapse;
pub mod features;
pub mod geometry;
pub mod metric;
pub mod pairs;
pub mod quadric;

pub use metric::Metric;

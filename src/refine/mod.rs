//! The view-dependent refinement runtime (seed 001 §3.2–3.3, §4): a live front through a vertex tree,
//! refined and coarsened every frame by the frustum, normal and screen-space error tests, amortised over
//! frames, with geomorphs. No GPU here: [`Front::indices`] and [`Refiner::vertex_updates`] are what a
//! renderer uploads.
//!
//! [`hierarchy`] prepares a tree for the runtime, [`front`] holds the live vertex and triangle chains
//! and the `vsplit` / `vunify` operations, [`criteria`] the camera and the three tests, [`adapt`] the
//! per-frame driver (with `lookahead`, the prefetching that keeps it from waiting on memory),
//! [`validation`] from-scratch checks for tests.

pub mod adapt;
pub mod criteria;
pub mod front;
pub mod hierarchy;
mod lookahead;
mod trace;
pub mod validation;

pub use adapt::{FrameStats, Mode, Refiner, Settings};
pub use criteria::{Camera, Tests, View};
pub use front::{CutError, Front};
pub use hierarchy::Hierarchy;

//! The view-dependent refinement runtime (Tao et al. §3.2–3.3, §4): a live front through a vertex tree,
//! refined and coarsened every frame by the frustum, normal and screen-space error tests, amortised over
//! frames, with geomorphs. No GPU here: [`Front::indices`] and [`Refiner::vertex_updates`] are what a
//! renderer uploads.
//!
//! [`hierarchy`] prepares a tree for the runtime, [`front`] holds the live vertex and triangle chains
//! and the `vsplit` / `vunify` operations, [`criteria`] the camera and the three tests, [`adapt`] the
//! per-frame driver (with `stream`, the front in the order its visits read it),
//! [`hold`] the frame-rate hold a viewer puts on τ, [`validation`] from-scratch checks for tests.
//!
//! Tao, Cheng, Pan and Shi, *Dynamic level of detail framework with topological structure
//! modification* (State Key Laboratory of CAD&CG, Zhejiang University), §3–4; with Hoppe's
//! *View-dependent refinement of progressive meshes* (SIGGRAPH 97) and Luebke and Erikson's
//! *View-dependent simplification of arbitrary polygonal environments* (SIGGRAPH 97).
//! `docs/RUNTIME.md` explains it.

pub mod adapt;
pub mod cache;
pub mod criteria;
pub mod front;
pub mod hierarchy;
pub mod hold;
mod stream;
pub mod streamed;
mod trace;
pub mod validation;

pub use adapt::{FrameStats, Mode, Refiner, Settings};
pub use cache::{CacheStats, PageCache, PageSource};
pub use criteria::{Camera, Tests, View};
pub use front::{CutError, Front};
pub use hierarchy::Hierarchy;
pub use hold::Hold;
pub use streamed::{StreamError, StreamFrame, Streamed};

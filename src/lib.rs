//! vunify: view-dependent level of detail for triangle meshes.
//!
//! The crate reads as a pipeline, each module depending only on those before it:
//! [`mesh`] (input, welding) → [`simplify`] (quadrics, pairs, the merge operation) → [`vtree`] (the
//! binary vertex tree of seed 001: its builder, file format and static extraction) → [`measure`]
//! (Hausdorff distance). None of these touch a GPU.

#[cfg(feature = "viewer")]
pub mod app;
pub mod export;
pub mod measure;
pub mod mesh;
pub mod path;
pub mod refine;
#[cfg(feature = "render")]
pub mod render;
pub mod simplify;
pub mod vtree;

//! Radiosity illumination meshes (seed 000's input): a progressive refinement solver with adaptive,
//! conforming subdivision along shadow boundaries (`solve`), over scenes read from OBJ + MTL
//! (`scene`), written as lit meshes with per-vertex and per-element radiosity (`output`). See
//! docs/RADIOSITY.md.

pub mod earclip;
pub mod elements;
pub mod output;
pub mod scene;
pub mod solve;
pub mod superfaces;

pub use scene::{Material, Polygon, Scene, SceneError};
pub use solve::{RadiosityOptions, RadiosityStats, Solution, solve};

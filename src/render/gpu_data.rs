//! `#[repr(C)]` mirrors of the WGSL structs in `shaders/`, with their sizes asserted.

use bytemuck::{Pod, Zeroable};

/// `Globals` of `shaders/mesh.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Globals {
    pub clip_from_world: [[f32; 4]; 4],
    /// xyz: the eye; w: pixels per unit of length at distance 1.
    pub eye: [f32; 4],
    /// xyz: towards the light; w: ambient share.
    pub light: [f32; 4],
    /// x: τ in pixels; y: near plane.
    pub params: [f32; 4],
    /// x: colour mode; y: flat shading; z: wireframe pass.
    pub modes: [u32; 4],
    pub wire_color: [f32; 4],
}

const _: () = assert!(std::mem::size_of::<Globals>() == 144);

/// Per-node debug attributes (`@location(3)`): object-space error and tree depth.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Debug {
    pub error: f32,
    pub depth: f32,
}

const _: () = assert!(std::mem::size_of::<Debug>() == 8);

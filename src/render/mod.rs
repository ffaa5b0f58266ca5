//! The wgpu renderer of a live front: it draws into any `&TextureView`, so the same code
//! serves the app's window and headless rendering on lavapipe. Depends on [`crate::refine`]; nothing
//! below it depends on this.

pub mod gpu_data;
pub mod headless;
pub mod image_diff;
pub mod job;
pub mod renderer;
pub mod textures;

pub use headless::{Gpu, Offscreen};
pub use renderer::{ColorBy, DrawOptions, Renderer, Target, UploadStats, WireMode};

/// The GPU could not be used.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(
        "no Vulkan adapter found. vunify renders with any Vulkan device; on a machine without a GPU, \
         install Mesa's software renderer lavapipe: `sudo apt-get install -y mesa-vulkan-drivers libvulkan1` \
         (Debian/Ubuntu)"
    )]
    NoAdapter,
    #[error("could not create the GPU device: {0}")]
    Device(String),
    #[error("reading the frame back failed: {0}")]
    Readback(String),
}

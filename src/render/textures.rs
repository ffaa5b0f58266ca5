//! Base colour textures on the GPU: one 2D array, a layer per texture, each resampled to one
//! square size (a power of two, at most [`MAX_SIZE`]) with its mip chain, as sRGB.

use std::sync::Arc;

/// The largest layer side, in texels: 1024² × 4 bytes × 4/3 for the mips is 5.3 MB a texture.
pub const MAX_SIZE: u32 = 1024;

const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// A 1 × 1, one-layer array for models without textures (the pass binds one either way); its
/// texel is whatever wgpu zero-initialises it to, and no vertex samples it.
pub fn placeholder(device: &wgpu::Device) -> wgpu::TextureView {
    array(device, 1, 1, 1).create_view(&view_descriptor())
}

/// Decodes `files` (PNG or JPEG) and uploads them as one array. A file that no longer decodes
/// (the reader decoded it once) becomes a grey layer.
pub fn upload(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    files: &[Arc<Vec<u8>>],
) -> wgpu::TextureView {
    let images: Vec<image::RgbaImage> = files
        .iter()
        .map(|f| {
            image::load_from_memory(f)
                .map(|i| i.to_rgba8())
                .unwrap_or_else(|_| {
                    image::RgbaImage::from_pixel(1, 1, image::Rgba([128, 128, 128, 255]))
                })
        })
        .collect();
    let largest = images
        .iter()
        .map(|i| i.width().max(i.height()))
        .max()
        .unwrap_or(1);
    let size = largest.next_power_of_two().clamp(1, MAX_SIZE);
    let levels = size.ilog2() + 1;
    let texture = array(device, size, images.len() as u32, levels);
    for (layer, image) in images.iter().enumerate() {
        let mut level =
            image::imageops::resize(image, size, size, image::imageops::FilterType::Triangle);
        for mip in 0..levels {
            let side = level.width();
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: mip,
                    origin: wgpu::Origin3d {
                        x: 0,
                        y: 0,
                        z: layer as u32,
                    },
                    aspect: wgpu::TextureAspect::All,
                },
                level.as_raw(),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(4 * side),
                    rows_per_image: Some(side),
                },
                wgpu::Extent3d {
                    width: side,
                    height: side,
                    depth_or_array_layers: 1,
                },
            );
            if side > 1 {
                level = image::imageops::resize(
                    &level,
                    side / 2,
                    side / 2,
                    image::imageops::FilterType::Triangle,
                );
            }
        }
    }
    texture.create_view(&view_descriptor())
}

/// Trilinear, repeating (glTF's default sampler), anisotropic up to 4×.
pub fn sampler(device: &wgpu::Device) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("textures"),
        address_mode_u: wgpu::AddressMode::Repeat,
        address_mode_v: wgpu::AddressMode::Repeat,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        anisotropy_clamp: 4,
        ..Default::default()
    })
}

fn array(device: &wgpu::Device, size: u32, layers: u32, levels: u32) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("base colour textures"),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: layers.max(1),
        },
        mip_level_count: levels,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

fn view_descriptor() -> wgpu::TextureViewDescriptor<'static> {
    wgpu::TextureViewDescriptor {
        label: Some("base colour textures"),
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    }
}

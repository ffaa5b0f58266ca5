//! The long-lived renderer: pipelines, the model's per-node vertex buffers, and the index buffer that
//! follows the front, written only where the runtime reports changes.

use super::gpu_data::{Debug, Globals};
use crate::refine::{Camera, Front, Hierarchy, View};
use glam::Vec3;
use wgpu::util::DeviceExt;

pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The index buffer grows by this factor when the front outgrows it, so that a growing front
/// reallocates O(log n) times, not every frame.
const GROWTH: f64 = 1.5;
/// No index buffer chunk is larger than lavapipe's largest storage binding, 128 MiB.
const MAX_CHUNK_BYTES: u64 = 128 << 20;
/// The smallest index buffer, in triangles.
const MIN_TRIANGLES: u64 = 1024;

pub use crate::display::ColorBy;

#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DrawOptions {
    pub color_by: ColorBy,
    /// Face normals instead of the nodes' interpolated normals.
    pub flat: bool,
    /// Draw the triangle edges over the surface (where the adapter can draw lines).
    pub wireframe: bool,
    /// Linear RGBA the target is cleared to.
    pub background: [f64; 4],
    /// τ, for the error colouring.
    pub tolerance_px: f32,
    /// Draw into this rectangle of the target only, `[x, y, width, height]` in pixels (the camera's
    /// viewport should match its size). `None`: the whole target.
    pub viewport: Option<[f32; 4]>,
    /// Clear the target first; off to draw several viewports into one target.
    pub clear: bool,
}

impl Default for DrawOptions {
    fn default() -> Self {
        DrawOptions {
            color_by: ColorBy::Auto,
            flat: false,
            wireframe: false,
            background: [0.02, 0.025, 0.035, 1.0],
            tolerance_px: 1.0,
            viewport: None,
            clear: true,
        }
    }
}

/// Where a frame is drawn: a colour view (of a format the renderer was made for) and a
/// [`DEPTH_FORMAT`] view of the same size.
#[derive(Clone, Copy)]
pub struct Target<'a> {
    pub color: &'a wgpu::TextureView,
    pub depth: &'a wgpu::TextureView,
}

/// What one upload moved to the GPU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UploadStats {
    pub bytes: u64,
    /// The index buffer was reallocated.
    pub reallocated: bool,
}

struct Model {
    positions: wgpu::Buffer,
    normals: wgpu::Buffer,
    colors: wgpu::Buffer,
    debug: wgpu::Buffer,
    /// `[u, v, texture, material]` per node (−1: none; all −1 for a model with neither).
    uv_texture: wgpu::Buffer,
    /// Per vertex, the tint its texture is multiplied by (white where nothing is tinted).
    tint: wgpu::Buffer,
    has_colors: bool,
    has_textures: bool,
    /// A one-sided mesh with colours: lighting baked in, drawn unlit by `ColorBy::Auto`.
    baked: bool,
    /// Faces are drawn from their front only (a lit room seen from outside shows its inside).
    one_sided: bool,
    indices: Indices,
    triangles: u32,
}

/// GPU time of the last frame from timestamp queries, where the adapter has them.
struct Timer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    period_ns: f32,
}

pub struct Renderer {
    /// Triangles per index buffer chunk.
    chunk_triangles: u64,
    fill: wgpu::RenderPipeline,
    wire: Option<wgpu::RenderPipeline>,
    /// The wireframe where lines cannot be drawn: barycentric edges from pulled vertices.
    barycentric: Option<(wgpu::RenderPipeline, wgpu::BindGroupLayout)>,
    globals: wgpu::Buffer,
    bind_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    bind_group: wgpu::BindGroup,
    model: Option<Model>,
    timer: Option<Timer>,
}

fn vertex_layouts() -> [wgpu::VertexBufferLayout<'static>; 6] {
    const POSITION: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x3];
    const NORMAL: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![1 => Snorm16x2];
    const COLOR: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![2 => Unorm8x4];
    const DEBUG: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![3 => Float32x2];
    const UV_TEXTURE: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![4 => Float32x4];
    const TINT: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![5 => Unorm8x4];
    let layout =
        |stride: u64, attributes: &'static [wgpu::VertexAttribute]| wgpu::VertexBufferLayout {
            array_stride: stride,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes,
        };
    [
        layout(12, &POSITION),
        layout(4, &NORMAL),
        layout(4, &COLOR),
        layout(8, &DEBUG),
        layout(16, &UV_TEXTURE),
        layout(4, &TINT),
    ]
}

/// The WGSL of the mesh pass (also validated on the CPU by a test).
pub const MESH_WGSL: &str = concat!(
    include_str!("../../shaders/globals.wgsl"),
    include_str!("../../shaders/mesh.wgsl")
);
/// The WGSL of the barycentric wireframe fallback.
pub const WIRE_BARYCENTRIC_WGSL: &str = concat!(
    include_str!("../../shaders/globals.wgsl"),
    include_str!("../../shaders/wire_barycentric.wgsl")
);

/// How the wireframe overlay is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WireMode {
    /// `POLYGON_MODE_LINE` where the device has it, else barycentric.
    Auto,
    /// Barycentric edges even where lines exist (to test the fallback).
    Barycentric,
}

impl Renderer {
    /// Pipelines for targets of `color_format` with a [`DEPTH_FORMAT`] depth buffer. The wireframe
    /// pipeline exists only where the device has `POLYGON_MODE_LINE`.
    pub fn new(device: &wgpu::Device, color_format: wgpu::TextureFormat) -> Renderer {
        Self::with_wire_mode(device, color_format, WireMode::Auto)
    }

    pub fn with_wire_mode(
        device: &wgpu::Device,
        color_format: wgpu::TextureFormat,
        wire_mode: WireMode,
    ) -> Renderer {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("mesh.wgsl"),
            source: wgpu::ShaderSource::Wgsl(MESH_WGSL.into()),
        });
        let bind_layout = globals_layout(device);
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("mesh"),
            bind_group_layouts: &[Some(&bind_layout)],
            immediate_size: 0,
        });
        let buffers = vertex_layouts().map(Some);
        let pipeline = |label: &str, fragment: &str, polygon_mode, bias: wgpu::DepthBiasState| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &buffers,
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    // Two-sided: trees merge across parts and the inputs are not all closed.
                    cull_mode: None,
                    polygon_mode,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::LessEqual),
                    stencil: Default::default(),
                    bias,
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some(fragment),
                    compilation_options: Default::default(),
                    targets: &[Some(color_format.into())],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let fill = pipeline(
            "fill",
            "fs_main",
            wgpu::PolygonMode::Fill,
            Default::default(),
        );
        // Lines drawn over their own surface need a slope-scaled bias towards the eye; a constant
        // one alone leaves them dashed (TOOLCHAIN.md).
        let lines = device
            .features()
            .contains(wgpu::Features::POLYGON_MODE_LINE)
            && wire_mode == WireMode::Auto;
        let wire = lines.then(|| {
            pipeline(
                "wire",
                "fs_wire",
                wgpu::PolygonMode::Line,
                wgpu::DepthBiasState {
                    constant: -2,
                    slope_scale: -1.0,
                    clamp: 0.0,
                },
            )
        });
        let barycentric =
            (!lines).then(|| barycentric_pipeline(device, color_format, &bind_layout));
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("globals"),
            size: std::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sampler = super::textures::sampler(device);
        let none = super::textures::placeholder(device);
        let bind_group = globals_bind_group(
            device,
            &bind_layout,
            &globals,
            &none,
            &sampler,
            &materials_buffer(device, &[]),
        );
        let timer = Timer::new(device);
        let chunk_bytes = device.limits().max_buffer_size.min(MAX_CHUNK_BYTES);
        Renderer {
            chunk_triangles: (chunk_bytes / 12).max(1),
            fill,
            wire,
            barycentric,
            globals,
            bind_layout,
            sampler,
            bind_group,
            model: None,
            timer,
        }
    }

    /// Splits the index buffer into chunks of at most this many triangles (tests use it to check
    /// that models larger than one buffer render). Call before [`Renderer::set_hierarchy`].
    pub fn set_chunk_triangles(&mut self, triangles: u64) {
        self.chunk_triangles = triangles.max(1);
    }

    /// How the wireframe overlay is drawn: "lines" or "barycentric".
    pub fn wireframe_kind(&self) -> &'static str {
        if self.wire.is_some() {
            "lines"
        } else {
            "barycentric"
        }
    }

    /// Uploads the model's per-node data (positions, normals, colours, errors and depths) and starts
    /// with an empty index buffer.
    pub fn set_hierarchy(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, h: &Hierarchy) {
        let vertex = |label: &str, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            })
        };
        let has_colors = !h.color.is_empty();
        let colors: Vec<[u8; 4]> = if has_colors {
            h.color.clone()
        } else {
            vec![[200, 194, 184, 255]; h.position.len()]
        };
        let mut depth = vec![0f32; h.position.len()];
        for u in h.top_down() {
            let p = h.parent[u as usize];
            if p != crate::refine::hierarchy::NIL {
                depth[u as usize] = depth[p as usize] + 1.0;
            }
        }
        let has_textures = !h.textures.is_empty() && !h.uv_texture.is_empty();
        let uv_texture: Vec<[f32; 4]> = if h.uv_texture.is_empty() {
            vec![[0.0, 0.0, -1.0, -1.0]; h.position.len()]
        } else {
            h.uv_texture.clone()
        };
        // Textures upload once per model; the bind group then points at them.
        let view = if has_textures {
            super::textures::upload(device, queue, &h.textures)
        } else {
            super::textures::placeholder(device)
        };
        let materials = materials_buffer(device, &h.materials);
        self.bind_group = globals_bind_group(
            device,
            &self.bind_layout,
            &self.globals,
            &view,
            &self.sampler,
            &materials,
        );
        let debug: Vec<Debug> = (0..h.node_count())
            .map(|u| Debug {
                error: h.drawn_error(u),
                depth: depth[u as usize],
            })
            .collect();
        // With wedges the vertices are wedges, each at its node (see `HierarchyWedges`).
        let (positions, normals, debug) = (
            expand(h, &h.position),
            h.wedges
                .as_ref()
                .map_or_else(|| h.normal.clone(), |w| w.normal.clone()),
            expand(h, &debug),
        );
        let tint = match &h.wedges {
            Some(w) if !w.tint.is_empty() => w.tint.clone(),
            _ => vec![[255u8; 4]; positions.len()],
        };
        let colors = if has_colors || h.wedges.is_none() {
            colors
        } else {
            vec![[200, 194, 184, 255]; positions.len()]
        };
        let model = Model {
            positions: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("positions"),
                contents: bytemuck::cast_slice(&positions),
                // Storage too: the barycentric wireframe pulls positions itself.
                usage: wgpu::BufferUsages::VERTEX
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::STORAGE,
            }),
            normals: vertex("normals", bytemuck::cast_slice(&normals)),
            colors: vertex("colors", bytemuck::cast_slice(&colors)),
            debug: vertex("debug", bytemuck::cast_slice(&debug)),
            uv_texture: vertex("uv_texture", bytemuck::cast_slice(&uv_texture)),
            tint: vertex("tint", bytemuck::cast_slice(&tint)),
            has_colors,
            has_textures,
            baked: has_colors && h.one_sided,
            one_sided: h.one_sided,
            indices: Indices::new(device, self.chunk_triangles),
            triangles: 0,
        };
        self.model = Some(model);
        queue.submit([]);
    }

    /// Writes what changed in the front since the last upload: its dirty index ranges and the
    /// geomorphing vertices. The index buffer grows geometrically when the front outgrows it.
    pub fn upload(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        h: &Hierarchy,
        front: &mut Front,
        vertex_updates: &[(u32, Vec3)],
    ) -> UploadStats {
        let model = self.model.as_mut().expect("set_hierarchy before upload");
        let mut stats = UploadStats::default();
        let dirty = front.take_dirty();
        let count = front.triangle_count();
        let mut scratch = Vec::new();
        // Plain trees draw the front's indices as they are; trees with wedges their corners'
        // wedges, found for the written ranges only.
        let reallocated = model.indices.ensure(device, count as u64);
        let indices = &mut model.indices;
        let mut write = |range: std::ops::Range<u32>| {
            let slice = match h.wedges {
                None => &front.indices()[range.start as usize..range.end as usize],
                Some(_) => {
                    scratch.clear();
                    front.vertices(h, range.clone(), &mut scratch);
                    &scratch[..]
                }
            };
            indices.write(queue, range.start as u64, slice);
            stats.bytes += slice.len() as u64 * 12;
        };
        if reallocated {
            write(0..count as u32);
        } else {
            for range in dirty {
                write(range);
            }
        }
        stats.reallocated = reallocated;
        model.triangles = count as u32;
        for &(u, p) in vertex_updates {
            let vertices = match &h.wedges {
                None => u..u + 1,
                Some(w) => w.start[u as usize]..w.start[u as usize + 1],
            };
            for v in vertices {
                queue.write_buffer(&model.positions, v as u64 * 12, bytemuck::bytes_of(&p));
                stats.bytes += 12;
            }
        }
        stats
    }

    /// Replaces the drawn triangles wholesale (a static mesh, e.g. the full-resolution reference).
    pub fn set_triangles(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        indices: &[[u32; 3]],
    ) {
        let model = self
            .model
            .as_mut()
            .expect("set_hierarchy before set_triangles");
        model.indices.ensure(device, indices.len() as u64);
        model.indices.write(queue, 0, indices);
        model.triangles = indices.len() as u32;
    }

    /// Triangles the next draw will draw.
    pub fn triangles(&self) -> u32 {
        self.model.as_ref().map_or(0, |m| m.triangles)
    }

    /// Records the frame: clears `color` and `depth`, draws the model as seen by `camera`.
    pub fn draw(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: Target<'_>,
        camera: &Camera,
        options: &DrawOptions,
    ) {
        let Target { color, depth } = target;
        let view = View::new(camera);
        let forward = camera.forward();
        // A headlight, raised and to the left, so that shapes read from any side.
        let light = (-forward + camera.orientation * Vec3::new(-0.4, 0.6, 0.0)).normalize();
        let has_colors = self.model.as_ref().is_some_and(|m| m.has_colors);
        let baked = self.model.as_ref().is_some_and(|m| m.baked);
        let textured = self.model.as_ref().is_some_and(|m| m.has_textures);
        let mode = match options.color_by {
            ColorBy::Auto if textured => 5,
            ColorBy::Auto if baked => 4,
            ColorBy::Auto if has_colors => 1,
            ColorBy::Auto | ColorBy::Shaded => 0,
            ColorBy::Depth => 2,
            ColorBy::Error => 3,
            ColorBy::Baked => 4,
            ColorBy::Texture => 5,
            ColorBy::Uv => 6,
        };
        let globals = Globals {
            clip_from_world: camera.clip_from_world().to_cols_array_2d(),
            eye: camera.position.extend(view.px_per_unit()).to_array(),
            light: light.extend(0.25).to_array(),
            params: [options.tolerance_px, camera.near, 0.0, 0.0],
            modes: [
                mode,
                options.flat as u32,
                0,
                self.model.as_ref().is_some_and(|m| m.one_sided) as u32,
            ],
            wire_color: [0.02, 0.02, 0.02, 1.0],
        };
        queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));
        let [r, g, b, a] = options.background;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("mesh"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: color,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: if options.clear {
                        wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a })
                    } else {
                        wgpu::LoadOp::Load
                    },
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations {
                    load: if options.clear {
                        wgpu::LoadOp::Clear(1.0)
                    } else {
                        wgpu::LoadOp::Load
                    },
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: self
                .timer
                .as_ref()
                .map(|t| wgpu::RenderPassTimestampWrites {
                    query_set: &t.queries,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let Some(model) = self.model.as_ref().filter(|m| m.triangles > 0) else {
            return;
        };
        if let Some([x, y, w, h]) = options.viewport {
            pass.set_viewport(x, y, w, h, 0.0, 1.0);
            pass.set_scissor_rect(x as u32, y as u32, w as u32, h as u32);
        }
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, model.positions.slice(..));
        pass.set_vertex_buffer(1, model.normals.slice(..));
        pass.set_vertex_buffer(2, model.colors.slice(..));
        pass.set_vertex_buffer(3, model.debug.slice(..));
        pass.set_vertex_buffer(4, model.uv_texture.slice(..));
        pass.set_vertex_buffer(5, model.tint.slice(..));
        pass.set_pipeline(&self.fill);
        model.indices.draw(&mut pass, model.triangles as u64);
        if options.wireframe {
            if let Some(wire) = &self.wire {
                pass.set_pipeline(wire);
                model.indices.draw(&mut pass, model.triangles as u64);
            } else if let Some((pipeline, layout)) = &self.barycentric {
                pass.set_pipeline(pipeline);
                let triangles = model.triangles as u64;
                for (i, chunk) in model.indices.chunks.iter().enumerate() {
                    let first = i as u64 * model.indices.chunk;
                    if first >= triangles {
                        break;
                    }
                    let n = (triangles - first).min(model.indices.chunk) as u32;
                    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("barycentric wireframe"),
                        layout,
                        entries: &[
                            wgpu::BindGroupEntry {
                                binding: 0,
                                resource: model.positions.as_entire_binding(),
                            },
                            wgpu::BindGroupEntry {
                                binding: 1,
                                resource: chunk.as_entire_binding(),
                            },
                        ],
                    });
                    pass.set_bind_group(1, &group, &[]);
                    pass.draw(0..n * 3, 0..1);
                }
            }
        }
    }

    /// After [`Renderer::draw`]'s commands: copies the frame's timestamps out (call before submit).
    pub fn resolve_timing(&self, encoder: &mut wgpu::CommandEncoder) {
        if let Some(t) = &self.timer {
            encoder.resolve_query_set(&t.queries, 0..2, &t.resolve, 0);
            encoder.copy_buffer_to_buffer(&t.resolve, 0, &t.readback, 0, 16);
        }
    }

    /// GPU milliseconds of the last submitted frame (waits for it); `None` without timestamps.
    pub fn read_gpu_ms(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) -> Option<f64> {
        let t = self.timer.as_mut()?;
        t.period_ns = queue.get_timestamp_period();
        let slice = t.readback.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        device.poll(wgpu::PollType::wait_indefinitely()).ok()?;
        let ms = {
            let data = slice.get_mapped_range().ok()?;
            let ticks: &[u64] = bytemuck::cast_slice(&data);
            ticks[1].saturating_sub(ticks[0]) as f64 * t.period_ns as f64 / 1e6
        };
        t.readback.unmap();
        Some(ms)
    }
}

/// The index buffer, in chunks of at most `chunk` triangles: a front larger than one buffer may be
/// (the device's `max_buffer_size`, and at most 128 MiB, lavapipe's largest storage binding, so that
/// no chunk is ever near a limit) is drawn chunk by chunk.
struct Indices {
    chunks: Vec<wgpu::Buffer>,
    chunk: u64,
    capacity: u64,
}

impl Indices {
    fn new(device: &wgpu::Device, chunk: u64) -> Indices {
        let first = MIN_TRIANGLES.min(chunk);
        Indices {
            chunks: vec![index_buffer(device, first)],
            chunk,
            capacity: first,
        }
    }

    /// Makes room for `needed` triangles, growing geometrically; returns whether the buffers were
    /// replaced (their contents are then undefined: write them all).
    fn ensure(&mut self, device: &wgpu::Device, needed: u64) -> bool {
        if needed <= self.capacity {
            return false;
        }
        let capacity = ((self.capacity as f64 * GROWTH) as u64).max(needed);
        self.chunks = (0..capacity.div_ceil(self.chunk))
            .map(|i| index_buffer(device, (capacity - i * self.chunk).min(self.chunk)))
            .collect();
        self.capacity = capacity;
        true
    }

    /// Writes triangles from slot `start` on, across chunk boundaries.
    fn write(&self, queue: &wgpu::Queue, start: u64, triangles: &[[u32; 3]]) {
        let mut slot = start;
        let mut rest = triangles;
        while !rest.is_empty() {
            let (chunk, offset) = ((slot / self.chunk) as usize, slot % self.chunk);
            let n = ((self.chunk - offset) as usize).min(rest.len());
            queue.write_buffer(
                &self.chunks[chunk],
                offset * 12,
                bytemuck::cast_slice(&rest[..n]),
            );
            rest = &rest[n..];
            slot += n as u64;
        }
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, triangles: u64) {
        for (i, buffer) in self.chunks.iter().enumerate() {
            let first = i as u64 * self.chunk;
            if first >= triangles {
                break;
            }
            let n = (triangles - first).min(self.chunk) as u32;
            pass.set_index_buffer(buffer.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..n * 3, 0, 0..1);
        }
    }
}

fn index_buffer(device: &wgpu::Device, triangles: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("indices"),
        size: triangles.max(1) * 12,
        usage: wgpu::BufferUsages::INDEX
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    })
}

fn barycentric_pipeline(
    device: &wgpu::Device,
    color_format: wgpu::TextureFormat,
    globals: &wgpu::BindGroupLayout,
) -> (wgpu::RenderPipeline, wgpu::BindGroupLayout) {
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("wire_barycentric.wgsl"),
        source: wgpu::ShaderSource::Wgsl(WIRE_BARYCENTRIC_WGSL.into()),
    });
    let storage = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let pulled = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("barycentric wireframe"),
        entries: &[storage(0), storage(1)],
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("barycentric wireframe"),
        bind_group_layouts: &[Some(globals), Some(&pulled)],
        immediate_size: 0,
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("barycentric wireframe"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &shader,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(wgpu::CompareFunction::LessEqual),
            stencil: Default::default(),
            bias: wgpu::DepthBiasState {
                constant: -2,
                slope_scale: -1.0,
                clamp: 0.0,
            },
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &shader,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: color_format,
                blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    });
    (pipeline, pulled)
}

impl Timer {
    /// Timestamp queries around the render pass, where the device has them.
    fn new(device: &wgpu::Device) -> Option<Timer> {
        device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| Timer {
                queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("frame time"),
                    ty: wgpu::QueryType::Timestamp,
                    count: 2,
                }),
                resolve: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamps"),
                    size: 16,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                readback: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamps readback"),
                    size: 16,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                period_ns: 1.0,
            })
    }
}

/// The mesh pass's bind group: the globals, the model's texture array and the sampler.
fn globals_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    globals: &wgpu::Buffer,
    textures: &wgpu::TextureView,
    sampler: &wgpu::Sampler,
    materials: &wgpu::Buffer,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("globals"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(textures),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::Sampler(sampler),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: materials.as_entire_binding(),
            },
        ],
    })
}

/// A material as the mesh pass reads it (`Material` in mesh.wgsl).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuMaterial {
    /// Base colour factor, linear RGBA.
    factor: [f32; 4],
    /// Alpha mode (0 opaque, 1 mask, 2 blend), mask cutoff, double-sided (1) or not (0), unused.
    alpha: [f32; 4],
}

/// The materials' storage buffer (one opaque white material for a model without any: the pass
/// binds one either way).
fn materials_buffer(device: &wgpu::Device, materials: &[crate::mesh::Material]) -> wgpu::Buffer {
    use crate::mesh::AlphaMode;
    let mut gpu: Vec<GpuMaterial> = materials
        .iter()
        .map(|m| GpuMaterial {
            factor: m.base_color_factor,
            alpha: [
                match m.alpha_mode {
                    AlphaMode::Opaque => 0.0,
                    AlphaMode::Mask => 1.0,
                    AlphaMode::Blend => 2.0,
                },
                m.alpha_cutoff,
                if m.double_sided { 1.0 } else { 0.0 },
                0.0,
            ],
        })
        .collect();
    if gpu.is_empty() {
        gpu.push(GpuMaterial {
            factor: [1.0; 4],
            alpha: [0.0, 0.0, 1.0, 0.0],
        });
    }
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("materials"),
        contents: bytemuck::cast_slice(&gpu),
        usage: wgpu::BufferUsages::STORAGE,
    })
}

/// The mesh pass's bind group layout: the globals (0), the texture array (1), its sampler (2) and
/// the materials (3).
fn globals_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("globals"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 3,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
        ],
    })
}

/// Per-node values as per-vertex ones: the same for a plain tree, each wedge's node's with wedges.
fn expand<T: Copy>(h: &Hierarchy, per_node: &[T]) -> Vec<T> {
    match &h.wedges {
        None => per_node.to_vec(),
        Some(w) => w.node.iter().map(|&u| per_node[u as usize]).collect(),
    }
}

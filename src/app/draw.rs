//! Drawing a frame into the window or offscreen: the 3D view, the compare view's quadrants, the
//! frozen frustum, the UI.

use super::*;

pub(super) fn present_mode(vsync: bool) -> wgpu::PresentMode {
    // TOOLCHAIN.md: get_default_config picks Immediate on Xvfb; choose explicitly.
    if vsync {
        wgpu::PresentMode::AutoVsync
    } else {
        wgpu::PresentMode::AutoNoVsync
    }
}

pub(super) fn depth_view(device: &wgpu::Device, size: [u32; 2]) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("window depth"),
            size: wgpu::Extent3d {
                width: size[0].max(1),
                height: size[1].max(1),
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: crate::render::renderer::DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        })
        .create_view(&Default::default())
}

/// The 3D view (or the compare view's quadrants), the frozen frustum, then the UI, into the views.
#[allow(clippy::too_many_arguments)]
pub(super) fn draw_frame(
    gpu: &Gpu,
    egui_renderer: &mut egui_wgpu::Renderer,
    view: &ViewState,
    settings: &ViewerSettings,
    camera: &Camera,
    scene_view: &wgpu::TextureView,
    ui_view: &wgpu::TextureView,
    depth: &wgpu::TextureView,
    paint_jobs: &[egui::ClippedPrimitive],
    screen: &egui_wgpu::ScreenDescriptor,
) {
    let (device, queue) = (&gpu.device, &gpu.queue);
    let mut encoder = device.create_command_encoder(&Default::default());
    let [x0, w] = [view.scene_x, view.size[0]];
    let h = screen.size_in_pixels[1];
    let draw = DrawOptions {
        color_by: settings.color_by,
        flat: settings.flat,
        wireframe: settings.wireframe,
        tolerance_px: settings.tolerance_px,
        viewport: Some([x0 as f32, 0.0, w.max(1) as f32, h.max(1) as f32]),
        ..Default::default()
    };
    match (&view.compare, &view.model) {
        (Some(compare), _) => {
            // Clear once, then each ready method into its quadrant.
            let mut cleared = false;
            for (i, slot) in compare.slots.iter().enumerate() {
                let ([x, y], [qw, qh]) = compare.cell(i, w, h);
                let x = x0 + x;
                if let Some(ready) = &slot.ready {
                    let mut cam = *camera;
                    cam.viewport_px = [qw.max(1), qh.max(1)];
                    let options = DrawOptions {
                        viewport: Some([x as f32, y as f32, qw.max(1) as f32, qh.max(1) as f32]),
                        clear: !cleared,
                        ..draw
                    };
                    ready.renderer.draw(
                        device,
                        queue,
                        &mut encoder,
                        Target {
                            color: scene_view,
                            depth,
                        },
                        &cam,
                        &options,
                    );
                    // Each renderer has its own uniform buffer, but writes land at submit: submit
                    // per quadrant.
                    queue.submit([std::mem::replace(
                        &mut encoder,
                        device.create_command_encoder(&Default::default()),
                    )
                    .finish()]);
                    cleared = true;
                }
            }
            if !cleared {
                clear(&mut encoder, scene_view, depth);
            }
        }
        (None, Some(m)) => m.renderer.draw(
            device,
            queue,
            &mut encoder,
            Target {
                color: scene_view,
                depth,
            },
            camera,
            &draw,
        ),
        (None, None) => clear(&mut encoder, scene_view, depth),
    }
    // egui's buffers, then its pass over the 3D image.
    let egui_buffers =
        egui_renderer.update_buffers(device, queue, &mut encoder, paint_jobs, screen);
    {
        let mut ui_pass =
            pass(&mut encoder, "egui", ui_view, wgpu::LoadOp::Load, None).forget_lifetime();
        egui_renderer.render(&mut ui_pass, paint_jobs, screen);
    }
    queue.submit(egui_buffers.into_iter().chain([encoder.finish()]));
}

pub(super) fn clear(
    encoder: &mut wgpu::CommandEncoder,
    color: &wgpu::TextureView,
    depth: &wgpu::TextureView,
) {
    let [r, g, b, a] = DrawOptions::default().background;
    pass(
        encoder,
        "clear",
        color,
        wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a }),
        Some(depth),
    );
}

/// A render pass over `color` (loaded or cleared) and, when given, a cleared depth buffer.
pub(super) fn pass<'a>(
    encoder: &'a mut wgpu::CommandEncoder,
    label: &str,
    color: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
    depth: Option<&wgpu::TextureView>,
) -> wgpu::RenderPass<'a> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: color,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load,
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: depth.map(|view| wgpu::RenderPassDepthStencilAttachment {
            view,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// The frame as the window shows it (3D and UI), rendered again offscreen and read back.
pub(super) fn screenshot(
    gfx: &mut Gfx,
    view: &ViewState,
    settings: &ViewerSettings,
    camera: &Camera,
    paint_jobs: &[egui::ClippedPrimitive],
    screen: &egui_wgpu::ScreenDescriptor,
) -> anyhow::Result<image::RgbaImage> {
    let device = gfx.gpu.device.clone();
    let [w, h] = screen.size_in_pixels;
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("screenshot"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: gfx.ui_format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[gfx.scene_format],
    });
    let scene_view = texture.create_view(&wgpu::TextureViewDescriptor {
        format: Some(gfx.scene_format),
        ..Default::default()
    });
    let ui_view = texture.create_view(&Default::default());
    let depth = depth_view(&device, [w, h]);
    draw_frame(
        &gfx.gpu,
        &mut gfx.egui_renderer,
        view,
        settings,
        camera,
        &scene_view,
        &ui_view,
        &depth,
        paint_jobs,
        screen,
    );
    Ok(read_texture(&gfx.gpu.device, &gfx.gpu.queue, &texture)?)
}

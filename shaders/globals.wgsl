// The uniforms every pass shares; prepended to each shader by `vunify::render::renderer`
// (WGSL has no includes). Mirrors `vunify::render::gpu_data::Globals` (size asserted there).

struct Globals {
    clip_from_world: mat4x4<f32>,
    // xyz: the eye; w: pixels per unit of length at distance 1 (height / (2 tan(fov / 2))).
    eye: vec4<f32>,
    // xyz: direction towards the light (world); w: ambient share.
    light: vec4<f32>,
    // x: τ in pixels (debug error colouring); y: near plane; zw: unused.
    params: vec4<f32>,
    // x: colour mode (0 shaded, 1 vertex colours, 2 tree depth, 3 projected error, 4 baked,
    // 5 base colour texture, 6 UV checker);
    // y: flat shading (1) or smooth (0); z: 1 for the wireframe pass; w: 1 for a one-sided model,
    // whose back faces are not drawn.
    modes: vec4<u32>,
    wire_color: vec4<f32>,
}

@group(0) @binding(0) var<uniform> g: Globals;

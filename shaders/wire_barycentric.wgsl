// Wireframe without line polygons (adapters lacking POLYGON_MODE_LINE): vertex pulling from the index
// and position buffers, so that each triangle corner gets its own barycentric coordinate, and edges
// drawn where one coordinate is near zero, about a pixel wide, blended over the filled surface.
// `Globals` and `g` come from globals.wgsl, prepended when the shader is built.


// Node positions, three floats each (a vec3 array would be padded to 16 bytes).
@group(1) @binding(0) var<storage, read> positions: array<f32>;
// One chunk of the index buffer: three node ids per triangle.
@group(1) @binding(1) var<storage, read> indices: array<u32>;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) barycentric: vec3<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VertexOut {
    let node = indices[i];
    let p = vec3<f32>(positions[3u * node], positions[3u * node + 1u], positions[3u * node + 2u]);
    var out: VertexOut;
    out.clip = g.clip_from_world * vec4<f32>(p, 1.0);
    let corner = i % 3u;
    out.barycentric = vec3<f32>(f32(corner == 0u), f32(corner == 1u), f32(corner == 2u));
    return out;
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    if (g.modes.w == 1u && !front) {
        discard;
    }
    // Distance to the nearest edge in pixels, from the barycentric's screen-space rate of change.
    let d = in.barycentric / max(fwidth(in.barycentric), vec3<f32>(1e-6));
    let edge = 1.0 - smoothstep(0.5, 1.5, min(d.x, min(d.y, d.z)));
    if (edge <= 0.0) {
        discard;
    }
    return vec4<f32>(g.wire_color.rgb, edge);
}

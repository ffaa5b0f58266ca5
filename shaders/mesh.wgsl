// The mesh pass: one vertex per tree node (position, octahedral normal, colour, and the node's
// object-space error and depth for debug colouring); lit shading, vertex colours, or a debug colouring.
// `Globals` and `g` come from globals.wgsl, prepended when the shader is built.



// Base colour textures, a layer each (`vunify::render::textures`), and their sampler.
@group(0) @binding(1) var textures: texture_2d_array<f32>;
@group(0) @binding(2) var texture_sampler: sampler;

// The model's materials (`GpuMaterial` in renderer.rs): base colour factor; alpha mode (0 opaque,
// 1 mask, 2 blend), mask cutoff and double-sided (1) or not (0).
struct Material {
    factor: vec4<f32>,
    alpha: vec4<f32>,
}
@group(0) @binding(3) var<storage, read> materials: array<Material>;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec2<f32>,   // snorm16x2, octahedral; (-1, -1) exactly: unknown
    @location(2) color: vec4<f32>,    // unorm8x4
    @location(3) debug: vec2<f32>,    // (object-space error, depth)
    @location(4) uv_texture: vec4<f32>, // texture coordinates, the texture's layer and the material (-1: none)
    @location(5) tint: vec4<f32>,     // unorm8x4: what the texture is multiplied by (glTF COLOR_0)
}

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    @location(3) uv: vec2<f32>,
    // One texture a triangle: the provoking vertex's (a triangle's corners share one but where a
    // coarse node joins two).
    @location(4) @interpolate(flat) layer: i32,
    @location(5) @interpolate(flat) material: i32,
    @location(6) tint: vec3<f32>,
}

// A 4 × 4 ordered-dither threshold at a pixel: blended surfaces are drawn as a screen door (as
// much of each pixel block as their alpha), which needs no sorting of the triangles.
fn dither(pixel: vec2<f32>) -> f32 {
    var bayer = array<f32, 16>(0.0, 8.0, 2.0, 10.0, 12.0, 4.0, 14.0, 6.0, 3.0, 11.0, 1.0, 9.0, 15.0, 7.0, 13.0, 5.0);
    let i = (u32(pixel.y) % 4u) * 4u + u32(pixel.x) % 4u;
    return (bayer[i] + 0.5) / 16.0;
}

fn decode_octahedral(e: vec2<f32>) -> vec3<f32> {
    if (e.x <= -1.0 && e.y <= -1.0) {
        return vec3<f32>(0.0);
    }
    var v = vec3<f32>(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    let t = max(-v.z, 0.0);
    v.x = v.x - t * sign(v.x);
    v.y = v.y - t * sign(v.y);
    return normalize(v);
}

// A small perceptual ramp for debug colours: 0 → blue, 0.5 → green, 1 → red.
fn ramp(x: f32) -> vec3<f32> {
    let t = clamp(x, 0.0, 1.0);
    return clamp(vec3<f32>(2.0 * t - 0.5, 1.5 - abs(2.0 * t - 1.0) * 1.5, 1.0 - 2.0 * t), vec3<f32>(0.0), vec3<f32>(1.0));
}

// Distinct hues for tree depths, repeating every 8 levels.
fn depth_color(d: f32) -> vec3<f32> {
    let h = fract(d * 0.381966);
    let k = vec3<f32>(0.0, 2.0 / 3.0, 1.0 / 3.0);
    return clamp(abs(fract(vec3<f32>(h) + k) * 6.0 - 3.0) - 1.0, vec3<f32>(0.0), vec3<f32>(1.0)) * 0.75 + 0.2;
}

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let low = c / 12.92;
    let high = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(high, low, c <= vec3<f32>(0.04045));
}

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.clip = g.clip_from_world * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = decode_octahedral(v.normal);
    out.uv = v.uv_texture.xy;
    out.layer = i32(round(v.uv_texture.z));
    out.material = i32(round(v.uv_texture.w));
    out.tint = v.tint.rgb;
    switch g.modes.x {
        case 1u: { out.color = vec4<f32>(v.color.rgb, 1.0); }
        // Baked: 8-bit display colours are sRGB-encoded; decoded here, the sRGB target re-encodes
        // them, so they reach the screen as stored.
        case 4u: { out.color = vec4<f32>(srgb_to_linear(v.color.rgb), 1.0); }
        case 2u: { out.color = vec4<f32>(depth_color(v.debug.y), 1.0); }
        case 3u: {
            let d = max(distance(v.position, g.eye.xyz), g.params.y);
            let px = v.debug.x * g.eye.w / d;
            out.color = vec4<f32>(ramp(px / (2.0 * g.params.x)), 1.0);
        }
        // Texture and UV checker: the vertex colour stands where there is no texture.
        case 5u, 6u: { out.color = vec4<f32>(v.color.rgb, 1.0); }
        default: { out.color = vec4<f32>(0.78, 0.76, 0.72, 1.0); }
    }
    return out;
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    if (g.modes.w == 1u && !front) {
        discard;
    }
    if (g.modes.x == 4u) {
        return vec4<f32>(in.color.rgb, 1.0);
    }
    var base = in.color.rgb;
    if (g.modes.x == 5u) {
        // A branch on a uniform keeps control flow uniform, as the mip level's derivatives need;
        // the other modes pay nothing for the texture.
        let texel = textureSample(textures, texture_sampler, in.uv, max(in.layer, 0));
        var alpha = 1.0;
        if (in.layer >= 0) {
            base = texel.rgb * in.tint;
            alpha = texel.a;
        }
        // The material: its factor times the texture (an untextured vertex's colour has it
        // already), and its alpha mode.
        if (in.material >= 0) {
            let m = materials[in.material];
            if (in.layer >= 0) {
                base = base * m.factor.rgb;
            }
            alpha = alpha * m.factor.a;
            if ((m.alpha.x == 1.0 && alpha < m.alpha.y) || (m.alpha.x == 2.0 && alpha < dither(in.clip.xy))) {
                discard;
            }
            // glTF: a material that is not double-sided shows its front faces only.
            if (m.alpha.z == 0.0 && !front) {
                discard;
            }
        }
    } else if (g.modes.x == 6u) {
        let cell = floor(in.uv * 8.0);
        let odd = (i32(cell.x) + i32(cell.y)) & 1;
        base = select(vec3<f32>(0.9, 0.9, 0.85), vec3<f32>(0.15, 0.25, 0.6), odd == 1);
    }
    var n = in.normal;
    if (g.modes.y == 1u || dot(n, n) < 0.5) {
        // Flat: the face normal from screen-space derivatives (also where a vertex has no normal).
        n = normalize(cross(dpdx(in.world), dpdy(in.world)));
    }
    // Two-sided: open and inward-wound models are lit from whichever side is seen.
    let to_eye = normalize(g.eye.xyz - in.world);
    if (dot(n, to_eye) < 0.0) {
        n = -n;
    }
    let diffuse = max(dot(n, normalize(g.light.xyz)), 0.0);
    let shade = g.light.w + (1.0 - g.light.w) * diffuse;
    return vec4<f32>(base * shade, 1.0);
}

@fragment
fn fs_wire(in: VertexOut) -> @location(0) vec4<f32> {
    return g.wire_color;
}

//! glTF 2.0 input (`.gltf` with its `.bin` and images, data URIs, or one `.glb`): the default
//! scene's node graph flattened into one triangle mesh, a part per primitive.
//!
//! The `gltf` crate parses the JSON and the GLB container and resolves buffers; accessors are read
//! here, because the crate's typed readers take only the float types of the core specification,
//! while `KHR_mesh_quantization` (what meshoptimizer's `gltfpack` writes by default) stores positions,
//! normals and texture coordinates as normalized or plain integers. Every read is checked against its
//! buffer view and buffer, and an error names the accessor.
//!
//! Appearance: each vertex keeps its base colour texture and texture coordinates (through
//! `KHR_texture_transform`), which the tree carries and the renderer draws; and a colour, its
//! material's base colour factor × `COLOR_0` × the texture's mean around it ([`bake`]), which the
//! builder weighs (docs/APPEARANCE.md).

use super::error::InputError;
use super::{AlphaMode, Material, Mesh, NO_TEXTURE, Part};
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use std::path::Path;

/// The largest image the reader decodes, in pixels: a texture past it is left out with a note
/// (a 16k × 16k texture is 1 GiB as RGBA).
const MAX_IMAGE_PIXELS: u64 = 1 << 26;

/// The most elements an accessor without a buffer view (all zeros but its sparse values) may
/// declare: its size is otherwise bounded by nothing in the file.
const MAX_VIEWLESS_ELEMENTS: usize = 1 << 24;

/// A glTF file read: the mesh (not yet cleaned), and notes on what was left out or replaced.
pub struct Read {
    pub mesh: Mesh,
    pub notes: Vec<String>,
}

/// Reads `bytes`, a `.gltf` or `.glb` file at `path` (external buffers and images are resolved
/// beside it).
pub fn parse(bytes: &[u8], path: &Path) -> Result<Read, InputError> {
    let err = |m: String| InputError::whole(path, m);
    let (document, blob) =
        document(bytes).map_err(|e| err(format!("not a valid glTF file: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(&document, blob, base, path)?;
    let mut notes = Vec::new();
    let images = load_images(&document, &buffers, base, &mut notes);
    let mut reader = Reader {
        path,
        base,
        buffers: &buffers,
        images: &images,
        mesh: Mesh::default(),
        colors: Vec::new(),
        tints: Vec::new(),
        uvs: Vec::new(),
        texture_of: Vec::new(),
        texture_index: Default::default(),
        material_index: Default::default(),
        material_of: Vec::new(),
        notes,
    };
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    match scene {
        Some(scene) => {
            for node in scene.nodes() {
                reader.node(&node, Mat4::IDENTITY, 0)?;
            }
        }
        // No scene: every mesh once, untransformed (the specification allows a file of meshes alone).
        None => {
            for mesh in document.meshes() {
                reader.mesh(&mesh, Mat4::IDENTITY)?;
            }
        }
    }
    let Reader {
        mut mesh,
        colors,
        tints,
        uvs,
        texture_of,
        material_of,
        notes,
        ..
    } = reader;
    mesh.material_of = Some(material_of);
    if !mesh.textures.is_empty() {
        mesh.uvs = Some(uvs);
        mesh.texture_of = Some(texture_of);
    }
    if colors.iter().any(|&c| c != Vec3::ONE) {
        mesh.colors = Some(colors);
    }
    if !mesh.textures.is_empty() && tints.iter().any(|&c| c != Vec3::ONE) {
        mesh.tints = Some(tints);
    }
    if mesh.triangles.is_empty() {
        return Err(err(if notes.is_empty() {
            "the scene has no triangles".into()
        } else {
            format!("the scene has no triangles ({})", notes.join("; "))
        }));
    }
    Ok(Read { mesh, notes })
}

/// Extensions a file may require that this reader handles itself (the `gltf` crate refuses files
/// that require ones it does not know).
const HANDLED_HERE: &[&str] = &["KHR_mesh_quantization"];

/// The validated document and the GLB's binary chunk, if any.
fn document(bytes: &[u8]) -> Result<(gltf::Document, Option<Vec<u8>>), String> {
    let (json, blob) = if bytes.starts_with(b"glTF") {
        split_glb(bytes)?
    } else {
        (bytes.to_vec(), None)
    };
    let mut value: serde_json::Value = serde_json::from_slice(&json).map_err(|e| e.to_string())?;
    if let Some(required) = value
        .get_mut("extensionsRequired")
        .and_then(|r| r.as_array_mut())
    {
        required.retain(|e| !e.as_str().is_some_and(|e| HANDLED_HERE.contains(&e)));
    }
    let root: gltf::json::Root = serde_json::from_value(value).map_err(|e| e.to_string())?;
    // The crate's validation indexes some lists unchecked (a primitive of an empty `meshes`
    // list: `tests/fuzz_inputs/gltf-crash-43cf39d9.glb`): its panic is this file's error.
    let validated = std::panic::catch_unwind(|| gltf::Document::from_json(root))
        .map_err(|_| "its references do not hold together (the gltf crate's validation failed)")?;
    let document = validated.map_err(|e| e.to_string())?;
    Ok((document, blob))
}

/// A GLB container's JSON chunk and binary chunk. Read here rather than by the crate, whose reader
/// overflowed on a truncated chunk (found by fuzzing).
fn split_glb(bytes: &[u8]) -> Result<(Vec<u8>, Option<Vec<u8>>), String> {
    let word = |at: usize| -> Option<usize> {
        let b = bytes.get(at..at + 4)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let (version, length) = word(4).zip(word(8)).ok_or("a GLB header is 12 bytes")?;
    if version != 2 {
        return Err(format!("GLB version {version}: vunify reads version 2"));
    }
    if length > bytes.len() {
        return Err(format!(
            "the GLB header says {length} bytes, the file has {}",
            bytes.len()
        ));
    }
    let (mut json, mut bin) = (None, None);
    let mut at = 12;
    while at + 8 <= length {
        let (size, kind) = (word(at).unwrap_or(0), word(at + 4).unwrap_or(0));
        let start = at + 8;
        let end = start
            .checked_add(size)
            .filter(|&e| e <= length)
            .ok_or_else(|| format!("the chunk at byte {at} runs past the end of the GLB"))?;
        match &(kind as u32).to_le_bytes() {
            b"JSON" if json.is_none() => json = Some(bytes[start..end].to_vec()),
            b"BIN\0" if bin.is_none() => bin = Some(bytes[start..end].to_vec()),
            _ => {}
        }
        at = end;
    }
    Ok((json.ok_or("the GLB has no JSON chunk")?, bin))
}

/// Every buffer's bytes: the GLB's binary chunk, a data URI, or a file beside the glTF.
fn load_buffers(
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
    base: &Path,
    path: &Path,
) -> Result<Vec<Vec<u8>>, InputError> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let what = format!("buffer {}", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                InputError::whole(
                    path,
                    format!("{what} is the GLB's binary chunk, which is missing"),
                )
            })?,
            gltf::buffer::Source::Uri(uri) => read_uri(uri, base)
                .map_err(|e| InputError::whole(path, format!("{what} ({uri}): {e}")))?,
        };
        if data.len() < buffer.length() {
            return Err(InputError::whole(
                path,
                format!(
                    "{what} holds {} bytes, fewer than the {} the file declares",
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// The bytes of a URI: a base64 data URI, or a (percent-encoded) path relative to `base`.
fn read_uri(uri: &str, base: &Path) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest
            .split_once(";base64,")
            .ok_or("a data URI that is not base64")?;
        return base64_decode(data);
    }
    let name = urlencoding::decode(uri).map_err(|e| format!("a malformed URI: {e}"))?;
    let file = base.join(&*name);
    std::fs::read(&file).map_err(|e| format!("cannot read {}: {e}", file.display()))
}

/// Standard base64 (RFC 4648, `=` padding optional): written here for the one use, data URIs.
fn base64_decode(text: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let (mut acc, mut bits) = (0u32, 0u32);
    for (i, c) in text.bytes().enumerate() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => break,
            b' ' | b'\n' | b'\r' | b'\t' => continue,
            _ => return Err(format!("a data URI with a byte that is not base64 at {i}")),
        };
        acc = acc << 6 | v as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    Ok(out)
}

/// A decoded base colour texture: sRGB bytes, row by row (decoded to linear when sampled).
pub(super) struct Image {
    /// The image file's bytes, as the tree keeps them.
    pub(super) file: std::sync::Arc<Vec<u8>>,
    width: u32,
    height: u32,
    rgb: Vec<[u8; 3]>,
    /// sRGB byte to linear value.
    linear: [f32; 256],
}

impl Image {
    /// Bilinear sample at texture coordinate `uv` with repeat wrapping (glTF's default sampler).
    fn sample(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as f32, self.height as f32);
        let x = uv.x.rem_euclid(1.0) * w - 0.5;
        let y = uv.y.rem_euclid(1.0) * h - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |i: f32, j: f32| {
            let i = (i as i64).rem_euclid(self.width as i64) as usize;
            let j = (j as i64).rem_euclid(self.height as i64) as usize;
            Vec3::from_array(self.rgb[j * self.width as usize + i].map(|c| self.linear[c as usize]))
        };
        let top = at(x0, y0).lerp(at(x0 + 1.0, y0), fx);
        let bottom = at(x0, y0 + 1.0).lerp(at(x0 + 1.0, y0 + 1.0), fx);
        top.lerp(bottom, fy)
    }
}

/// Every image, decoded; `None` (with a note) where one is missing, unreadable or absurdly large:
/// its materials fall back to their factors.
fn load_images(
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    base: &Path,
    notes: &mut Vec<String>,
) -> Vec<Option<Image>> {
    // Only base colour textures are read: normal, occlusion and other maps are not drawn yet.
    let used: std::collections::HashSet<usize> = document
        .materials()
        .filter_map(|m| m.pbr_metallic_roughness().base_color_texture())
        .map(|t| t.texture().source().index())
        .collect();
    document
        .images()
        .map(|image| {
            if !used.contains(&image.index()) {
                return None;
            }
            let what = format!("image {}", image.index());
            let decoded = image_file(&image, buffers, base).and_then(|b| decode_image(&b));
            match decoded {
                Ok(i) => Some(i),
                Err(e) => {
                    notes.push(format!(
                        "{what} left out ({e}): its materials use their colour factors"
                    ));
                    None
                }
            }
        })
        .collect()
}

/// An image's file: its URI's or its buffer view's bytes.
fn image_file(image: &gltf::Image, buffers: &[Vec<u8>], base: &Path) -> Result<Vec<u8>, String> {
    match image.source() {
        gltf::image::Source::Uri { uri, .. } => read_uri(uri, base),
        gltf::image::Source::View { view, .. } => {
            let data = &buffers[view.buffer().index()];
            data.get(view.offset()..view.offset() + view.length())
                .map(<[u8]>::to_vec)
                .ok_or_else(|| format!("buffer view {} runs past its buffer", view.index()))
        }
    }
}

/// A map carried through (normal, metallic-roughness, occlusion, emissive): its file, checked for
/// a sane size but not decoded.
fn carried_image(image: &gltf::Image, buffers: &[Vec<u8>], base: &Path) -> Result<Vec<u8>, String> {
    let bytes = image_file(image, buffers, base)?;
    let reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    let (w, h) = reader.into_dimensions().map_err(|e| e.to_string())?;
    if w == 0 || h == 0 || w as u64 * h as u64 > MAX_IMAGE_PIXELS {
        return Err(format!("{w} × {h} pixels"));
    }
    Ok(bytes)
}

/// A triangle whose texture footprint is smaller than this many texels is sampled once, at its
/// centroid: a bilinear sample there already averages the four texels around it.
const SMALL_FOOTPRINT: f32 = 2.0;

/// Each vertex's colour from a texture: the area-weighted mean, over the triangles around it, of
/// the texture's mean over each triangle's UV footprint (15 samples a triangle, one for a footprint
/// under [`SMALL_FOOTPRINT`] texels). Sampling at the
/// vertex alone reads whatever lies under its UV, often a chart's border (the Deccer cubes'
/// corners are white on blue faces); the mean is what a coarse level of the triangle shows.
pub(super) fn bake(
    image: &Image,
    positions: &[[f32; 3]],
    uvs: &[Vec2],
    tris: &[[u32; 3]],
) -> Vec<Vec3> {
    const STEPS: u32 = 4;
    let samples: Vec<[f32; 3]> = (0..=STEPS)
        .flat_map(|i| {
            (0..=STEPS - i).map(move |j| {
                let (a, b) = (i as f32 / STEPS as f32, j as f32 / STEPS as f32);
                [a, b, 1.0 - a - b]
            })
        })
        .collect();
    use rayon::prelude::*;
    // The triangles' means on every core (most of a big textured model's load), then summed at
    // their corners in order.
    let means: Vec<(Vec3, f32)> = tris
        .par_iter()
        .map(|t| {
            let [p, q, r] = t.map(|i| Vec3::from_array(positions[i as usize]));
            let area = (q - p).cross(r - p).length().max(f32::MIN_POSITIVE);
            let [a, b, c] = t.map(|i| uvs[i as usize]);
            // A footprint of a texel or two is one bilinear sample at its centroid (a scan's
            // triangles mostly are: the textured dragon's load spent a third of itself here).
            let texels =
                0.5 * (b - a).perp_dot(c - a).abs() * image.width as f32 * image.height as f32;
            let mean = if texels < SMALL_FOOTPRINT {
                image.sample((a + b + c) / 3.0)
            } else {
                samples
                    .iter()
                    .map(|w| image.sample(a * w[0] + b * w[1] + c * w[2]))
                    .sum::<Vec3>()
                    / samples.len() as f32
            };
            (mean, area)
        })
        .collect();
    let mut sum = vec![Vec3::ZERO; uvs.len()];
    let mut weight = vec![0f32; uvs.len()];
    for (t, &(mean, area)) in tris.iter().zip(&means) {
        for &i in t {
            sum[i as usize] += mean * area;
            weight[i as usize] += area;
        }
    }
    (0..uvs.len())
        .map(|i| match weight[i] > 0.0 {
            true => sum[i] / weight[i],
            false => image.sample(uvs[i]),
        })
        .collect()
}

pub(super) fn decode_image(bytes: &[u8]) -> Result<Image, String> {
    let reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    let (w, h) = reader.into_dimensions().map_err(|e| e.to_string())?;
    if w == 0 || h == 0 || w as u64 * h as u64 > MAX_IMAGE_PIXELS {
        return Err(format!("{w} × {h} pixels"));
    }
    let decoded = image::load_from_memory(bytes).map_err(|e| e.to_string())?;
    let rgb = decoded.to_rgb8().pixels().map(|p| p.0).collect();
    Ok(Image {
        file: std::sync::Arc::new(bytes.to_vec()),
        width: w,
        height: h,
        rgb,
        linear: std::array::from_fn(|c| crate::color::srgb_to_linear(c as f32 / 255.0)),
    })
}

/// The deepest node graph the reader follows: glTF's graph is a forest, but a malformed file may
/// loop.
const MAX_DEPTH: usize = 256;

struct Reader<'a> {
    path: &'a Path,
    /// The folder external files are resolved in.
    base: &'a Path,
    buffers: &'a [Vec<u8>],
    images: &'a [Option<Image>],
    mesh: Mesh,
    /// One per position, linear RGB (white where the file gives no colour).
    colors: Vec<Vec3>,
    /// One per position: `COLOR_0` where a base colour texture is drawn with it, white elsewhere.
    tints: Vec<Vec3>,
    /// One per position: texture coordinates and texture ([`NO_TEXTURE`] and zero where none).
    uvs: Vec<Vec2>,
    texture_of: Vec<u32>,
    /// `mesh.textures`' index of each image of the file read so far.
    texture_index: std::collections::HashMap<usize, u32>,
    /// `mesh.materials`' index of each material of the file (`None`: the default one) read so far.
    material_index: std::collections::HashMap<Option<usize>, u32>,
    /// One per position.
    material_of: Vec<u32>,
    notes: Vec<String>,
}

impl Reader<'_> {
    fn error(&self, message: String) -> InputError {
        InputError::whole(self.path, message)
    }

    fn node(&mut self, node: &gltf::Node, parent: Mat4, depth: usize) -> Result<(), InputError> {
        if depth > MAX_DEPTH {
            return Err(self.error(format!(
                "node {} is {MAX_DEPTH} levels deep: the node graph loops",
                node.index()
            )));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            return Err(self.error(format!("node {}'s transform is not finite", node.index())));
        }
        if let Some(mesh) = node.mesh() {
            self.mesh(&mesh, world)?;
        }
        for child in node.children() {
            self.node(&child, world, depth + 1)?;
        }
        Ok(())
    }

    fn mesh(&mut self, mesh: &gltf::Mesh, world: Mat4) -> Result<(), InputError> {
        // A mirroring transform turns counter-clockwise corners clockwise: swap two back.
        let flip = world.determinant() < 0.0;
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        for primitive in mesh.primitives() {
            let what = format!(
                "primitive {} of mesh {}{}",
                primitive.index(),
                mesh.index(),
                mesh.name().map(|n| format!(" ({n})")).unwrap_or_default()
            );
            let mode = primitive.mode();
            if matches!(
                mode,
                Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip
            ) {
                self.notes
                    .push(format!("{what} draws {mode:?}, not triangles: left out"));
                continue;
            }
            let Some(positions) = primitive.get(&gltf::Semantic::Positions) else {
                self.notes.push(format!("{what} has no POSITION: left out"));
                continue;
            };
            let positions = self.read::<3>(&positions, "POSITION")?;
            let count = positions.len();
            let normals = match primitive.get(&gltf::Semantic::Normals) {
                Some(a) => Some(self.read_per_vertex::<3>(&a, "NORMAL", count)?),
                None => None,
            };
            let indices: Vec<u32> = match primitive.indices() {
                Some(a) => {
                    let raw = self.read_indices(&a)?;
                    if let Some(&bad) = raw.iter().find(|&&i| i as usize >= count) {
                        return Err(self.error(format!(
                            "accessor {} ({what}'s indices) holds index {bad}, but the primitive has {count} vertices",
                            a.index()
                        )));
                    }
                    raw
                }
                None => (0..count as u32).collect(),
            };
            let tris = triangles(mode, &indices);
            let (colors, tints, uvs_here, texture_here) =
                self.appearance(&primitive, &what, &positions, &tris)?;
            let material = self.material(&primitive, &what, texture_here);
            self.material_of
                .extend(std::iter::repeat_n(material, count));
            let base = self.mesh.positions.len() as u32;
            let first = self.mesh.triangles.len() as u32;
            for corners in tris {
                let [a, b, c] = corners.map(|i| i + base);
                self.mesh
                    .triangles
                    .push(if flip { [a, c, b] } else { [a, b, c] });
            }
            for p in &positions {
                let p = world.transform_point3(Vec3::from_array(*p));
                if !p.is_finite() {
                    return Err(self.error(format!("{what} has a position that is not finite")));
                }
                self.mesh.positions.push(p);
            }
            if let Some(n) = normals {
                let all = self.mesh.normals.get_or_insert_with(Vec::new);
                // Vertices before this primitive had none: leave them zero (no normal).
                all.resize(base as usize, Vec3::ZERO);
                all.extend(
                    n.iter()
                        .map(|n| (normal_matrix * Vec3::from_array(*n)).normalize_or_zero()),
                );
            } else if let Some(all) = self.mesh.normals.as_mut() {
                all.resize(self.mesh.positions.len(), Vec3::ZERO);
            }
            self.colors.extend(colors);
            match tints {
                Some(t) => self.tints.extend(t),
                None => self.tints.extend(std::iter::repeat_n(Vec3::ONE, count)),
            }
            self.uvs.extend(uvs_here);
            self.texture_of
                .extend(std::iter::repeat_n(texture_here, count));
            let last = self.mesh.triangles.len() as u32;
            if last > first {
                self.mesh.parts.push(Part {
                    name: mesh
                        .name()
                        .map_or_else(|| format!("mesh {}", mesh.index()), str::to_owned),
                    triangles: first..last,
                });
            }
        }
        Ok(())
    }

    /// The primitive's material, as an index into `mesh.materials` (added when first met). Its
    /// other maps are carried when its base colour texture was read (they read its coordinates).
    fn material(&mut self, primitive: &gltf::Primitive, what: &str, base_texture: u32) -> u32 {
        let m = primitive.material();
        let tinted = primitive.get(&gltf::Semantic::Colors(0)).is_some();
        if let Some(&i) = self.material_index.get(&m.index()) {
            self.mesh.materials[i as usize].vertex_colors |= tinted;
            return i;
        }
        let pbr = m.pbr_metallic_roughness();
        let mut out = Material {
            name: m.name().map_or_else(
                || {
                    m.index()
                        .map_or("default".into(), |k| format!("material {k}"))
                },
                str::to_owned,
            ),
            base_color_factor: pbr.base_color_factor(),
            base_color_texture: (base_texture != NO_TEXTURE).then_some(base_texture),
            metallic_factor: pbr.metallic_factor(),
            roughness_factor: pbr.roughness_factor(),
            emissive_factor: m.emissive_factor(),
            alpha_mode: match m.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => AlphaMode::Mask,
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            },
            alpha_cutoff: m.alpha_cutoff().unwrap_or(0.5),
            double_sided: m.double_sided(),
            vertex_colors: tinted,
            ..Material::default()
        };
        let set = pbr.base_color_texture().map(|t| t.tex_coord());
        let maps = [
            (
                "metallic-roughness",
                pbr.metallic_roughness_texture()
                    .map(|t| (t.texture(), t.tex_coord())),
            ),
            (
                "normal",
                m.normal_texture().map(|t| (t.texture(), t.tex_coord())),
            ),
            (
                "occlusion",
                m.occlusion_texture().map(|t| (t.texture(), t.tex_coord())),
            ),
            (
                "emissive",
                m.emissive_texture().map(|t| (t.texture(), t.tex_coord())),
            ),
        ];
        let mut carried = [None; 4];
        for (slot, (kind, map)) in carried.iter_mut().zip(maps) {
            let Some((texture, coords)) = map else {
                continue;
            };
            if out.base_color_texture.is_none() {
                self.notes.push(format!(
                    "{what}: the {kind} map of material {:?} left out (it is carried only beside a base colour texture, whose coordinates it reads)",
                    out.name
                ));
                continue;
            }
            if Some(coords) != set {
                self.notes.push(format!(
                    "{what}: the {kind} map of material {:?} reads TEXCOORD_{coords}; it is written with the base colour's coordinates",
                    out.name
                ));
            }
            let image = texture.source();
            if let Some(&t) = self.texture_index.get(&image.index()) {
                *slot = Some(t);
                continue;
            }
            match carried_image(&image, self.buffers, self.base) {
                Ok(bytes) => {
                    self.mesh.textures.push(std::sync::Arc::new(bytes));
                    let t = self.mesh.textures.len() as u32 - 1;
                    self.texture_index.insert(image.index(), t);
                    *slot = Some(t);
                }
                Err(e) => self.notes.push(format!(
                    "image {} ({kind} map) left out ({e})",
                    image.index()
                )),
            }
        }
        [
            out.metallic_roughness_texture,
            out.normal_texture,
            out.occlusion_texture,
            out.emissive_texture,
        ] = carried;
        self.mesh.materials.push(out);
        let i = self.mesh.materials.len() as u32 - 1;
        self.material_index.insert(m.index(), i);
        i
    }

    /// A primitive's vertex colours (base colour factor × `COLOR_0` × the texture's mean around
    /// each vertex, [`bake`]), tints (`COLOR_0` alone, when it has a texture and colours),
    /// texture coordinates and texture (an index into `mesh.textures`).
    #[allow(clippy::type_complexity)]
    fn appearance(
        &mut self,
        primitive: &gltf::Primitive,
        what: &str,
        positions: &[[f32; 3]],
        tris: &[[u32; 3]],
    ) -> Result<(Vec<Vec3>, Option<Vec<Vec3>>, Vec<Vec2>, u32), InputError> {
        let count = positions.len();
        let material = primitive.material();
        let pbr = material.pbr_metallic_roughness();
        let factor = Vec4::from_array(pbr.base_color_factor());
        let mut colors = vec![factor.truncate(); count];
        let (mut uvs_here, mut texture_here) = (vec![Vec2::ZERO; count], NO_TEXTURE);
        let mut tints = None;
        if let Some(a) = primitive.get(&gltf::Semantic::Colors(0)) {
            let c = if a.dimensions() == Dimensions::Vec4 {
                self.read_per_vertex::<4>(&a, "COLOR_0", count)?
                    .into_iter()
                    .map(|c| [c[0], c[1], c[2]])
                    .collect()
            } else {
                self.read_per_vertex::<3>(&a, "COLOR_0", count)?
            };
            let c: Vec<Vec3> = c.into_iter().map(Vec3::from_array).collect();
            for (out, &c) in colors.iter_mut().zip(&c) {
                *out *= c;
            }
            tints = Some(c);
        }
        if let Some(info) = pbr.base_color_texture() {
            let set = info.tex_coord();
            let image = self.images[info.texture().source().index()].as_ref();
            match (primitive.get(&gltf::Semantic::TexCoords(set)), image) {
                (Some(a), Some(image)) => {
                    let transform = uv_transform(info.texture_transform());
                    let uvs: Vec<Vec2> = self
                        .read_per_vertex::<2>(&a, "TEXCOORD", count)?
                        .into_iter()
                        .map(|uv| transform.transform_point2(Vec2::from_array(uv)))
                        .collect();
                    let baked = bake(image, positions, &uvs, tris);
                    for (out, c) in colors.iter_mut().zip(baked) {
                        *out *= c;
                    }
                    let index = info.texture().source().index();
                    texture_here = *self.texture_index.entry(index).or_insert_with(|| {
                        self.mesh.textures.push(image.file.clone());
                        self.mesh.textures.len() as u32 - 1
                    });
                    uvs_here = uvs;
                }
                (None, Some(_)) => self.notes.push(format!(
                    "{what}'s base colour texture reads TEXCOORD_{set}, which it lacks: left out"
                )),
                _ => {}
            }
        }
        // Only a texture is tinted: an untextured vertex's colour holds its `COLOR_0` already.
        let tints = tints.filter(|_| texture_here != NO_TEXTURE);
        Ok((colors, tints, uvs_here, texture_here))
    }

    /// `accessor` as `N`-component floats, normalized integers scaled to [0, 1] or [−1, 1] as the
    /// specification says (`KHR_mesh_quantization` also allows plain integers, taken as they are).
    fn read<const N: usize>(
        &self,
        accessor: &gltf::Accessor,
        semantic: &str,
    ) -> Result<Vec<[f32; N]>, InputError> {
        let components = accessor.dimensions().multiplicity();
        if components != N {
            return Err(self.error(format!(
                "accessor {} ({semantic}) has {components} components, expected {N}",
                accessor.index()
            )));
        }
        let values = self.components(accessor, semantic)?;
        Ok(values
            .chunks_exact(N)
            .map(|c| std::array::from_fn(|i| c[i]))
            .collect())
    }

    /// As [`Reader::read`], with one entry per vertex required.
    fn read_per_vertex<const N: usize>(
        &self,
        accessor: &gltf::Accessor,
        semantic: &str,
        count: usize,
    ) -> Result<Vec<[f32; N]>, InputError> {
        let values = self.read::<N>(accessor, semantic)?;
        if values.len() != count {
            return Err(self.error(format!(
                "accessor {} ({semantic}) has {} entries, but POSITION has {count}",
                accessor.index(),
                values.len()
            )));
        }
        Ok(values)
    }

    fn read_indices(&self, accessor: &gltf::Accessor) -> Result<Vec<u32>, InputError> {
        if accessor.dimensions() != Dimensions::Scalar
            || !matches!(
                accessor.data_type(),
                DataType::U8 | DataType::U16 | DataType::U32
            )
        {
            return Err(self.error(format!(
                "accessor {} (indices) is not unsigned integer scalars",
                accessor.index()
            )));
        }
        let raw = self.raw_components(accessor, "indices")?;
        Ok(raw.into_iter().map(|x| x as u32).collect())
    }

    /// The accessor's components as floats, normalization applied.
    fn components(
        &self,
        accessor: &gltf::Accessor,
        semantic: &str,
    ) -> Result<Vec<f32>, InputError> {
        let raw = self.raw_components(accessor, semantic)?;
        let scale = if accessor.normalized() {
            match accessor.data_type() {
                DataType::I8 => Some(127.0),
                DataType::U8 => Some(255.0),
                DataType::I16 => Some(32767.0),
                DataType::U16 => Some(65535.0),
                _ => None,
            }
        } else {
            None
        };
        let out: Vec<f32> = match scale {
            Some(s) => raw.into_iter().map(|x| (x / s).max(-1.0) as f32).collect(),
            None => raw.into_iter().map(|x| x as f32).collect(),
        };
        if out.iter().any(|x| !x.is_finite()) {
            return Err(self.error(format!(
                "accessor {} ({semantic}) holds a value that is not finite",
                accessor.index()
            )));
        }
        Ok(out)
    }

    /// The accessor's components as stored (as `f64`, which holds every glTF component type
    /// exactly), with its sparse substitution applied.
    fn raw_components(
        &self,
        accessor: &gltf::Accessor,
        semantic: &str,
    ) -> Result<Vec<f64>, InputError> {
        let what = format!("accessor {} ({semantic})", accessor.index());
        let n = accessor.dimensions().multiplicity();
        let kind = accessor.data_type();
        let size = kind.size();
        let count = accessor.count();
        let mut out = match accessor.view() {
            Some(view) => {
                let stride = view.stride().unwrap_or(n * size);
                let bytes = self.view_bytes(&view, &what)?;
                let start = accessor.offset();
                let needed = if count == 0 {
                    0
                } else {
                    start + stride * (count - 1) + n * size
                };
                if needed > bytes.len() {
                    return Err(self.error(format!(
                        "{what} reads {needed} bytes of buffer view {}, which holds {}",
                        view.index(),
                        bytes.len()
                    )));
                }
                let mut out = Vec::with_capacity(count * n);
                for i in 0..count {
                    for k in 0..n {
                        out.push(component(kind, &bytes[start + i * stride + k * size..]));
                    }
                }
                out
            }
            // No view: zeros, replaced by the sparse values if any.
            None if count > MAX_VIEWLESS_ELEMENTS => {
                return Err(self.error(format!(
                    "{what} declares {count} elements and no buffer view (at most {MAX_VIEWLESS_ELEMENTS})"
                )));
            }
            None => vec![0.0; count * n],
        };
        if let Some(sparse) = accessor.sparse() {
            let m = sparse.count();
            let (iv, vv) = (sparse.indices(), sparse.values());
            let index_kind = match iv.index_type() {
                gltf::accessor::sparse::IndexType::U8 => DataType::U8,
                gltf::accessor::sparse::IndexType::U16 => DataType::U16,
                gltf::accessor::sparse::IndexType::U32 => DataType::U32,
            };
            let ib = self.view_bytes(&iv.view(), &what)?;
            let vb = self.view_bytes(&vv.view(), &what)?;
            let (ioff, voff) = (iv.offset(), vv.offset());
            if ioff + m * index_kind.size() > ib.len() || voff + m * n * size > vb.len() {
                return Err(self.error(format!("{what}'s sparse data runs past its buffer views")));
            }
            for j in 0..m {
                let i = component(index_kind, &ib[ioff + j * index_kind.size()..]) as usize;
                if i >= count {
                    return Err(self.error(format!(
                        "{what}'s sparse index {i} is past its {count} elements"
                    )));
                }
                for k in 0..n {
                    out[i * n + k] = component(kind, &vb[voff + (j * n + k) * size..]);
                }
            }
        }
        Ok(out)
    }

    fn view_bytes(&self, view: &gltf::buffer::View, what: &str) -> Result<&[u8], InputError> {
        let buffer = &self.buffers[view.buffer().index()];
        buffer
            .get(view.offset()..view.offset() + view.length())
            .ok_or_else(|| {
                self.error(format!(
                    "{what}: buffer view {} runs past buffer {} ({} bytes)",
                    view.index(),
                    view.buffer().index(),
                    buffer.len()
                ))
            })
    }
}

/// One component at the start of `bytes` (little-endian; the caller checked the length).
fn component(kind: DataType, bytes: &[u8]) -> f64 {
    let b = |n: usize| -> [u8; 4] {
        let mut a = [0; 4];
        a[..n].copy_from_slice(&bytes[..n]);
        a
    };
    match kind {
        DataType::I8 => bytes[0] as i8 as f64,
        DataType::U8 => bytes[0] as f64,
        DataType::I16 => i16::from_le_bytes([bytes[0], bytes[1]]) as f64,
        DataType::U16 => u16::from_le_bytes([bytes[0], bytes[1]]) as f64,
        DataType::U32 => u32::from_le_bytes(b(4)) as f64,
        DataType::F32 => f32::from_le_bytes(b(4)) as f64,
    }
}

/// The triangles of a primitive drawn in `mode` over `indices` (strips alternate their winding,
/// fans turn around the first index; a strip's or fan's degenerate triangles are left to `clean`).
fn triangles(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
        Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
            .map(|i| {
                let t = &indices[i..i + 3];
                if i % 2 == 0 {
                    [t[0], t[1], t[2]]
                } else {
                    [t[1], t[0], t[2]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..indices.len().saturating_sub(1))
            .map(|i| [indices[0], indices[i], indices[i + 1]])
            .collect(),
        _ => Vec::new(),
    }
}

/// `KHR_texture_transform` as a 2D affine map: scale, then rotate, then offset (its specification's
/// order).
fn uv_transform(t: Option<gltf::texture::TextureTransform>) -> glam::Affine2 {
    let Some(t) = t else {
        return glam::Affine2::IDENTITY;
    };
    let (s, r, o) = (t.scale(), t.rotation(), t.offset());
    // The extension's matrix: translation · rotation(−r in its y-down convention) · scale.
    let rotation = glam::Mat2::from_cols_array(&[r.cos(), -r.sin(), r.sin(), r.cos()]);
    glam::Affine2::from_mat2_translation(
        rotation * glam::Mat2::from_diagonal(Vec2::from_array(s)),
        Vec2::from_array(o),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_known_text() {
        assert_eq!(base64_decode("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(base64_decode("aGVsbG8").unwrap(), b"hello");
        assert!(base64_decode("a*b").is_err());
    }

    /// A strip of four indices is two triangles, the second turned back to the first's winding; a
    /// fan of five turns three around its first index.
    #[test]
    fn strips_and_fans() {
        assert_eq!(
            triangles(Mode::TriangleStrip, &[0, 1, 2, 3]),
            vec![[0, 1, 2], [2, 1, 3]]
        );
        assert_eq!(
            triangles(Mode::TriangleFan, &[0, 1, 2, 3, 4]),
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]
        );
    }
}

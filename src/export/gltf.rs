//! glTF 2.0 output: one mesh with a primitive per material (positions, unit normals when every
//! vertex has one, texture coordinates, vertex colours where the materials want them, 32-bit
//! indices; all primitives share the vertex arrays), the materials with their textures, as a
//! `.glb` (images embedded) or as a `.gltf` with its `.bin` and images beside it.
//!
//! Colours: a vertex's colour in a [`Mesh`] is what it shows (base colour factor × `COLOR_0` × its
//! texture's mean around it). Written back, a textured material draws its texture × its factor,
//! so its vertices' colours are left out; an untextured material's vertices write `COLOR_0` as their
//! colour over the factor, where the input had vertex colours (docs/APPEARANCE.md).

use crate::mesh::{AlphaMode, Material, Mesh, NO_TEXTURE};
use glam::Vec3;
use serde_json::{Value, json};

/// Where a `.gltf`'s files go: the buffer's file name, and a name for the k-th image of a given
/// extension; `None` for a GLB.
pub type External<'a> = Option<(&'a str, &'a dyn Fn(usize, &str) -> String)>;

/// An image of the output: its file's bytes, and the extension its format has.
pub struct Image<'a> {
    pub bytes: &'a [u8],
    pub extension: &'static str,
}

/// The format of an image file, by its signature (glTF core allows PNG and JPEG).
pub(crate) fn mime_type(bytes: &[u8]) -> (&'static str, &'static str) {
    if bytes.starts_with(&[0xFF, 0xD8]) {
        ("image/jpeg", "jpg")
    } else {
        ("image/png", "png")
    }
}

/// The mesh's materials and each vertex's: its own when it has them; otherwise one per texture
/// (and a plain one for untextured vertices) when it has textures; none for a mesh with neither.
pub(crate) fn materials_of(mesh: &Mesh) -> Option<(Vec<Material>, Vec<u32>)> {
    if let Some(of) = &mesh.material_of {
        return Some((mesh.materials.clone(), of.clone()));
    }
    let texture_of = mesh.texture_of.as_ref()?;
    let mut list: Vec<Material> = (0..mesh.textures.len())
        .map(|t| Material {
            name: format!("texture {t}"),
            base_color_texture: Some(t as u32),
            metallic_factor: 0.0,
            ..Material::default()
        })
        .collect();
    let plain = list.len() as u32;
    list.push(Material {
        name: "untextured".into(),
        metallic_factor: 0.0,
        vertex_colors: mesh.colors.is_some(),
        ..Material::default()
    });
    let of = texture_of
        .iter()
        .map(|&t| if t == NO_TEXTURE { plain } else { t })
        .collect();
    Some((list, of))
}

/// The binary buffer and the JSON document that describes it. `external`: the `.gltf` case, with
/// the buffer's file name and a name for each image file (which the caller writes beside it);
/// `None` for a GLB, whose images go into its binary chunk.
pub fn document(mesh: &Mesh, external: External) -> (Value, Vec<u8>) {
    chain_document(&[(mesh, Value::Null)], external)
}

/// A chain of levels of detail of one model (they share its materials and textures), each a mesh
/// of its own in a scene of its own, the first the default; `extras` (what the level is) goes into
/// its scene, node and mesh.
pub fn chain_document(levels: &[(&Mesh, Value)], external: External) -> (Value, Vec<u8>) {
    let mut b = Buffer::default();
    let mut meshes = Vec::new();
    for (mesh, extras) in levels {
        let mut m = json!({"primitives": primitives(mesh, &mut b)});
        if !extras.is_null() {
            m["extras"] = extras.clone();
        }
        meshes.push(m);
    }
    let scene = |k: usize| {
        let mut s = json!({"nodes": [k]});
        if levels.len() > 1 {
            s["name"] = json!(format!("LOD{k}"));
            s["extras"] = levels[k].1.clone();
        }
        s
    };
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": format!("vunify {}", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": (0..levels.len()).map(scene).collect::<Vec<_>>(),
        "nodes": (0..levels.len()).map(|k| json!({"mesh": k})).collect::<Vec<_>>(),
        "meshes": meshes,
    });
    let mesh = levels[0].0;
    let materials = materials_of(mesh);
    if let Some((list, _)) = &materials {
        // Only the images some material uses, renumbered in order.
        let mut index = vec![None; mesh.textures.len()];
        let mut images = Vec::new();
        for t in list.iter().flat_map(Material::textures) {
            if index[t as usize].is_none() {
                index[t as usize] = Some(images.len());
                let bytes = &mesh.textures[t as usize];
                let (mime, extension) = mime_type(bytes);
                images.push(match external {
                    Some((_, name)) => json!({"uri": name(images.len(), extension)}),
                    None => json!({"bufferView": b.view(bytes, None), "mimeType": mime}),
                });
            }
        }
        let texture = |t: Option<u32>| t.map(|t| json!({"index": index[t as usize]}));
        doc["materials"] = list.iter().map(|m| material_json(m, &texture)).collect();
        if !images.is_empty() {
            doc["textures"] = (0..images.len()).map(|i| json!({"source": i})).collect();
            doc["images"] = json!(images);
        }
    }
    let Buffer {
        mut bin,
        views,
        accessors,
    } = b;
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let mut buffer = json!({"byteLength": bin.len()});
    if let Some((uri, _)) = external {
        buffer["uri"] = json!(uri);
    }
    doc["buffers"] = json!([buffer]);
    doc["bufferViews"] = json!(views);
    doc["accessors"] = json!(accessors);
    (doc, bin)
}

/// The primitives of `mesh`, a primitive per material, their arrays written into `b`.
fn primitives(mesh: &Mesh, b: &mut Buffer) -> Vec<Value> {
    const VERTICES: u32 = 34962;
    const INDICES: u32 = 34963;
    let materials = materials_of(mesh);
    let any = |f: fn(&Material) -> bool| {
        materials
            .as_ref()
            .is_some_and(|(list, _)| list.iter().any(f))
    };
    // glTF's normals are unit vectors: written only when every vertex has one.
    let normals: Option<Vec<Vec3>> = mesh
        .normals
        .as_ref()
        .and_then(|n| n.iter().map(|v| v.try_normalize()).collect());
    let uvs = mesh
        .uvs
        .as_ref()
        .filter(|_| any(|m| m.textures().next().is_some()));
    // A normal map needs a tangent space (the validator warns that a generated one is not
    // portable): written where a material has one and every vertex a normal.
    let tangents = match (&normals, uvs) {
        (Some(n), Some(uvs)) if any(|m| m.normal_texture.is_some()) => {
            Some(tangents(&mesh.positions, n, uvs, &mesh.triangles))
        }
        _ => None,
    };
    let colors = vertex_colors(mesh, materials.as_ref());
    // A primitive per material, in the materials' order (a triangle's material is its first
    // corner's: a triangle of a coarse cut may join nodes of two).
    let groups: Vec<(Option<usize>, Vec<[u32; 3]>)> = match &materials {
        None => vec![(None, mesh.triangles.clone())],
        Some((list, of)) => {
            let mut by: Vec<Vec<[u32; 3]>> = vec![Vec::new(); list.len()];
            for t in &mesh.triangles {
                by[of[t[0] as usize] as usize].push(*t);
            }
            by.into_iter()
                .enumerate()
                .filter(|(_, t)| !t.is_empty())
                .map(|(m, t)| (Some(m), t))
                .collect()
        }
    };
    // Each primitive has vertex arrays of its own, holding the vertices its triangles use.
    let mut primitives = Vec::new();
    let mut local = vec![u32::MAX; mesh.positions.len()];
    for (material, triangles) in &groups {
        let mut used: Vec<u32> = Vec::new();
        let indices: Vec<u8> = triangles
            .iter()
            .flatten()
            .flat_map(|&v| {
                if local[v as usize] == u32::MAX {
                    local[v as usize] = used.len() as u32;
                    used.push(v);
                }
                local[v as usize].to_le_bytes()
            })
            .collect();
        let count = used.len();
        let mut attribute =
            |values: &mut dyn FnMut(usize) -> Vec<f32>, kind: &str, bounds: bool| {
                let data: Vec<f32> = used.iter().flat_map(|&v| values(v as usize)).collect();
                let mut accessor = json!({"componentType": 5126, "count": count, "type": kind});
                if bounds {
                    let width = data.len() / count;
                    let column = |k: usize| data.iter().skip(k).step_by(width);
                    let lo: Vec<f32> = (0..width)
                        .map(|k| column(k).copied().fold(f32::INFINITY, f32::min))
                        .collect();
                    let hi: Vec<f32> = (0..width)
                        .map(|k| column(k).copied().fold(f32::NEG_INFINITY, f32::max))
                        .collect();
                    accessor["min"] = json!(lo);
                    accessor["max"] = json!(hi);
                }
                let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
                json!(b.accessor(&bytes, VERTICES, accessor))
            };
        let mut attributes = serde_json::Map::new();
        attributes.insert(
            "POSITION".into(),
            attribute(&mut |v| mesh.positions[v].to_array().to_vec(), "VEC3", true),
        );
        if let Some(n) = &normals {
            attributes.insert(
                "NORMAL".into(),
                attribute(&mut |v| n[v].to_array().to_vec(), "VEC3", false),
            );
        }
        if let Some(uv) = uvs {
            attributes.insert(
                "TEXCOORD_0".into(),
                attribute(&mut |v| uv[v].to_array().to_vec(), "VEC2", false),
            );
        }
        if let Some(t) = &tangents {
            attributes.insert(
                "TANGENT".into(),
                attribute(&mut |v| t[v].to_array().to_vec(), "VEC4", false),
            );
        }
        if let Some(c) = &colors {
            attributes.insert(
                "COLOR_0".into(),
                attribute(&mut |v| c[v].to_array().to_vec(), "VEC3", false),
            );
        }
        for &v in &used {
            local[v as usize] = u32::MAX;
        }
        let index = b.accessor(
            &indices,
            INDICES,
            json!({"componentType": 5125, "count": triangles.len() * 3, "type": "SCALAR"}),
        );
        let mut p = json!({"attributes": attributes, "indices": index, "mode": 4});
        if let Some(m) = material {
            p["material"] = json!(m);
        }
        primitives.push(p);
    }
    primitives
}

/// The one buffer being filled, with its views and accessors.
#[derive(Default)]
struct Buffer {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Buffer {
    /// A view of `bytes`, appended at the next 4-byte boundary.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(target) = target {
            v["target"] = json!(target);
        }
        self.views.push(v);
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    /// An accessor (`accessor` without its view) of `bytes` in a view of their own.
    fn accessor(&mut self, bytes: &[u8], target: u32, accessor: Value) -> usize {
        let mut a = accessor;
        a["bufferView"] = json!(self.view(bytes, Some(target)));
        self.accessors.push(a);
        self.accessors.len() - 1
    }
}

/// The images a `.gltf` of `mesh` refers to, in the order [`document`] names them.
pub fn images(mesh: &Mesh) -> Vec<Image<'_>> {
    let Some((list, _)) = materials_of(mesh) else {
        return Vec::new();
    };
    let mut seen = vec![false; mesh.textures.len()];
    let mut out = Vec::new();
    for t in list.iter().flat_map(Material::textures) {
        if !std::mem::replace(&mut seen[t as usize], true) {
            let bytes = &mesh.textures[t as usize][..];
            out.push(Image {
                bytes,
                extension: mime_type(bytes).1,
            });
        }
    }
    out
}

fn material_json(m: &Material, texture: &dyn Fn(Option<u32>) -> Option<Value>) -> Value {
    let mut pbr = json!({
        "baseColorFactor": m.base_color_factor,
        "metallicFactor": m.metallic_factor,
        "roughnessFactor": m.roughness_factor,
    });
    if let Some(t) = texture(m.base_color_texture) {
        pbr["baseColorTexture"] = t;
    }
    if let Some(t) = texture(m.metallic_roughness_texture) {
        pbr["metallicRoughnessTexture"] = t;
    }
    let mut out = json!({"name": m.name, "pbrMetallicRoughness": pbr});
    for (key, t) in [
        ("normalTexture", m.normal_texture),
        ("occlusionTexture", m.occlusion_texture),
        ("emissiveTexture", m.emissive_texture),
    ] {
        if let Some(t) = texture(t) {
            out[key] = t;
        }
    }
    if m.emissive_factor != [0.0; 3] {
        out["emissiveFactor"] = json!(m.emissive_factor);
    }
    match m.alpha_mode {
        AlphaMode::Opaque => {}
        AlphaMode::Mask => {
            out["alphaMode"] = json!("MASK");
            out["alphaCutoff"] = json!(m.alpha_cutoff);
        }
        AlphaMode::Blend => out["alphaMode"] = json!("BLEND"),
    }
    if m.double_sided {
        out["doubleSided"] = json!(true);
    }
    out
}

/// Per-vertex tangents for a normal map (xyz unit and perpendicular to the normal, w = ±1 the
/// bitangent's handedness): each triangle's direction of increasing `u`, weighted by its area in
/// UV space and summed at its corners, then made perpendicular to the normal (Lengyel's method,
/// *Mathematics for 3D Game Programming and Computer Graphics*).
fn tangents(
    positions: &[Vec3],
    normals: &[Vec3],
    uvs: &[glam::Vec2],
    triangles: &[[u32; 3]],
) -> Vec<glam::Vec4> {
    let mut tan = vec![Vec3::ZERO; positions.len()];
    let mut bitan = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let [p, q, r] = t.map(|i| positions[i as usize]);
        let [a, b, c] = t.map(|i| uvs[i as usize]);
        let (e1, e2) = (q - p, r - p);
        let (d1, d2) = (b - a, c - a);
        let det = d1.x * d2.y - d2.x * d1.y;
        if det.abs() < 1e-20 {
            continue;
        }
        let s = (e1 * d2.y - e2 * d1.y) / det;
        let u = (e2 * d1.x - e1 * d2.x) / det;
        for &i in t {
            tan[i as usize] += s * det.abs();
            bitan[i as usize] += u * det.abs();
        }
    }
    (0..positions.len())
        .map(|i| {
            let n = normals[i].normalize();
            let t = (tan[i] - n * n.dot(tan[i]))
                .try_normalize()
                .unwrap_or_else(|| n.any_orthonormal_vector());
            let w = if n.cross(t).dot(bitan[i]) < 0.0 {
                -1.0
            } else {
                1.0
            };
            t.extend(w)
        })
        .collect()
}

/// `COLOR_0` in [0, 1], or `None` where no vertex needs one: without materials, the colours; with
/// them, for vertices of untextured materials that had vertex colours, the colour over the
/// material's factor, and for textured ones the tint of their texture (white elsewhere).
fn vertex_colors(mesh: &Mesh, materials: Option<&(Vec<Material>, Vec<u32>)>) -> Option<Vec<Vec3>> {
    let colors = mesh.colors.as_ref()?;
    let clamp = |c: Vec3| c.clamp(Vec3::ZERO, Vec3::ONE);
    let Some((list, of)) = materials else {
        return Some(colors.iter().map(|&c| clamp(c)).collect());
    };
    let tinted = |m: &Material| m.vertex_colors && m.base_color_texture.is_none();
    let tints = mesh.tints.as_ref();
    if !list.iter().any(tinted) && tints.is_none() {
        return None;
    }
    Some(
        colors
            .iter()
            .zip(of)
            .enumerate()
            .map(|(v, (&c, &m))| {
                let m = &list[m as usize];
                if m.base_color_texture.is_some() {
                    return tints.map_or(Vec3::ONE, |t| clamp(t[v]));
                }
                if !tinted(m) {
                    return Vec3::ONE;
                }
                let factor = Vec3::from_slice(&m.base_color_factor[..3]);
                let over = Vec3::select(factor.cmpgt(Vec3::ZERO), c / factor, Vec3::ONE);
                clamp(over)
            })
            .collect(),
    )
}

/// The mesh as one GLB file: a 12-byte header, the JSON chunk (padded with spaces) and the binary
/// chunk (padded with zeros), images inside it.
pub fn glb_bytes(mesh: &Mesh) -> Vec<u8> {
    let (doc, bin) = document(mesh, None);
    glb(&doc, bin)
}

/// A GLB of a document and its binary chunk.
pub fn glb(doc: &Value, bin: Vec<u8>) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).expect("a JSON value serializes");
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

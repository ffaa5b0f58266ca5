//! Textured Wavefront OBJ: `vt` texture coordinates, `usemtl` materials from an `mtllib` library,
//! `map_Kd` base colour textures (and `norm`/`map_Bump` normal maps, carried through).
//!
//! A corner of a textured face is a (position, texture coordinate, normal) triple, and a texture
//! seam splits a vertex: this is what `tobj` reads with `single_index` (one index a corner, a model
//! per object and material), so this path uses it rather than growing vunify's parallel reader,
//! which stays the fast path for the geometry-only files that big scans are. The file is first
//! read by that reader too, so a malformed line is still an error naming its line.

use super::error::InputError;
use super::gltf::{bake, decode_image};
use super::{AlphaMode, Material, Mesh, NO_TEXTURE, Part};
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::path::Path;

/// Whether `text` needs this reader: it names a material library and has texture coordinates.
pub fn wants(text: &str) -> bool {
    let mut library = false;
    let mut coordinates = false;
    for line in text.lines() {
        let line = line.trim_start();
        library |= line.starts_with("mtllib");
        coordinates |= line.starts_with("vt ") || line.starts_with("vt\t");
        if library && coordinates {
            return true;
        }
    }
    false
}

/// Reads a textured OBJ (its material library and images beside it); what could not be used (a
/// missing library or image) is a note, and the material's colour stands in.
pub fn parse(text: &str, path: &Path, notes: &mut Vec<String>) -> Result<Mesh, InputError> {
    let base = path.parent().unwrap_or(Path::new("."));
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, library) = tobj::load_obj_buf(&mut text.as_bytes(), &options, |name| {
        tobj::load_mtl(base.join(name))
    })
    .map_err(|e| InputError::whole(path, format!("cannot read it as a textured OBJ: {e}")))?;
    let library = library.unwrap_or_else(|e| {
        notes.push(format!(
            "its material library could not be read ({e}): surfaces are white"
        ));
        Vec::new()
    });
    let mut mesh = Mesh::default();
    let mut images: HashMap<String, Option<(u32, super::gltf::Image)>> = HashMap::new();
    let mut colors = Vec::new();
    let mut uvs = Vec::new();
    let mut texture_of = Vec::new();
    let mut material_of = Vec::new();
    let mut material_index: HashMap<Option<usize>, u32> = HashMap::new();
    for model in &models {
        let m = &model.mesh;
        let count = m.positions.len() / 3;
        let first = mesh.triangles.len() as u32;
        let base_vertex = mesh.positions.len() as u32;
        mesh.positions
            .extend(m.positions.chunks_exact(3).map(Vec3::from_slice));
        let (corners, here) = corners_and_coordinates(m, &model.name, path)?;
        let material = *material_index.entry(m.material_id).or_insert_with(|| {
            let source = m.material_id.and_then(|i| library.get(i));
            mesh.materials.push(material(source));
            mesh.materials.len() as u32 - 1
        });
        let mut color = vec![Vec3::ONE; count];
        let mut texture = NO_TEXTURE;
        if let Some(source) = m.material_id.and_then(|i| library.get(i)) {
            let factor = Vec3::from_array(source.diffuse.unwrap_or([1.0; 3]));
            color.fill(factor);
            if let Some(name) = &source.diffuse_texture {
                let entry = image(&mut images, name, base, &mut mesh, notes, &source.name);
                if entry.is_some() && mesh.materials[material as usize].normal_texture.is_none() {
                    carry_normal_map(source, material, base, &mut mesh, notes);
                }
                if let (Some((t, image)), true) = (entry, m.texcoords.len() == 2 * count) {
                    let positions: Vec<[f32; 3]> = m
                        .positions
                        .chunks_exact(3)
                        .map(|p| [p[0], p[1], p[2]])
                        .collect();
                    for (c, b) in color
                        .iter_mut()
                        .zip(bake(image, &positions, &here, &corners))
                    {
                        *c *= b;
                    }
                    texture = *t;
                    mesh.materials[material as usize].base_color_texture = Some(*t);
                }
            }
        }
        if !m.vertex_color.is_empty() && m.vertex_color.len() == 3 * count {
            for (c, v) in color.iter_mut().zip(m.vertex_color.chunks_exact(3)) {
                *c *= Vec3::from_slice(v);
            }
            mesh.materials[material as usize].vertex_colors = true;
        }
        if m.normals.len() == 3 * count {
            let all = mesh.normals.get_or_insert_with(Vec::new);
            all.resize(base_vertex as usize, Vec3::ZERO);
            all.extend(m.normals.chunks_exact(3).map(Vec3::from_slice));
        } else if let Some(all) = mesh.normals.as_mut() {
            all.resize(base_vertex as usize + count, Vec3::ZERO);
        }
        colors.extend(color);
        uvs.extend(here);
        texture_of.extend(std::iter::repeat_n(texture, count));
        material_of.extend(std::iter::repeat_n(material, count));
        mesh.triangles
            .extend(corners.iter().map(|t| t.map(|i| i + base_vertex)));
        let last = mesh.triangles.len() as u32;
        if last > first {
            mesh.parts.push(Part {
                name: model.name.clone(),
                triangles: first..last,
            });
        }
    }
    if let Some(n) = mesh.normals.as_mut() {
        n.resize(mesh.positions.len(), Vec3::ZERO);
    }
    if !mesh.textures.is_empty() {
        mesh.uvs = Some(uvs);
        mesh.texture_of = Some(texture_of);
    }
    if colors.iter().any(|&c| c != Vec3::ONE) {
        mesh.colors = Some(colors);
    }
    mesh.material_of = Some(material_of);
    Ok(mesh)
}

/// A model's triangles (checked against its vertices) and texture coordinates: OBJ's start at the
/// image's bottom row; glTF's (and the renderer's) at its top.
fn corners_and_coordinates(
    m: &tobj::Mesh,
    name: &str,
    path: &Path,
) -> Result<(Vec<[u32; 3]>, Vec<Vec2>), InputError> {
    let count = m.positions.len() / 3;
    if let Some(&bad) = m.indices.iter().find(|&&i| i as usize >= count) {
        return Err(InputError::whole(
            path,
            format!("object {name:?} has a corner {bad} past its {count} vertices"),
        ));
    }
    let corners = m
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let uvs = if m.texcoords.len() == 2 * count {
        m.texcoords
            .chunks_exact(2)
            .map(|t| Vec2::new(t[0], 1.0 - t[1]))
            .collect()
    } else {
        vec![Vec2::ZERO; count]
    };
    Ok((corners, uvs))
}

/// A material's normal map (`map_Bump`, `bump`), carried through to the output unread.
fn carry_normal_map(
    source: &tobj::Material,
    material: u32,
    base: &Path,
    mesh: &mut Mesh,
    notes: &mut Vec<String>,
) {
    let Some(normal) = &source.normal_texture else {
        return;
    };
    match std::fs::read(base.join(normal)) {
        Ok(bytes) => {
            mesh.textures.push(std::sync::Arc::new(bytes));
            mesh.materials[material as usize].normal_texture = Some(mesh.textures.len() as u32 - 1);
        }
        Err(e) => notes.push(format!("normal map {normal} left out ({e})")),
    }
}

/// The decoded image of a `map_Kd` file and its index in `mesh.textures`, read once (a note and
/// `None` when it cannot be read).
fn image<'a>(
    images: &'a mut HashMap<String, Option<(u32, super::gltf::Image)>>,
    name: &str,
    base: &Path,
    mesh: &mut Mesh,
    notes: &mut Vec<String>,
    material: &str,
) -> &'a Option<(u32, super::gltf::Image)> {
    images.entry(name.to_owned()).or_insert_with(|| {
        let read = std::fs::read(base.join(name))
            .map_err(|e| e.to_string())
            .and_then(|b| decode_image(&b));
        match read {
            Ok(image) => {
                mesh.textures.push(image.file.clone());
                Some((mesh.textures.len() as u32 - 1, image))
            }
            Err(e) => {
                notes.push(format!(
                    "texture {name} of material {material:?} left out ({e}): its colour stands in"
                ));
                None
            }
        }
    })
}

/// An MTL material as glTF's: `Kd` the base colour, `d` (or `Tr`) its alpha (blended below 1),
/// not metallic; the texture is set by the caller once its image is read.
fn material(source: Option<&tobj::Material>) -> Material {
    let Some(m) = source else {
        return Material {
            name: "default".into(),
            metallic_factor: 0.0,
            ..Material::default()
        };
    };
    let [r, g, b] = m.diffuse.unwrap_or([1.0; 3]);
    let alpha = m.dissolve.unwrap_or(1.0).clamp(0.0, 1.0);
    Material {
        name: m.name.clone(),
        base_color_factor: [r, g, b, alpha],
        metallic_factor: 0.0,
        roughness_factor: 1.0,
        emissive_factor: m.emissive.unwrap_or([0.0; 3]),
        alpha_mode: if alpha < 1.0 {
            AlphaMode::Blend
        } else {
            AlphaMode::Opaque
        },
        ..Material::default()
    }
}

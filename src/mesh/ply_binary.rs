//! The payload of a binary PLY, read straight from its bytes.
//!
//! ply-rs-bw reads every record into a map from property names to values; on a scan of 14 million
//! triangles that took 55 seconds. Here the header (already read and checked by ply-rs-bw) says
//! where each property sits, and each record is decoded in place: the vertices' fixed-size records
//! on all threads, the faces' lists in one pass. Every error names the byte where its record starts.

use super::{InputError, Mesh};
use glam::Vec3;
use ply_rs_bw::ply::{ElementDef, PropertyType, ScalarType};
use rayon::prelude::*;
use std::path::Path;

/// What a vertex property is to vunify.
#[derive(Clone, Copy, PartialEq)]
enum Role {
    Position(usize),
    Color(usize),
    Normal(usize),
    Radiosity(usize),
    /// Texture coordinates (`s t`, `u v`, `texture_u texture_v`, `texture_s texture_t`).
    Uv(usize),
    Indices,
    Other,
}

/// One property of an element: its role and type.
struct Field {
    role: Role,
    name: String,
    ty: PropertyType,
}

fn size(t: &ScalarType) -> usize {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// Reads the payload's bytes in one byte order.
#[derive(Clone, Copy)]
struct Reader<'a> {
    bytes: &'a [u8],
    big_endian: bool,
}

impl Reader<'_> {
    /// The scalar of type `t` at `at`, as f64; `None` past the end.
    #[inline]
    fn scalar(&self, at: usize, t: &ScalarType) -> Option<f64> {
        let n = size(t);
        let b = self.bytes.get(at..at + n)?;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.big_endian {
            a[..n].reverse();
        }
        Some(match t {
            ScalarType::Char => a[0] as i8 as f64,
            ScalarType::UChar => a[0] as f64,
            ScalarType::Short => i16::from_le_bytes([a[0], a[1]]) as f64,
            ScalarType::UShort => u16::from_le_bytes([a[0], a[1]]) as f64,
            ScalarType::Int => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            ScalarType::UInt => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            ScalarType::Float => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            ScalarType::Double => f64::from_le_bytes(a),
        })
    }
}

/// The mesh in a binary payload: `bytes` is the whole file, `start` where the payload begins,
/// `elements` the header's, in file order.
pub(super) fn parse(
    bytes: &[u8],
    start: usize,
    elements: &[&ElementDef],
    big_endian: bool,
    path: &Path,
) -> Result<Mesh, InputError> {
    let reader = Reader { bytes, big_endian };
    let vertex_count = elements
        .iter()
        .find(|e| e.name == "vertex")
        .ok_or_else(|| InputError::whole(path, "no 'vertex' element"))?
        .count;
    if !elements.iter().any(|e| e.name == "face") {
        return Err(InputError::whole(path, "no 'face' element"));
    }
    let truncated = |at: usize, what: &str| {
        InputError::byte(
            path,
            bytes.len() as u64,
            format!("truncated file: {what} record at byte {at} runs past the end of the file"),
        )
    };
    let mut at = start;
    let mut mesh = Mesh::default();
    for e in elements {
        let fields: Vec<Field> = e
            .properties
            .iter()
            .map(|(name, p)| Field {
                role: role(&e.name, name),
                name: name.clone(),
                ty: p.data_type.clone(),
            })
            .collect();
        match e.name.as_str() {
            "vertex" => {
                let (vertices, end) = vertices(reader, at, e.count, &fields, path)?;
                mesh.positions = vertices.positions;
                mesh.colors = vertices.colors;
                mesh.normals = vertices.normals;
                mesh.radiosity = vertices.radiosity;
                mesh.uvs = vertices.uvs;
                at = end;
            }
            "face" => {
                let Some(list) = fields.iter().position(|f| f.role == Role::Indices) else {
                    return Err(InputError::byte(
                        path,
                        at as u64,
                        "face: no integer list 'vertex_indices'",
                    ));
                };
                if !matches!(&fields[list].ty, PropertyType::List(_, t) if !matches!(t, ScalarType::Float | ScalarType::Double))
                {
                    return Err(InputError::byte(
                        path,
                        at as u64,
                        "face: no integer list 'vertex_indices'",
                    ));
                }
                let mut triangles = Vec::with_capacity(e.count);
                for _ in 0..e.count {
                    let record = at;
                    for (k, f) in fields.iter().enumerate() {
                        match &f.ty {
                            PropertyType::Scalar(t) => at += size(t),
                            PropertyType::List(count, t) => {
                                let n = reader
                                    .scalar(at, count)
                                    .ok_or_else(|| truncated(record, "a face"))?;
                                at += size(count);
                                if k == list {
                                    fan(&reader, at, n, t, vertex_count, &mut triangles).map_err(
                                        |message| {
                                            InputError::byte(
                                                path,
                                                record as u64,
                                                format!("face: {message}"),
                                            )
                                        },
                                    )?;
                                }
                                at += n.max(0.0) as usize * size(t);
                            }
                        }
                    }
                    if at > bytes.len() {
                        return Err(truncated(record, "a face"));
                    }
                }
                mesh.triangles = triangles;
            }
            _ => {
                // Skipped, record by record when it has lists.
                for _ in 0..e.count {
                    let record = at;
                    for f in &fields {
                        match &f.ty {
                            PropertyType::Scalar(t) => at += size(t),
                            PropertyType::List(count, t) => {
                                let n = reader
                                    .scalar(at, count)
                                    .ok_or_else(|| truncated(record, &e.name))?;
                                at += size(count) + n.max(0.0) as usize * size(t);
                            }
                        }
                    }
                    if at > bytes.len() {
                        return Err(truncated(record, &e.name));
                    }
                }
            }
        }
    }
    Ok(Mesh {
        colors: mesh.colors,
        normals: mesh.normals,
        radiosity: mesh.radiosity,
        uvs: mesh.uvs,
        ..Mesh::from_triangles(mesh.positions, mesh.triangles)
    })
}

fn role(element: &str, name: &str) -> Role {
    match (element, name) {
        ("vertex", "x") => Role::Position(0),
        ("vertex", "y") => Role::Position(1),
        ("vertex", "z") => Role::Position(2),
        ("vertex", "red") => Role::Color(0),
        ("vertex", "green") => Role::Color(1),
        ("vertex", "blue") => Role::Color(2),
        ("vertex", "nx") => Role::Normal(0),
        ("vertex", "ny") => Role::Normal(1),
        ("vertex", "nz") => Role::Normal(2),
        ("vertex", "radiosity_r") => Role::Radiosity(0),
        ("vertex", "radiosity_g") => Role::Radiosity(1),
        ("vertex", "radiosity_b") => Role::Radiosity(2),
        ("vertex", "s" | "u" | "texture_u" | "texture_s") => Role::Uv(0),
        ("vertex", "t" | "v" | "texture_v" | "texture_t") => Role::Uv(1),
        ("face", "vertex_indices" | "vertex_index") => Role::Indices,
        _ => Role::Other,
    }
}

/// Appends the fan of the face list of `n` indices of type `t` at `at`; the message if it is bad.
fn fan(
    reader: &Reader,
    at: usize,
    n: f64,
    t: &ScalarType,
    vertex_count: usize,
    out: &mut Vec<[u32; 3]>,
) -> Result<(), String> {
    if n < 3.0 {
        return Err(format!("a face needs at least 3 vertices, found {n}"));
    }
    let n = n as usize;
    let index = |k: usize| -> Result<u32, String> {
        let i = reader
            .scalar(at + k * size(t), t)
            .ok_or_else(|| "the face runs past the end of the file".to_string())?;
        if i < 0.0 || i >= vertex_count as f64 {
            return Err(format!(
                "vertex index {i} is out of range (the file has {vertex_count} vertices)"
            ));
        }
        Ok(i as u32)
    };
    let first = index(0)?;
    let mut previous = index(1)?;
    for k in 2..n {
        let next = index(k)?;
        out.push([first, previous, next]);
        previous = next;
    }
    Ok(())
}

struct Vertices {
    positions: Vec<Vec3>,
    colors: Option<Vec<Vec3>>,
    normals: Option<Vec<Vec3>>,
    radiosity: Option<Vec<Vec3>>,
    uvs: Option<Vec<glam::Vec2>>,
}

/// `count` vertex records from `at`; with the byte after them.
fn vertices(
    reader: Reader,
    at: usize,
    count: usize,
    fields: &[Field],
    path: &Path,
) -> Result<(Vertices, usize), InputError> {
    let has = |role: fn(usize) -> Role| (0..3).all(|k| fields.iter().any(|f| f.role == role(k)));
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        if !fields.iter().any(|f| f.role == Role::Position(k)) {
            return Err(InputError::byte(
                path,
                at as u64,
                format!("vertex: property '{name}' missing"),
            ));
        }
    }
    let (has_colors, has_normals) = (has(Role::Color), has(Role::Normal));
    let has_radiosity = has(Role::Radiosity);
    let has_uvs = (0..2).all(|k| fields.iter().any(|f| f.role == Role::Uv(k)));
    let color_scale = match fields
        .iter()
        .find(|f| f.role == Role::Color(0))
        .map(|f| &f.ty)
    {
        Some(PropertyType::Scalar(ScalarType::Float | ScalarType::Double)) => 1.0,
        _ => 1.0 / 255.0,
    };
    // Each field's offset in a record, if records have one size (no lists).
    let mut offsets = Vec::with_capacity(fields.len());
    let mut record = 0;
    for f in fields {
        match &f.ty {
            PropertyType::Scalar(t) => {
                offsets.push(record);
                record += size(t);
            }
            PropertyType::List(..) => {
                return Err(InputError::byte(
                    path,
                    at as u64,
                    format!(
                        "vertex: list property '{}' (vunify reads scalar vertex properties only)",
                        f.name
                    ),
                ));
            }
        }
    }
    let end = at + count * record;
    if end > reader.bytes.len() {
        return Err(InputError::byte(
            path,
            reader.bytes.len() as u64,
            format!(
                "truncated file: {count} vertex records of {record} bytes from byte {at} run past the end"
            ),
        ));
    }
    // One record: position, colour, normal, radiosity, texture coordinates.
    let decode = |v: usize| -> Result<[Vec3; 5], InputError> {
        let base = at + v * record;
        let mut out = [Vec3::ZERO; 5];
        for (f, &offset) in fields.iter().zip(&offsets) {
            let (slot, k) = match f.role {
                Role::Position(k) => (0, k),
                Role::Color(k) if has_colors => (1, k),
                Role::Normal(k) if has_normals => (2, k),
                Role::Radiosity(k) if has_radiosity => (3, k),
                Role::Uv(k) if has_uvs => (4, k),
                _ => continue,
            };
            let PropertyType::Scalar(t) = &f.ty else {
                continue;
            };
            let x = reader.scalar(base + offset, t).unwrap_or(f64::NAN);
            if !x.is_finite() {
                return Err(InputError::byte(
                    path,
                    base as u64,
                    format!("vertex: '{}' = {x} is not finite", f.name),
                ));
            }
            out[slot][k] = x as f32;
        }
        out[1] *= color_scale;
        Ok(out)
    };
    let records: Vec<[Vec3; 5]> = match (0..count)
        .into_par_iter()
        .with_min_len(1 << 14)
        .map(decode)
        .collect::<Result<_, _>>()
    {
        Ok(records) => records,
        // Any thread's error; the first in the file is reported.
        Err(e) => return Err((0..count).find_map(|v| decode(v).err()).unwrap_or(e)),
    };
    let pick = |slot: usize| records.iter().map(|r| r[slot]).collect::<Vec<_>>();
    Ok((
        Vertices {
            positions: pick(0),
            colors: has_colors.then(|| pick(1)),
            normals: has_normals.then(|| pick(2)),
            radiosity: has_radiosity.then(|| pick(3)),
            uvs: has_uvs.then(|| {
                records
                    .iter()
                    .map(|r| super::ply::uv_of(r[4].x, r[4].y))
                    .collect()
            }),
        },
        end,
    ))
}

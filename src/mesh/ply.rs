//! Stanford PLY (ASCII, binary little- and big-endian): the header through ply-rs-bw, an ASCII
//! payload too, a binary payload by `ply_binary`.
//!
//! Before the crate sees the payload, the header's element counts are checked against the file's size,
//! so a truncated binary file is reported with the byte offset where its data runs out, and no count
//! from the header is trusted for an allocation.

use super::{InputError, Location, Mesh};
use glam::Vec3;
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{
    DefaultElement, ElementDef, Encoding, Header, Property, PropertyType, ScalarType,
};
use std::path::Path;

fn scalar_size(t: ScalarType) -> u64 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// Bytes one record of `e` takes at least, and whether every record takes exactly that (no lists).
fn record_size(e: &ElementDef) -> (u64, bool) {
    let mut size = 0;
    let mut fixed = true;
    for p in e.properties.values() {
        match &p.data_type {
            PropertyType::Scalar(t) => size += scalar_size(t.clone()),
            PropertyType::List(count, _) => {
                size += scalar_size(count.clone());
                fixed = false;
            }
        }
    }
    (size, fixed)
}

fn as_f64(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(x) => x as f64,
        Property::UChar(x) => x as f64,
        Property::Short(x) => x as f64,
        Property::UShort(x) => x as f64,
        Property::Int(x) => x as f64,
        Property::UInt(x) => x as f64,
        Property::Float(x) => x as f64,
        Property::Double(x) => x,
        _ => return None,
    })
}

fn as_indices(p: &Property) -> Option<Vec<i64>> {
    Some(match p {
        Property::ListChar(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListUChar(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListShort(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListUShort(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListInt(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListUInt(v) => v.iter().map(|&x| x as i64).collect(),
        _ => return None,
    })
}

/// Where an element's records start: `(base, record size, fixed size)` (see [`record_starts`]).
type RecordStart = (u64, u64, bool);

fn find_header_end(bytes: &[u8]) -> Option<usize> {
    let key = b"end_header";
    let at = bytes.windows(key.len()).position(|w| w == key)?;
    let nl = bytes[at..].iter().position(|&b| b == b'\n')?;
    Some(at + nl + 1)
}

/// The first line of a message from ply-rs-bw, whose errors go on with a multi-line dump of its
/// parser state.
fn first_line(e: &impl std::fmt::Display) -> String {
    let text = e.to_string();
    text.lines().next().unwrap_or_default().trim().to_string()
}

/// What ply-rs-bw accepts silently and vunify does not: an element or a property declared twice
/// (the second would replace the first), and an element that has records but no properties (which
/// take no bytes, so no file size bounds their count). Line numbers are 1-based.
fn check_declarations(header: &[u8], path: &Path) -> Result<(), InputError> {
    let text = String::from_utf8_lossy(header);
    let mut elements: Vec<&str> = Vec::new();
    let mut properties: Vec<&str> = Vec::new();
    let mut records = 0u64;
    let mut declared_at = 0;
    let no_properties = |name: &str, records: u64, line: usize| {
        InputError::line(
            path,
            line,
            format!("element '{name}' has {records} records but no properties"),
        )
    };
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let mut tokens = raw.split_whitespace();
        match tokens.next() {
            Some("element") | Some("end_header") => {
                if let Some(&last) = elements.last()
                    && properties.is_empty()
                    && records > 0
                {
                    return Err(no_properties(last, records, declared_at));
                }
                let Some(name) = tokens.next() else { continue };
                if raw.trim_start().starts_with("end_header") {
                    continue;
                }
                if elements.contains(&name) {
                    return Err(InputError::line(
                        path,
                        line,
                        format!("element '{name}' is declared twice"),
                    ));
                }
                elements.push(name);
                properties.clear();
                records = tokens.next().and_then(|c| c.parse().ok()).unwrap_or(0);
                declared_at = line;
            }
            Some("property") => {
                let Some(name) = tokens.last() else { continue };
                if properties.contains(&name) {
                    let element = elements.last().copied().unwrap_or("?");
                    return Err(InputError::line(
                        path,
                        line,
                        format!("property '{name}' of element '{element}' is declared twice"),
                    ));
                }
                properties.push(name);
            }
            _ => {}
        }
    }
    Ok(())
}

pub fn parse(bytes: &[u8], path: &Path) -> Result<Mesh, InputError> {
    parse_with(bytes, path, true)
}

/// [`parse`], a binary payload read by `ply_binary` when `direct`, else by ply-rs-bw (the tests
/// hold the two to the same meshes).
/// The header, checked, and its length in bytes.
fn read_header(bytes: &[u8], path: &Path) -> Result<(Header, usize), InputError> {
    if !bytes.starts_with(b"ply") {
        return Err(InputError::byte(path, 0, "missing the 'ply' magic line"));
    }
    let header_len = find_header_end(bytes)
        .ok_or_else(|| InputError::whole(path, "no 'end_header' line: the header is truncated"))?;
    let header = Parser::<DefaultElement>::new()
        .read_ply_header(&mut &bytes[..header_len])
        .map_err(|e| match e.line() {
            Some(line) => {
                InputError::line(path, line, format!("bad PLY header: {}", first_line(&e)))
            }
            None => InputError::whole(path, format!("bad PLY header: {}", first_line(&e))),
        })?;
    check_declarations(&bytes[..header_len], path)?;
    Ok((header, header_len))
}

fn parse_with(bytes: &[u8], path: &Path, direct: bool) -> Result<Mesh, InputError> {
    let (header, header_len) = read_header(bytes, path)?;
    let header_lines = bytes[..header_len].iter().filter(|&&b| b == b'\n').count();
    let parser = Parser::<DefaultElement>::new();

    let elements: Vec<&ElementDef> = header.elements.values().collect();
    let binary = header.encoding != Encoding::Ascii;
    let payload_len = (bytes.len() - header_len) as u64;
    let starts = record_starts(
        &elements,
        binary,
        header_len,
        header_lines,
        payload_len,
        path,
    )?;
    if binary && direct {
        let big_endian = header.encoding == Encoding::BinaryBigEndian;
        let mesh = super::ply_binary::parse(bytes, header_len, &elements, big_endian, path)?;
        return Ok(Mesh {
            one_sided: one_sided(&header.comments),
            ..mesh
        });
    }
    let locate = |element: usize, k: usize| -> Location {
        match starts[element] {
            Some((base, _, true)) if !binary => Location::Line((base + k as u64 + 1) as usize),
            Some((base, size, true)) => Location::Byte(header_len as u64 + base + k as u64 * size),
            _ => Location::Whole,
        }
    };

    let ply = parser
        .read_ply(&mut &bytes[..])
        .map_err(|e| match (e.line(), binary) {
            (Some(line), false) => {
                InputError::line(path, line, format!("bad PLY data: {}", first_line(&e)))
            }
            _ => InputError::byte(
                path,
                header_len as u64,
                format!(
                    "bad PLY data in the payload that starts here: {}",
                    first_line(&e)
                ),
            ),
        })?;

    let vi = elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| InputError::whole(path, "no 'vertex' element"))?;
    let fi = elements
        .iter()
        .position(|e| e.name == "face")
        .ok_or_else(|| InputError::whole(path, "no 'face' element"))?;
    let empty = Vec::new();
    let verts = ply.payload.get("vertex").unwrap_or(&empty);
    let faces = ply.payload.get("face").unwrap_or(&empty);

    let bad = |element: usize, k: usize, msg: String| {
        let loc = locate(element, k);
        let what = if elements[element].name == "vertex" {
            "vertex"
        } else {
            "face"
        };
        let msg = match loc {
            Location::Whole => format!("{what} record {k}: {msg}"),
            _ => format!("{what}: {msg}"),
        };
        InputError::new(path, loc, msg)
    };
    let vdef = elements[vi];
    let has = |name: &str| vdef.properties.contains_key(name);
    let has_colors = has("red") && has("green") && has("blue");
    let has_normals = has("nx") && has("ny") && has("nz");
    let has_radiosity = has("radiosity_r") && has("radiosity_g") && has("radiosity_b");
    let uv_names = UV_NAMES.iter().find(|[u, v]| has(u) && has(v));
    let color_scale = color_scale(vdef);

    let mut positions = Vec::with_capacity(verts.len());
    let mut colors = Vec::new();
    let mut normals = Vec::new();
    let mut radiosity = Vec::new();
    let mut uvs = Vec::new();
    let get3 = |v: &DefaultElement, k: usize, names: [&str; 3]| -> Result<Vec3, InputError> {
        let mut out = [0f32; 3];
        for (slot, name) in out.iter_mut().zip(names) {
            let x = v
                .get(name)
                .and_then(as_f64)
                .ok_or_else(|| bad(vi, k, format!("property '{name}' missing or not a number")))?;
            if !x.is_finite() {
                return Err(bad(vi, k, format!("'{name}' = {x} is not finite")));
            }
            *slot = x as f32;
        }
        Ok(Vec3::from_array(out))
    };
    for (k, v) in verts.iter().enumerate() {
        positions.push(get3(v, k, ["x", "y", "z"])?);
        if has_colors {
            colors.push(get3(v, k, ["red", "green", "blue"])? * color_scale);
        }
        if has_normals {
            normals.push(get3(v, k, ["nx", "ny", "nz"])?);
        }
        if has_radiosity {
            radiosity.push(get3(v, k, ["radiosity_r", "radiosity_g", "radiosity_b"])?);
        }
        if let Some([u, w]) = uv_names {
            let uv = get3(v, k, [u, w, "x"])?;
            uvs.push(uv_of(uv.x, uv.y));
        }
    }
    let triangles = fan_triangles(faces, positions.len(), |k, msg| bad(fi, k, msg))?;
    Ok(Mesh {
        colors: has_colors.then_some(colors),
        normals: has_normals.then_some(normals),
        radiosity: has_radiosity.then_some(radiosity),
        uvs: uv_names.map(|_| uvs),
        one_sided: one_sided(&header.comments),
        ..Mesh::from_triangles(positions, triangles)
    })
}

/// What a colour property is multiplied by: 1 for floats, 1/255 for integers.
fn color_scale(vertex: &ElementDef) -> f32 {
    match vertex.properties.get("red").map(|p| &p.data_type) {
        Some(PropertyType::Scalar(ScalarType::Float | ScalarType::Double)) => 1.0,
        _ => 1.0 / 255.0,
    }
}

/// The vertex properties read as texture coordinates, in the order they are looked for.
const UV_NAMES: [[&str; 2]; 4] = [
    ["s", "t"],
    ["u", "v"],
    ["texture_u", "texture_v"],
    ["texture_s", "texture_t"],
];

/// A PLY texture coordinate as vunify keeps it: PLY files (MeshLab's) count `v` from the image's
/// bottom, as OBJ does; vunify from its top, as glTF does.
pub(super) fn uv_of(u: f32, v: f32) -> glam::Vec2 {
    glam::Vec2::new(u, 1.0 - v)
}

/// Gives a PLY with texture coordinates the image its header names (`texture_file`, beside
/// `path`): decoded, baked into the vertex colours as glTF textures are, and made the base colour
/// texture of one material. A missing or unreadable image is a note.
pub(super) fn attach_texture(mesh: &mut Mesh, name: &str, path: &Path, notes: &mut Vec<String>) {
    let Some(uvs) = &mesh.uvs else {
        notes.push(format!(
            "its texture {name} left out: the vertices have no texture coordinates"
        ));
        return;
    };
    let file = path.parent().unwrap_or(Path::new(".")).join(name);
    let image = std::fs::read(&file)
        .map_err(|e| e.to_string())
        .and_then(|b| super::gltf::decode_image(&b));
    let image = match image {
        Ok(image) => image,
        Err(e) => {
            notes.push(format!("its texture {name} left out ({e})"));
            return;
        }
    };
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
    let baked = super::gltf::bake(&image, &positions, uvs, &mesh.triangles);
    let colors = match &mesh.colors {
        Some(c) => c.iter().zip(&baked).map(|(a, b)| *a * *b).collect(),
        None => baked,
    };
    let n = mesh.positions.len();
    let vertex_colors = mesh.colors.is_some();
    mesh.colors = Some(colors);
    mesh.textures = vec![image.file.clone()];
    mesh.texture_of = Some(vec![0; n]);
    mesh.materials = vec![super::Material {
        name: name.to_owned(),
        base_color_texture: Some(0),
        metallic_factor: 0.0,
        vertex_colors,
        ..super::Material::default()
    }];
    mesh.material_of = Some(vec![0; n]);
}

/// The image a textured PLY names in its header (`comment TextureFile NAME`, as MeshLab writes).
pub fn texture_file(bytes: &[u8]) -> Option<String> {
    let end = find_header_end(bytes)?;
    let header = std::str::from_utf8(&bytes[..end]).ok()?;
    header.lines().find_map(|line| {
        let rest = line.trim().strip_prefix("comment")?.trim_start();
        let name = rest.strip_prefix("TextureFile")?.trim();
        (!name.is_empty()).then(|| name.to_owned())
    })
}

/// Whether the header's comments mark the mesh one-sided (a lit mesh from `vunify radiosity`).
fn one_sided(comments: &[String]) -> bool {
    comments
        .iter()
        .any(|c| c.trim_start().starts_with(crate::mesh::ONE_SIDED_COMMENT))
}

/// Where record k of each element starts, when it can be known without reading: `(first line, 1,
/// true)` in ASCII, `(byte offset, record size, true)` for fixed-size binary records, `None` after a
/// variable-size binary element. Checks first that the header's counts fit in the payload (each
/// record takes at least a line or its fixed bytes), so that no count the file cannot hold is ever
/// trusted for an allocation.
fn record_starts(
    elements: &[&ElementDef],
    binary: bool,
    header_len: usize,
    header_lines: usize,
    payload_len: u64,
    path: &Path,
) -> Result<Vec<Option<RecordStart>>, InputError> {
    // Where record k of element e starts, when it can be known without reading (None for variable records).
    let mut starts = Vec::with_capacity(elements.len());
    let mut offset = Some(0u64);
    let mut line = header_lines as u64;
    let mut min_total = 0u64;
    for e in elements {
        let (size, fixed) = record_size(e);
        starts.push(if binary {
            offset.map(|o| (o, size, fixed))
        } else {
            Some((line, 1, true))
        });
        let count = e.count as u64;
        min_total = min_total.saturating_add(if binary {
            count.saturating_mul(size)
        } else {
            count.saturating_mul(2)
        });
        if min_total > payload_len {
            let at = header_len as u64 + payload_len;
            let what = if binary {
                format!("at least {min_total} bytes")
            } else {
                format!("{count} more lines")
            };
            return Err(InputError::byte(
                path,
                at,
                format!(
                    "truncated file: element '{}' ({count} records) needs {what} of payload after the {header_len}-byte header, the file ends here",
                    e.name
                ),
            ));
        }
        offset = if fixed {
            offset.map(|o| o + count * size)
        } else {
            None
        };
        line += count;
    }
    Ok(starts)
}

/// The faces' vertex lists as fans of triangles, each index checked against `vertex_count`; `bad`
/// makes the error for face record k.
fn fan_triangles(
    faces: &[DefaultElement],
    vertex_count: usize,
    bad: impl Fn(usize, String) -> InputError,
) -> Result<Vec<[u32; 3]>, InputError> {
    let mut triangles = Vec::with_capacity(faces.len());
    for (k, f) in faces.iter().enumerate() {
        let idx = f
            .get("vertex_indices")
            .or_else(|| f.get("vertex_index"))
            .and_then(as_indices)
            .ok_or_else(|| bad(k, "no integer list 'vertex_indices'".into()))?;
        if idx.len() < 3 {
            return Err(bad(
                k,
                format!("a face needs at least 3 vertices, found {}", idx.len()),
            ));
        }
        if let Some(&i) = idx.iter().find(|&&i| i < 0 || i as usize >= vertex_count) {
            return Err(bad(
                k,
                format!(
                    "vertex index {i} is out of range (the file has {} vertices)",
                    vertex_count
                ),
            ));
        }
        for j in 1..idx.len() - 1 {
            triangles.push([idx[0] as u32, idx[j] as u32, idx[j + 1] as u32]);
        }
    }
    Ok(triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A binary PLY by hand: vertices with x y z as float or double, colours as uchar, normals, an
    /// extra scalar; faces with an extra list before their indices (uchar count, int or uint
    /// indices, polygons of 3–5 corners); an element of lists after them; either byte order.
    fn binary_ply(seed: u64, big_endian: bool) -> Vec<u8> {
        let mut state = seed | 1;
        let mut random = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let (nv, nf) = (5 + random() % 40, 1 + random() % 60);
        let double = random() % 2 == 0;
        let order = if big_endian { "big" } else { "little" };
        let mut out = format!(
            "ply\nformat binary_{order}_endian 1.0\ncomment one-sided\nelement vertex {nv}\n\
             property {t} x\nproperty {t} y\nproperty {t} z\nproperty float quality\n\
             property uchar red\nproperty uchar green\nproperty uchar blue\n\
             property float nx\nproperty float ny\nproperty float nz\n\
             element face {nf}\nproperty list uchar short tags\nproperty list uchar uint vertex_indices\n\
             element extra 2\nproperty list ushort float values\nend_header\n",
            t = if double { "double" } else { "float" }
        )
        .into_bytes();
        let put = |out: &mut Vec<u8>, mut b: Vec<u8>| {
            if big_endian {
                b.reverse();
            }
            out.extend(b);
        };
        for _ in 0..nv {
            for _ in 0..3 {
                let x = (random() % 2000) as f64 / 7.0 - 100.0;
                if double {
                    put(&mut out, x.to_le_bytes().to_vec());
                } else {
                    put(&mut out, (x as f32).to_le_bytes().to_vec());
                }
            }
            put(&mut out, 0.5f32.to_le_bytes().to_vec());
            for _ in 0..3 {
                out.push((random() % 256) as u8);
            }
            for _ in 0..3 {
                put(
                    &mut out,
                    ((random() % 200) as f32 / 100.0 - 1.0)
                        .to_le_bytes()
                        .to_vec(),
                );
            }
        }
        for _ in 0..nf {
            let tags = (random() % 3) as u8;
            out.push(tags);
            for _ in 0..tags {
                put(&mut out, 7i16.to_le_bytes().to_vec());
            }
            let corners = 3 + (random() % 3) as u8;
            out.push(corners);
            for _ in 0..corners {
                put(&mut out, ((random() % nv) as u32).to_le_bytes().to_vec());
            }
        }
        for _ in 0..2 {
            put(&mut out, 2u16.to_le_bytes().to_vec());
            put(&mut out, 1.5f32.to_le_bytes().to_vec());
            put(&mut out, 2.5f32.to_le_bytes().to_vec());
        }
        out
    }

    /// The direct binary reader makes the mesh ply-rs-bw makes, in either byte order.
    #[test]
    fn the_direct_reader_agrees_with_ply_rs() {
        for seed in 0..40u64 {
            let bytes = binary_ply(seed * 7919 + 1, seed % 2 == 0);
            let path = Path::new("r.ply");
            let direct = parse_with(&bytes, path, true).unwrap();
            let through_crate = parse_with(&bytes, path, false).unwrap();
            assert_eq!(direct.positions, through_crate.positions, "seed {seed}");
            assert_eq!(direct.triangles, through_crate.triangles, "seed {seed}");
            assert_eq!(direct.colors, through_crate.colors, "seed {seed}");
            assert_eq!(direct.normals, through_crate.normals, "seed {seed}");
            assert!(direct.one_sided && through_crate.one_sided);
        }
    }

    /// A face index out of range, a non-finite coordinate and a cut-off payload are errors with
    /// the byte where the record starts (or where the file ends).
    #[test]
    fn direct_reader_errors_name_the_byte() {
        let header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                      property float y\nproperty float z\nelement face 1\n\
                      property list uchar int vertex_indices\nend_header\n";
        let h = header.len();
        let mut bytes = header.as_bytes().to_vec();
        for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
            bytes.extend(v.to_le_bytes());
        }
        bytes.push(3);
        for i in [0i32, 1, 3] {
            bytes.extend(i.to_le_bytes());
        }
        let e = parse(&bytes, Path::new("r.ply")).unwrap_err().to_string();
        assert!(
            e.contains(&format!("byte {}", h + 36)) && e.contains("vertex index 3"),
            "{e}"
        );
        let mut nan = bytes.clone();
        nan[h + 16..h + 20].copy_from_slice(&f32::NAN.to_le_bytes());
        let e = parse(&nan, Path::new("r.ply")).unwrap_err().to_string();
        assert!(
            e.contains(&format!("byte {}", h + 12)) && e.contains("'y'"),
            "{e}"
        );
        let e = parse(&bytes[..bytes.len() - 2], Path::new("r.ply"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("truncated") || e.contains("past the end"), "{e}");
    }
}

//! Wavefront OBJ through tobj.
//!
//! tobj does the parsing proper (objects and groups, polygon triangulation, `v x y z r g b` colours), but
//! its errors carry no line number. So a cheap validating pass runs first and reports the first bad line
//! exactly — malformed numbers, non-finite coordinates, face indices out of range — and tobj only ever
//! sees records that pass it.

use super::{InputError, Mesh, Part};
use glam::Vec3;
use std::path::Path;

pub fn parse(bytes: &[u8], path: &Path) -> Result<Mesh, InputError> {
    // A UTF-8 byte-order mark, as some editors write, is not part of the first record.
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    let declared = validate(bytes, path)?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    // Materials are irrelevant to geometry, and a missing .mtl (beetle.obj names one) is not an error.
    let loaded = tobj::load_obj_buf(&mut std::io::BufReader::new(bytes), &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    });
    let (models, _materials) =
        loaded.map_err(|e| InputError::whole(path, format!("OBJ parse error: {e}")))?;

    let has_colors = models.iter().any(|m| !m.mesh.vertex_color.is_empty());
    let has_normals = models.iter().any(|m| !m.mesh.normals.is_empty());
    let mut mesh = Mesh::default();
    let mut colors = Vec::new();
    let mut normals = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32;
        let count = m.positions.len() / 3;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        if has_colors {
            if m.vertex_color.len() == m.positions.len() {
                colors.extend(
                    m.vertex_color
                        .chunks_exact(3)
                        .map(|c| Vec3::new(c[0], c[1], c[2])),
                );
            } else {
                colors.extend(std::iter::repeat_n(Vec3::ONE, count));
            }
        }
        if has_normals {
            let first = normals.len();
            normals.extend(std::iter::repeat_n(Vec3::ZERO, count));
            if m.normal_indices.len() == m.indices.len() {
                for (&vi, &ni) in m.indices.iter().zip(&m.normal_indices) {
                    let n = m.normals.get(3 * ni as usize..3 * ni as usize + 3);
                    // The first normal a vertex is used with wins.
                    if let (Some(n), Some(slot)) = (n, normals.get_mut(first + vi as usize))
                        && *slot == Vec3::ZERO
                    {
                        *slot = Vec3::new(n[0], n[1], n[2]);
                    }
                }
            }
        }
        let start = mesh.triangles.len() as u32;
        for t in m.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= count) {
                return Err(InputError::whole(
                    path,
                    "OBJ face index out of range after triangulation",
                ));
            }
            mesh.triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
        let end = mesh.triangles.len() as u32;
        if end > start {
            mesh.parts.push(Part {
                name: model.name.clone(),
                triangles: start..end,
            });
        }
    }
    mesh.colors = has_colors.then_some(colors);
    mesh.normals = has_normals.then_some(normals);
    // tobj keeps only the vertices faces use (each object keeps its own); what is left out was unused.
    mesh.unreferenced_vertices = declared.saturating_sub(mesh.positions.len());
    Ok(mesh)
}

/// Checks every `v`, `vn`, `vt` and `f` record; returns the first problem with its line number.
/// Returns the number of `v` records.
fn validate(bytes: &[u8], path: &Path) -> Result<usize, InputError> {
    let text = super::error::utf8_text(bytes, path, "is this really an OBJ file?")?;
    let (mut nv, mut nvt, mut nvn) = (0usize, 0usize, 0usize);
    // Whether the first `v` record has colours (x y z r g b), and its line: every other must agree.
    let mut colored: Option<(bool, usize)> = None;
    // Positive indices may refer forward; they are checked against the final counts at the end.
    let mut max_ref: [(usize, usize); 3] = [(0, 0); 3];
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let mut tokens = raw.split_whitespace();
        let Some(keyword) = tokens.next() else {
            continue;
        };
        let rest: Vec<&str> = tokens.collect();
        let floats = |min: usize, max: usize, what: &str| -> Result<(), InputError> {
            if rest.len() < min || rest.len() > max {
                let want = if min == max {
                    format!("{min}")
                } else {
                    format!("{min} to {max}")
                };
                return Err(InputError::line(
                    path,
                    line,
                    format!("{what}: expected {want} numbers, found {}", rest.len()),
                ));
            }
            for tok in &rest {
                match tok.parse::<f32>() {
                    Ok(x) if x.is_finite() => {}
                    Ok(_) => {
                        return Err(InputError::line(
                            path,
                            line,
                            format!("{what}: coordinate {tok:?} is not finite"),
                        ));
                    }
                    Err(_) => {
                        return Err(InputError::line(
                            path,
                            line,
                            format!("{what}: {tok:?} is not a number"),
                        ));
                    }
                }
            }
            Ok(())
        };
        match keyword {
            "v" => {
                floats(3, 7, "vertex")?;
                if rest.len() == 5 {
                    return Err(InputError::line(
                        path,
                        line,
                        "vertex: expected x y z [w] or x y z r g b, found 5 numbers",
                    ));
                }
                let has_color = rest.len() >= 6;
                match colored {
                    None => colored = Some((has_color, line)),
                    Some((first, at)) if first != has_color => {
                        let (this, that) = if first {
                            ("no colour", "one")
                        } else {
                            ("a colour", "none")
                        };
                        return Err(InputError::line(
                            path,
                            line,
                            format!(
                                "vertex: has {this}, but the first vertex (line {at}) has {that}: give every vertex r g b, or none"
                            ),
                        ));
                    }
                    Some(_) => {}
                }
                nv += 1;
            }
            "vt" => {
                floats(1, 3, "texture coordinate")?;
                nvt += 1;
            }
            "vn" => {
                floats(3, 3, "normal")?;
                nvn += 1;
            }
            "f" => check_face(&rest, line, [nv, nvt, nvn], &mut max_ref, path)?,
            _ => {}
        }
    }
    for (k, total) in [nv, nvt, nvn].into_iter().enumerate() {
        let (idx, line) = max_ref[k];
        if idx > total {
            let kind = ["vertex", "texture coordinate", "normal"][k];
            return Err(InputError::line(
                path,
                line,
                format!("face: {kind} index {idx} is out of range (the file has {total})"),
            ));
        }
    }
    Ok(nv)
}

/// Checks the vertex references of an `f` record on line `line` (`rest`: its tokens after `f`)
/// against the `counts` of vertices, texture coordinates and normals so far; the largest positive
/// index of each kind, and its line, goes to `max_ref` (positive indices may refer forward, so they
/// are checked at the end).
fn check_face(
    rest: &[&str],
    line: usize,
    counts: [usize; 3],
    max_ref: &mut [(usize, usize); 3],
    path: &Path,
) -> Result<(), InputError> {
    if rest.len() < 3 {
        return Err(InputError::line(
            path,
            line,
            format!("face: needs at least 3 vertices, found {}", rest.len()),
        ));
    }
    for tok in rest {
        let parts: Vec<&str> = tok.split('/').collect();
        if parts.len() > 3 || parts[0].is_empty() {
            return Err(InputError::line(
                path,
                line,
                format!("face: malformed vertex reference {tok:?}"),
            ));
        }
        for (k, part) in parts.iter().enumerate() {
            if part.is_empty() {
                continue;
            }
            let idx: i64 = part.parse().map_err(|_| {
                InputError::line(
                    path,
                    line,
                    format!("face: index {part:?} in {tok:?} is not an integer"),
                )
            })?;
            let kind = ["vertex", "texture coordinate", "normal"][k];
            if idx == 0 {
                return Err(InputError::line(
                    path,
                    line,
                    format!("face: {kind} index 0 (OBJ indices start at 1)"),
                ));
            }
            if idx < 0 {
                if idx.unsigned_abs() as usize > counts[k] {
                    return Err(InputError::line(
                        path,
                        line,
                        format!(
                            "face: relative {kind} index {idx} reaches before the first of {} defined so far",
                            counts[k]
                        ),
                    ));
                }
            } else if idx as usize > max_ref[k].0 {
                max_ref[k] = (idx as usize, line);
            }
        }
    }
    Ok(())
}

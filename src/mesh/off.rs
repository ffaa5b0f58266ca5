//! Object File Format (`OFF`, and `COFF` with per-vertex colours), parsed by hand: it is a dozen lines
//! of grammar, and doing it here gives exact line numbers in errors.

use super::{InputError, Mesh};
use glam::Vec3;
use std::path::Path;

struct Lines<'a> {
    inner: std::iter::Enumerate<std::str::Lines<'a>>,
}

impl<'a> Lines<'a> {
    /// The next line with content, comments stripped, with its 1-based number.
    fn next_content(&mut self) -> Option<(usize, Vec<&'a str>)> {
        for (i, raw) in self.inner.by_ref() {
            let body = raw.split('#').next().unwrap_or("");
            let tokens: Vec<&str> = body.split_whitespace().collect();
            if !tokens.is_empty() {
                return Some((i + 1, tokens));
            }
        }
        None
    }
}

pub fn parse(bytes: &[u8], path: &Path) -> Result<Mesh, InputError> {
    let text = super::error::utf8_text(bytes, path, "binary OFF is not supported")?;
    // A UTF-8 byte-order mark, as some editors write, is not part of the header.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = Lines {
        inner: text.lines().enumerate(),
    };
    let eof =
        |what: &str| InputError::whole(path, format!("unexpected end of file: expected {what}"));

    let (line, mut tokens) = lines.next_content().ok_or_else(|| eof("the OFF header"))?;
    let keyword = tokens.remove(0);
    let colored = match keyword {
        "OFF" => false,
        "COFF" => true,
        _ => {
            return Err(InputError::line(
                path,
                line,
                format!("expected OFF or COFF header, found {keyword:?}"),
            ));
        }
    };
    // The counts may follow the keyword on the same line.
    let (line, counts) = if tokens.is_empty() {
        lines
            .next_content()
            .ok_or_else(|| eof("vertex and face counts"))?
    } else {
        (line, tokens)
    };
    if counts.len() < 2 {
        return Err(InputError::line(
            path,
            line,
            "expected the vertex and face counts",
        ));
    }
    let count = |tok: &str, what: &str| -> Result<usize, InputError> {
        tok.parse::<usize>().map_err(|_| {
            InputError::line(
                path,
                line,
                format!("{what} count {tok:?} is not a non-negative integer"),
            )
        })
    };
    let nv = count(counts[0], "vertex")?;
    let nf = count(counts[1], "face")?;
    // Every record takes at least one line, so a count past the line total is a lie; never allocate from it.
    let budget = text.len() / 2 + 1;
    if nv > budget || nf > budget {
        return Err(InputError::line(
            path,
            line,
            format!(
                "counts {nv} vertices / {nf} faces exceed what a file of {} bytes can hold",
                text.len()
            ),
        ));
    }

    let (positions, colors) = read_vertices(&mut lines, nv, colored, path)?;
    let triangles = read_faces(&mut lines, nf, nv, path)?;
    Ok(Mesh {
        colors: colored.then_some(colors),
        normals: None,
        ..Mesh::from_triangles(positions, triangles)
    })
}

/// The `nv` vertex records (`x y z`, and with `colored` `r g b` after them).
fn read_vertices<'t>(
    lines: &mut Lines<'t>,
    nv: usize,
    colored: bool,
    path: &Path,
) -> Result<(Vec<Vec3>, Vec<Vec3>), InputError> {
    let eof =
        |what: &str| InputError::whole(path, format!("unexpected end of file: expected {what}"));
    let mut positions = Vec::with_capacity(nv);
    let mut colors = Vec::new();
    for k in 0..nv {
        let (line, t) = lines
            .next_content()
            .ok_or_else(|| eof(&format!("vertex {} of {nv}", k + 1)))?;
        let want = if colored { 6 } else { 3 };
        if t.len() < want {
            return Err(InputError::line(
                path,
                line,
                format!("vertex: expected {want} numbers, found {}", t.len()),
            ));
        }
        let mut v = [0f32; 7];
        for (slot, tok) in v.iter_mut().zip(t.iter().take(want)) {
            *slot = tok.parse::<f32>().map_err(|_| {
                InputError::line(path, line, format!("vertex: {tok:?} is not a number"))
            })?;
            if !slot.is_finite() {
                return Err(InputError::line(
                    path,
                    line,
                    format!("vertex: coordinate {tok:?} is not finite"),
                ));
            }
        }
        positions.push(Vec3::new(v[0], v[1], v[2]));
        if colored {
            // COFF colours are bytes 0..255 or floats 0..1; anything above 1 is taken as a byte.
            let c = Vec3::new(v[3], v[4], v[5]);
            colors.push(if c.max_element() > 1.0 { c / 255.0 } else { c });
        }
    }
    Ok((positions, colors))
}

/// The `nf` face records (a vertex count, then that many indices below `nv`), as fans of triangles.
fn read_faces<'t>(
    lines: &mut Lines<'t>,
    nf: usize,
    nv: usize,
    path: &Path,
) -> Result<Vec<[u32; 3]>, InputError> {
    let eof =
        |what: &str| InputError::whole(path, format!("unexpected end of file: expected {what}"));
    let mut triangles = Vec::with_capacity(nf);
    for k in 0..nf {
        let (line, t) = lines
            .next_content()
            .ok_or_else(|| eof(&format!("face {} of {nf}", k + 1)))?;
        let n: usize = t[0].parse().map_err(|_| {
            InputError::line(
                path,
                line,
                format!("face: vertex count {:?} is not an integer", t[0]),
            )
        })?;
        if n < 3 {
            return Err(InputError::line(
                path,
                line,
                format!("face: a face needs at least 3 vertices, the count says {n}"),
            ));
        }
        if t.len() - 1 < n {
            return Err(InputError::line(
                path,
                line,
                format!(
                    "face: the count says {n} vertex indices, the line has {}",
                    t.len() - 1
                ),
            ));
        }
        let mut idx = Vec::with_capacity(n);
        for tok in &t[1..=n] {
            let i: usize = tok.parse().map_err(|_| {
                InputError::line(
                    path,
                    line,
                    format!("face: index {tok:?} is not a non-negative integer"),
                )
            })?;
            if i >= nv {
                return Err(InputError::line(
                    path,
                    line,
                    format!("face: vertex index {i} is out of range (the file has {nv} vertices)"),
                ));
            }
            idx.push(i as u32);
        }
        // A convex fan, as every OFF reader does.
        for j in 1..n - 1 {
            triangles.push([idx[0], idx[j], idx[j + 1]]);
        }
    }
    Ok(triangles)
}

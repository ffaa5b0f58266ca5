//! Wavefront OBJ: a parallel reader of our own.
//!
//! The file is cut into pieces at line ends and each piece is parsed on its own thread into plain
//! arrays (positions, colours, normals, face references, object and group names); the pieces are
//! then joined in order. Relative (negative) indices and the one rule that spans the file (every
//! vertex has a colour, or none) are settled while joining, where the counts before each piece are
//! known. Every error names the file, the line and what is wrong; of several, the first in the file.
//!
//! The mesh is the one tobj made before (it read 4–5× slower, and its errors had no line): a part
//! per object or group with faces, each keeping the vertices its faces use in the order they are
//! first used, polygons fanned from their first corner, `v x y z w` divided by `w`, and a vertex's
//! normal the first one a face gives it.

use super::{InputError, Mesh, Part};
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

/// Pieces of at least this many bytes: enough work per thread to pay for the split.
const PIECE: usize = 1 << 20;

pub fn parse(bytes: &[u8], path: &Path) -> Result<Mesh, InputError> {
    // A UTF-8 byte-order mark, as some editors write, is not part of the first record.
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    let text = super::error::utf8_text(bytes, path, "is this really an OBJ file?")?;
    let size = (text.len() / (4 * rayon::current_num_threads())).max(PIECE);
    parse_in_pieces(text, size, path)
}

fn parse_in_pieces(text: &str, size: usize, path: &Path) -> Result<Mesh, InputError> {
    let pieces: Vec<Piece> = split(text, size)
        .into_par_iter()
        .map(|(first_line, text)| Piece::parse(text, first_line))
        .collect();
    join(pieces, path)
}

/// The text in pieces of about `size` bytes, each ending at a line end, with the number of its
/// first line.
fn split(text: &str, size: usize) -> Vec<(usize, &str)> {
    let mut pieces = Vec::new();
    let (mut start, mut line) = (0, 1);
    while start < text.len() {
        // Bytes, not chars: the cut may fall inside a character; the line end never does.
        let from = (start + size).min(text.len());
        let end = match text.as_bytes()[from..].iter().position(|&b| b == b'\n') {
            Some(k) => from + k + 1,
            None => text.len(),
        };
        let piece = &text[start..end];
        pieces.push((line, piece));
        line += piece.bytes().filter(|&b| b == b'\n').count();
        start = end;
    }
    pieces
}

/// A face corner's reference as written: 1-based from the start, or negative from the end so far.
/// Stored as the 0-based index counted from the start of the file (`Abs`) or from the start of the
/// piece (`Rel`, fixed up while joining). A `Rel` beyond `i32`'s range reaches before the file's
/// first vertex, and is reported so from [`Piece::reaching_back`]; it is stored clamped, in eight
/// bytes a corner instead of sixteen (the dragon has 2.6 million corners).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Ref {
    Abs(u32),
    Rel(i32),
    None,
}

const _: () = assert!(std::mem::size_of::<Ref>() == 8);

/// What went wrong on a line, found within a piece.
#[derive(Debug)]
struct LineError {
    line: usize,
    message: String,
}

/// One piece of the file, parsed.
#[derive(Default)]
struct Piece {
    positions: Vec<Vec3>,
    /// Per position: whether it had a colour.
    colors: Vec<Vec3>,
    normals: Vec<Vec3>,
    texcoords: usize,
    /// Face corners: vertex and normal references, `corners` per face. `normal_refs` stays empty
    /// until a corner names a normal (most meshes have none): then it is filled up to that corner.
    vertex_refs: Vec<Ref>,
    normal_refs: Vec<Ref>,
    corners: Vec<u32>,
    /// `o` and `g` records: (faces of this piece before it, name).
    names: Vec<(usize, String)>,
    /// The first `v` record's line and whether it had a colour; the first later one that differs.
    first_vertex: Option<(usize, bool)>,
    differing_vertex: Option<usize>,
    /// Relative references that reach before the piece: (line, kind, how far before, the index).
    reaching_back: Vec<(usize, usize, usize, i64)>,
    /// The largest forward reference of each kind and its line.
    max_ref: [(usize, usize); 3],
    error: Option<LineError>,
}

const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];

impl Piece {
    fn parse(text: &str, first_line: usize) -> Piece {
        let mut piece = Piece::default();
        piece.reserve(text);
        for (i, raw) in text.lines().enumerate() {
            let line = first_line + i;
            if let Err(message) = piece.record(raw, line) {
                piece.error = Some(LineError { line, message });
                break;
            }
        }
        piece
    }

    /// Room for the records a quick look at each line's first letters finds (triangles assumed):
    /// arrays grown by doubling instead copy themselves several times into fresh memory, which on
    /// the dragon was 45,000 of the build's 75,000 page faults.
    fn reserve(&mut self, text: &str) {
        let (mut vertices, mut faces) = (0, 0);
        for line in text.as_bytes().split(|&b| b == b'\n') {
            match line {
                [b'v', b' ' | b'\t', ..] => vertices += 1,
                [b'f', b' ' | b'\t', ..] => faces += 1,
                _ => {}
            }
        }
        self.positions.reserve_exact(vertices);
        self.vertex_refs.reserve_exact(3 * faces);
        self.corners.reserve_exact(faces);
    }

    /// Parses one line.
    fn record(&mut self, raw: &str, line: usize) -> Result<(), String> {
        let mut tokens = raw.split_ascii_whitespace();
        let Some(keyword) = tokens.next() else {
            return Ok(());
        };
        match keyword {
            "v" => {
                let mut v = [0f32; 7];
                let n = numbers(tokens, &mut v, 3, 7, "vertex")?;
                if n == 5 || n == 7 {
                    return Err(format!(
                        "vertex: expected x y z [w] or x y z r g b, found {n} numbers"
                    ));
                }
                let mut p = Vec3::new(v[0], v[1], v[2]);
                if n == 4 {
                    if v[3] == 0.0 {
                        return Err("vertex: its weight w is 0".into());
                    }
                    p /= v[3];
                }
                let colored = n == 6;
                match self.first_vertex {
                    None => self.first_vertex = Some((line, colored)),
                    Some((_, first)) if first != colored && self.differing_vertex.is_none() => {
                        self.differing_vertex = Some(line);
                    }
                    Some(_) => {}
                }
                self.positions.push(p);
                if colored {
                    self.colors.push(Vec3::new(v[3], v[4], v[5]));
                }
            }
            "vt" => {
                numbers(tokens, &mut [0f32; 3], 1, 3, "texture coordinate")?;
                self.texcoords += 1;
            }
            "vn" => {
                let mut n = [0f32; 3];
                numbers(tokens, &mut n, 3, 3, "normal")?;
                self.normals.push(Vec3::from(n));
            }
            "f" => self.face(tokens, line)?,
            "o" | "g" => {
                let name = raw.trim_start()[1..].trim();
                let name = if name.is_empty() {
                    "unnamed_object"
                } else {
                    name
                };
                self.names.push((self.corners.len(), name.to_owned()));
            }
            _ => {}
        }
        Ok(())
    }

    /// An `f` record: at least three corners `v`, `v/vt`, `v//vn` or `v/vt/vn`.
    fn face<'a>(
        &mut self,
        tokens: impl Iterator<Item = &'a str>,
        line: usize,
    ) -> Result<(), String> {
        let counts = [self.positions.len(), self.texcoords, self.normals.len()];
        let mut corners = 0u32;
        for tok in tokens {
            // The common case, a plain positive vertex index (`f 1 2 3`), without the splitting
            // and the general number parsing below (a third of the load's time on the dragon).
            if let Some(i) = plain_index(tok) {
                if i as usize + 1 > self.max_ref[0].0 {
                    self.max_ref[0] = (i as usize + 1, line);
                }
                self.vertex_refs.push(Ref::Abs(i));
                if !self.normal_refs.is_empty() {
                    self.normal_refs.push(Ref::None);
                }
                corners += 1;
                continue;
            }
            let mut parts = tok.split('/');
            let mut refs = [Ref::None; 3];
            for (k, slot) in refs.iter_mut().enumerate() {
                let Some(part) = parts.next() else {
                    break;
                };
                if part.is_empty() {
                    if k == 0 {
                        return Err(format!("face: malformed vertex reference {tok:?}"));
                    }
                    continue;
                }
                let idx: i64 = part
                    .parse()
                    .map_err(|_| format!("face: index {part:?} in {tok:?} is not an integer"))?;
                *slot = match idx {
                    0 => {
                        return Err(format!(
                            "face: {} index 0 (OBJ indices start at 1)",
                            KINDS[k]
                        ));
                    }
                    i if i < 0 => {
                        let at = counts[k] as i64 + i;
                        if at < 0 {
                            self.reaching_back
                                .push((line, k, at.unsigned_abs() as usize, i));
                        }
                        Ref::Rel(at.clamp(i32::MIN as i64, i32::MAX as i64) as i32)
                    }
                    i => {
                        let i = u32::try_from(i - 1)
                            .map_err(|_| format!("face: {} index {i} is out of range", KINDS[k]))?;
                        if i as usize + 1 > self.max_ref[k].0 {
                            self.max_ref[k] = (i as usize + 1, line);
                        }
                        Ref::Abs(i)
                    }
                };
            }
            if parts.next().is_some() {
                return Err(format!("face: malformed vertex reference {tok:?}"));
            }
            self.vertex_refs.push(refs[0]);
            if refs[2] != Ref::None || !self.normal_refs.is_empty() {
                // The corners before the first that names a normal name none.
                self.normal_refs
                    .resize(self.vertex_refs.len() - 1, Ref::None);
                self.normal_refs.push(refs[2]);
            }
            corners += 1;
        }
        if corners < 3 {
            self.vertex_refs
                .truncate(self.vertex_refs.len() - corners as usize);
            self.normal_refs
                .truncate(self.normal_refs.len().min(self.vertex_refs.len()));
            return Err(format!("face: needs at least 3 vertices, found {corners}"));
        }
        self.corners.push(corners);
        Ok(())
    }
}

/// `Some(n - 1)` when `tok` is only the decimal digits of a 1-based index `n` that fits (what the
/// general path would make of it), `None` for everything else, which that path then handles.
fn plain_index(tok: &str) -> Option<u32> {
    if tok.is_empty() {
        return None;
    }
    let mut n: u64 = 0;
    for &b in tok.as_bytes() {
        if !b.is_ascii_digit() {
            return None;
        }
        n = n.checked_mul(10)?.checked_add((b - b'0') as u64)?;
    }
    n.checked_sub(1).and_then(|i| u32::try_from(i).ok())
}

/// Parses `min..=max` finite numbers into `out`; returns how many.
fn numbers<'a>(
    tokens: impl Iterator<Item = &'a str>,
    out: &mut [f32],
    min: usize,
    max: usize,
    what: &str,
) -> Result<usize, String> {
    let mut n = 0;
    for tok in tokens {
        if n < out.len() {
            out[n] = match tok.parse::<f32>() {
                Ok(x) if x.is_finite() => x,
                Ok(_) => return Err(format!("{what}: coordinate {tok:?} is not finite")),
                Err(_) => return Err(format!("{what}: {tok:?} is not a number")),
            };
        }
        n += 1;
    }
    if n < min || n > max {
        let want = if min == max {
            format!("{min}")
        } else {
            format!("{min} to {max}")
        };
        return Err(format!("{what}: expected {want} numbers, found {n}"));
    }
    Ok(n)
}

/// The pieces joined in order into one mesh; the first error in the file, if any.
fn join(pieces: Vec<Piece>, path: &Path) -> Result<Mesh, InputError> {
    let (counts, colored) = check(&pieces, path)?;
    Ok(assemble(&pieces, counts, colored))
}

/// The first problem in the file: each piece's own, then the rules across pieces. Else the counts of
/// vertices, texture coordinates and normals, and whether the vertices have colours.
fn check(pieces: &[Piece], path: &Path) -> Result<([usize; 3], bool), InputError> {
    let mut first: Option<(usize, String)> = None;
    let mut report = |line: usize, message: String| {
        if first.as_ref().is_none_or(|(l, _)| line < *l) {
            first = Some((line, message));
        }
    };
    let mut file_colored: Option<(usize, bool)> = None;
    let mut before = [0usize; 3];
    for piece in pieces {
        if let Some(e) = &piece.error {
            report(e.line, e.message.clone());
        }
        if let Some((line, colored)) = piece.first_vertex {
            let (at, first) = *file_colored.get_or_insert((line, colored));
            let differing = if first != colored {
                Some(line)
            } else {
                piece.differing_vertex
            };
            if let Some(line) = differing {
                let (this, that) = if first {
                    ("no colour", "one")
                } else {
                    ("a colour", "none")
                };
                report(
                    line,
                    format!(
                        "vertex: has {this}, but the first vertex (line {at}) has {that}: give every vertex r g b, or none"
                    ),
                );
            }
        }
        for &(line, k, back, idx) in &piece.reaching_back {
            if back > before[k] {
                report(
                    line,
                    format!(
                        "face: relative {} index {idx} reaches before the first of {} defined so far",
                        KINDS[k],
                        before[k] + (idx.unsigned_abs() as usize - back)
                    ),
                );
            }
        }
        before[0] += piece.positions.len();
        before[1] += piece.texcoords;
        before[2] += piece.normals.len();
    }
    if let Some((line, message)) = first {
        return Err(InputError::line(path, line, message));
    }
    // Forward references, checked against the whole file's counts.
    for k in 0..3 {
        // The largest, at its first line.
        let (idx, line) = pieces
            .iter()
            .map(|p| p.max_ref[k])
            .fold((0, 0), |best, r| if r.0 > best.0 { r } else { best });
        if idx > before[k] {
            return Err(InputError::line(
                path,
                line,
                format!(
                    "face: {} index {idx} is out of range (the file has {})",
                    KINDS[k], before[k]
                ),
            ));
        }
    }

    Ok((before, file_colored.is_some_and(|(_, c)| c)))
}

/// One mesh from pieces that passed [`check`].
fn assemble(pieces: &[Piece], counts: [usize; 3], colored: bool) -> Mesh {
    let declared = counts[0];
    let has_normals = counts[2] > 0;
    let positions: Vec<Vec3> = pieces.iter().flat_map(|p| &p.positions).copied().collect();
    let colors: Vec<Vec3> = pieces.iter().flat_map(|p| &p.colors).copied().collect();
    let normals: Vec<Vec3> = pieces.iter().flat_map(|p| &p.normals).copied().collect();

    // Room for what a one-part mesh needs (each part keeps its own copy of a vertex it shares).
    let triangles: usize = pieces
        .iter()
        .flat_map(|p| &p.corners)
        .map(|&n| n as usize - 2)
        .sum();
    let mut mesh = Mesh {
        positions: Vec::with_capacity(declared),
        triangles: Vec::with_capacity(triangles),
        ..Mesh::default()
    };
    let mut out_colors = Vec::with_capacity(if colored { declared } else { 0 });
    let mut out_normals = Vec::with_capacity(if has_normals { declared } else { 0 });
    // The local index of each file vertex in the current part, valid when its stamp is the part's.
    let mut local = vec![(u32::MAX, 0u32); declared];
    let mut part = Part {
        name: "unnamed_object".to_owned(),
        triangles: 0..0,
    };
    let mut stamp = 0u32;
    // An `o` or `g` record: the part so far ends if it has faces (and the next keeps its own
    // vertices); the name goes to the part that follows.
    let named = |mesh: &mut Mesh, part: &mut Part, stamp: &mut u32, name: &str| {
        let at = mesh.triangles.len() as u32;
        if at > part.triangles.start {
            part.triangles.end = at;
            let next = Part {
                name: String::new(),
                triangles: at..at,
            };
            mesh.parts.push(std::mem::replace(part, next));
            *stamp += 1;
        }
        name.clone_into(&mut part.name);
    };
    let corner_at = |r: Ref, base: usize| -> u32 {
        match r {
            Ref::Abs(i) => i,
            Ref::Rel(i) => (base as i64 + i as i64) as u32,
            Ref::None => u32::MAX,
        }
    };
    let mut base = [0usize; 3];
    for piece in pieces {
        let mut names = piece.names.iter().peekable();
        let mut corner = 0usize;
        for (f, &n) in piece.corners.iter().enumerate() {
            while let Some((_, name)) = names.next_if(|(at, _)| *at <= f) {
                named(&mut mesh, &mut part, &mut stamp, name);
            }
            let range = corner..corner + n as usize;
            corner += n as usize;
            let mut ids = [0u32; 3];
            for (k, c) in range.enumerate() {
                let v = corner_at(piece.vertex_refs[c], base[0]) as usize;
                let slot = &mut local[v];
                if slot.0 != stamp {
                    *slot = (stamp, mesh.positions.len() as u32);
                    mesh.positions.push(positions[v]);
                    if colored {
                        out_colors.push(colors[v]);
                    }
                    if has_normals {
                        out_normals.push(Vec3::ZERO);
                    }
                }
                let id = slot.1;
                if has_normals {
                    let vn = corner_at(
                        piece.normal_refs.get(c).copied().unwrap_or(Ref::None),
                        base[2],
                    );
                    if let (Some(nrm), Some(out)) =
                        (normals.get(vn as usize), out_normals.get_mut(id as usize))
                        && *out == Vec3::ZERO
                    {
                        *out = *nrm;
                    }
                }
                // A fan from the first corner.
                match k {
                    0 | 1 => ids[k] = id,
                    _ => {
                        ids[2] = id;
                        mesh.triangles.push(ids);
                        ids[1] = id;
                    }
                }
            }
        }
        // Names after the piece's last face.
        for (_, name) in names {
            named(&mut mesh, &mut part, &mut stamp, name);
        }
        base[0] += piece.positions.len();
        base[1] += piece.texcoords;
        base[2] += piece.normals.len();
    }
    part.triangles.end = mesh.triangles.len() as u32;
    if !part.triangles.is_empty() {
        mesh.parts.push(part);
    }
    // Colours and normals of no vertex at all are none.
    let any = !mesh.positions.is_empty();
    mesh.colors = (colored && any).then_some(out_colors);
    mesh.normals = (has_normals && any).then_some(out_normals);
    // Only the vertices faces use are kept (each part its own); what is left out was unused.
    mesh.unreferenced_vertices = declared.saturating_sub(mesh.positions.len());
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The fast path reads a plain index as the general path does, and leaves it everything
        /// else (signs, zero, overflow, slashes, other characters).
        #[test]
        fn plain_indices_read_as_the_general_path_reads_them(tok in "(0{0,12}[0-9]{0,12})|[0-9+/a-]{0,12}") {
            let general = tok
                .parse::<i64>()
                .ok()
                .filter(|&i| i > 0)
                .and_then(|i| u32::try_from(i - 1).ok());
            match plain_index(&tok) {
                Some(i) => prop_assert_eq!(Some(i), general),
                None => prop_assert!(general.is_none() || !tok.bytes().all(|b| b.is_ascii_digit())),
            }
        }
    }

    #[test]
    fn plain_index_edges() {
        assert_eq!(plain_index("1"), Some(0));
        assert_eq!(plain_index("007"), Some(6));
        assert_eq!(plain_index("4294967296"), Some(u32::MAX));
        assert_eq!(plain_index("4294967297"), None);
        assert_eq!(plain_index("0000000000001"), Some(0));
        assert_eq!(plain_index("99999999999999999999999"), None);
        assert_eq!(plain_index("0"), None);
        assert_eq!(plain_index(""), None);
        assert_eq!(plain_index("+3"), None);
        assert_eq!(plain_index("3/1"), None);
    }

    /// The mesh tobj makes of `text` (how vunify read OBJ before its own reader).
    fn tobj_mesh(text: &str) -> Mesh {
        let options = tobj::LoadOptions {
            triangulate: true,
            single_index: false,
            ignore_points: true,
            ignore_lines: true,
        };
        let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &options, |_| {
            Err(tobj::LoadError::OpenFileFailed)
        })
        .unwrap();
        let has_colors = models.iter().any(|m| !m.mesh.vertex_color.is_empty());
        let has_normals = models.iter().any(|m| !m.mesh.normals.is_empty());
        let mut mesh = Mesh::default();
        let (mut colors, mut normals) = (Vec::new(), Vec::new());
        for model in &models {
            let m = &model.mesh;
            let base = mesh.positions.len() as u32;
            mesh.positions
                .extend(m.positions.chunks_exact(3).map(Vec3::from_slice));
            colors.extend(m.vertex_color.chunks_exact(3).map(Vec3::from_slice));
            let first = normals.len();
            if has_normals {
                normals.resize(mesh.positions.len(), Vec3::ZERO);
                for (&vi, &ni) in m.indices.iter().zip(&m.normal_indices) {
                    let slot = &mut normals[first + vi as usize];
                    if *slot == Vec3::ZERO {
                        *slot = Vec3::from_slice(&m.normals[3 * ni as usize..][..3]);
                    }
                }
            }
            let start = mesh.triangles.len() as u32;
            mesh.triangles.extend(
                m.indices
                    .chunks_exact(3)
                    .map(|t| [base + t[0], base + t[1], base + t[2]]),
            );
            mesh.parts.push(Part {
                name: model.name.clone(),
                triangles: start..mesh.triangles.len() as u32,
            });
        }
        mesh.colors = has_colors.then_some(colors);
        mesh.normals = has_normals.then_some(normals);
        mesh
    }

    /// A random OBJ: vertices (with colours, or a weight, or neither), normals, objects and groups
    /// between faces of 3–6 corners that refer forwards, backwards and relatively.
    fn obj_text() -> impl Strategy<Value = String> {
        (
            4usize..40,
            0usize..3,
            any::<bool>(),
            proptest::collection::vec((0usize..6, 3usize..7, any::<u64>()), 1..60),
        )
            .prop_map(|(nv, style, normals, records)| {
                let mut s = String::from("# random\n");
                let vertex = |i: usize| match style {
                    0 => format!("v {} {}.5 -{}\n", i, i * 3 % 7, i % 5),
                    1 => format!("v {} {} {} 0.{} 0.5 1\n", i, i % 3, i * 2 % 9, i % 10),
                    _ => format!("v {} {} {} 2\n", i, i % 4, i % 6),
                };
                let mut defined = 0;
                let mut defined_normals = 0;
                for (k, &(kind, corners, seed)) in records.iter().enumerate() {
                    // Vertices come in runs, so that relative indices have something to refer to.
                    while defined < nv && (defined < 3 || kind == 0) {
                        s += &vertex(defined);
                        defined += 1;
                        if normals {
                            s += &format!("vn 0 {} 1\n", defined % 3);
                            defined_normals += 1;
                        }
                        if kind != 0 && defined >= 3 {
                            break;
                        }
                    }
                    match kind {
                        1 => s += &format!("o part{k}\n"),
                        2 => s += &format!("g group{k}\n"),
                        _ => {
                            let mut f = String::from("f");
                            for c in 0..corners {
                                let pick = (seed >> (8 * c)) as usize;
                                let v = pick % defined;
                                let r = if pick.is_multiple_of(3) {
                                    format!("-{}", defined - v)
                                } else {
                                    format!("{}", v + 1)
                                };
                                if normals {
                                    f += &format!(" {r}//{}", 1 + pick % defined_normals);
                                } else {
                                    f += &format!(" {r}");
                                }
                            }
                            s += &f;
                            s += "\n";
                        }
                    }
                }
                while defined < nv {
                    s += &vertex(defined);
                    defined += 1;
                }
                s
            })
    }

    /// The shared models (`$VUNIFY_MODELS`) read as tobj read them, in pieces of 64 KiB.
    #[test]
    fn the_shared_models_read_as_tobj_read_them() {
        let Some(dir) = std::env::var_os("VUNIFY_MODELS") else {
            return;
        };
        let mut seen = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let name = path.to_string_lossy();
            if !(name.ends_with(".obj") || name.ends_with(".obj.xz")) {
                continue;
            }
            let bytes = super::super::read_maybe_xz(&path).unwrap();
            let text = std::str::from_utf8(&bytes).unwrap();
            let want = tobj_mesh(text);
            let got = parse_in_pieces(text, 1 << 16, &path).unwrap();
            assert_eq!(got.positions, want.positions, "{name}");
            assert_eq!(got.triangles, want.triangles, "{name}");
            assert_eq!(got.colors, want.colors, "{name}");
            assert_eq!(got.normals, want.normals, "{name}");
            seen += 1;
        }
        assert!(seen >= 7, "{seen} OBJ models");
    }

    proptest! {
        /// The same mesh as tobj's, whatever the pieces.
        #[test]
        fn the_same_mesh_as_tobj(text in obj_text(), size in 1usize..400) {
            let want = tobj_mesh(&text);
            let got = parse_in_pieces(&text, size, Path::new("r.obj")).unwrap();
            prop_assert_eq!(&got.positions, &want.positions);
            prop_assert_eq!(&got.triangles, &want.triangles);
            prop_assert_eq!(&got.colors, &want.colors);
            prop_assert_eq!(&got.normals, &want.normals);
            let parts = |m: &Mesh| -> Vec<(String, std::ops::Range<u32>)> {
                m.parts.iter().filter(|p| !p.triangles.is_empty()).map(|p| (p.name.clone(), p.triangles.clone())).collect()
            };
            prop_assert_eq!(parts(&got), parts(&want));
        }

        /// Faces that name normals after faces that name none (a piece keeps no normal
        /// references until it meets one):
        /// ```text
        ///  3 ---- 4     f 1 2 3        no normals
        ///  | \    |     f 2 4 3        no normals
        ///  |   \  |     f 2//2 4//1 3//1
        ///  1 ---- 2
        /// ```
        /// Vertex 1 is in no face with normals, so its normal is unknown (zero); the others take
        /// the normal they are first given.
        #[test]
        fn normals_named_only_by_later_faces(size in 1usize..80) {
            let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvn 1 0 0\nf 1 2 3\nf 2 4 3\nf 2//2 4//1 3//1\n";
            let mesh = parse_in_pieces(text, size, Path::new("n.obj")).unwrap();
            prop_assert_eq!(mesh.triangles, vec![[0, 1, 2], [1, 3, 2], [1, 3, 2]]);
            prop_assert_eq!(
                mesh.normals,
                Some(vec![Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::Z])
            );
        }

        /// Errors name the same line whatever the pieces.
        #[test]
        fn errors_do_not_depend_on_the_pieces(text in obj_text(), at in 0usize..60, bad in 0usize..4, size in 1usize..400) {
            let mut lines: Vec<&str> = text.lines().collect();
            let at = at % lines.len();
            let wrong = ["v 1 2", "f 1 2", "vn 1 x 2", "f 1 0 2"][bad];
            lines.insert(at, wrong);
            let text = lines.join("\n");
            let whole = parse_in_pieces(&text, usize::MAX / 2, Path::new("r.obj")).unwrap_err();
            let pieces = parse_in_pieces(&text, size, Path::new("r.obj")).unwrap_err();
            prop_assert_eq!(whole.to_string(), pieces.to_string());
            prop_assert!(whole.to_string().starts_with(&format!("r.obj:{}:", at + 1)), "{}", whole);
        }
    }
}

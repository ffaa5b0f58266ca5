//! The `.vtree` file: little-endian, a section table with a CRC-32 for every byte. See docs/FORMAT.md.
//!
//! The reader trusts nothing: every length is checked against the file size before anything is
//! allocated from it, every checksum is verified, and the tree is checked structurally ([`super::check`])
//! before it is returned. Any single changed byte is detected (CRC-32 catches every burst of ≤ 32 bits,
//! and the sections plus the table cover the file exactly).

use super::section::Body;
use super::table::{Fail, sections};
use super::{Node, PartInfo, VertexTree};
use crate::simplify::Metric;
use std::path::{Path, PathBuf};

pub const MAGIC: [u8; 8] = *b"VUNIFYVT";
/// The newest format version this build reads and writes: 5, the paged, quantised nodes of
/// [`Encoding::Paged`] (sections `PAGE` and `PDAT` instead of `NODE`, `TRIS` and `VOFF`) with the
/// leaves numbered depth-first and each page's leaves in the directory (what a streaming reader
/// needs; version 4, still read, keeps the input's order). An
/// exact file is version 3 with wedges (the optional `WEDG` section, per-corner appearance), 2
/// with appearance but no wedges (the optional `UVTX`, `TEXS` and `MATL` sections), else 1,
/// which readers from before appearance read too.
pub const FORMAT_VERSION: u32 = 6;
/// The version of an exact tree with wedges (see [`Encoding::Exact`]).
const WEDGE_VERSION: u32 = 3;
/// The oldest version this build reads.
pub const OLDEST_FORMAT_VERSION: u32 = 1;
pub(super) const TABLE_ENTRY: usize = 32;
pub(super) const HEADER: usize = 16;
/// Readers of this version accept a few unknown sections (skipped) for forward compatibility.
pub(super) const MAX_SECTIONS: u32 = 16;
pub(super) const META_LEN: usize = 32;
const NODE_LEN: u64 = std::mem::size_of::<Node>() as u64;
pub(super) const FLAG_COLORS: u32 = 1;
pub(super) const FLAG_NORMALS: u32 = 2;
pub(super) const FLAG_ONE_SIDED: u32 = 4;
/// Version 4: the pages store node colours (else every node is white).
pub(super) const FLAG_NODE_COLORS: u32 = 8;
/// The winding is recorded (see [`VertexTree::winds_inward`]), and is inward.
pub(super) const FLAG_WINDING: u32 = 16;
pub(super) const FLAG_INWARD: u32 = 32;

/// The winding META's flags record: `None` for a file from before it was recorded.
pub(super) fn recorded_winding(flags: u32) -> Option<bool> {
    (flags & FLAG_WINDING != 0).then_some(flags & FLAG_INWARD != 0)
}

const SECTIONS: [[u8; 4]; 5] = [*b"META", *b"NODE", *b"TRIS", *b"VOFF", *b"PART"];
/// Version 4's instead: the page directory and the pages (see [`super::paged`]).
const PAGED_SECTIONS: [[u8; 4]; 4] = [*b"META", *b"PAGE", *b"PDAT", *b"PART"];

/// How a file stores the nodes and triangles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Encoding {
    /// In pages of a few thousand nodes, each checked alone, positions, bounds and errors
    /// quantised (errors and bounds widened to hold): about a third of the exact size.
    #[default]
    Paged,
    /// Every node as built (84 bytes, `f32`s), every triangle as three `u32`s.
    Exact,
}

/// Sections a tree may have or not (readers before them skip them): a textured tree's per-node
/// texture coordinates and texture (`u`, `v` as f32, the texture as u32), and its textures (a
/// count, then each as a u64 length and its image file's bytes); and its materials (a u32 length
/// and the materials as JSON, then each node's material as a u32); and its wedges (a u32 count,
/// then per wedge its node and parent as u32, `u`, `v` as f32, texture and material as u32 and
/// colour and normal as three f32 each, one array after another; then each triangle's three leaf wedges as u32);
/// and its wedges' tints (`TINT`: a u32 count, then each wedge's tint of its texture as three f32;
/// only when some textured vertex of the input was tinted: a reader before it draws the textures
/// untinted).
pub(super) const OPTIONAL: [[u8; 4]; 5] = [*b"UVTX", *b"TEXS", *b"MATL", *b"WEDG", *b"TINT"];
/// Bytes of one wedge in `WEDG`.
const WEDGE_LEN: u64 = 48;
const UVTX_LEN: u64 = 12;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FormatErrorKind {
    Io,
    NotAVtree,
    WrongVersion { found: u32 },
    Truncated,
    Checksum,
    Invalid,
}

/// A `.vtree` that cannot be read, with the file, the byte offset when known, and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{}{}: {message}", path.display(), offset.map(|o| format!(": at byte {o}")).unwrap_or_default())]
pub struct FormatError {
    pub path: PathBuf,
    pub offset: Option<u64>,
    pub kind: FormatErrorKind,
    pub message: String,
}

pub(super) fn crc(bytes: &[u8]) -> u32 {
    crc32fast::hash(bytes)
}

/// Serialises a tree exactly.
pub fn to_bytes(tree: &VertexTree) -> Vec<u8> {
    to_bytes_with(tree, Encoding::Exact)
}

/// Serialises a tree with `encoding`.
pub fn to_bytes_with(tree: &VertexTree, encoding: Encoding) -> Vec<u8> {
    let mut out = Vec::new();
    write_to(tree, encoding, None, &mut out).expect("writing to memory cannot fail");
    out
}

/// Writes a tree's file to `out`: the header and the section table (their checksums computed from
/// the tree's arrays), then each section straight from the array that holds it.
/// Writes the file to `out`; the pages of a paged file wait in a temporary file in `spill` when
/// given, else in memory.
fn write_to(
    tree: &VertexTree,
    encoding: Encoding,
    spill: Option<&Path>,
    out: &mut dyn std::io::Write,
) -> std::io::Result<()> {
    let mut meta = Vec::with_capacity(META_LEN);
    let node_colors = encoding == Encoding::Paged && super::paged::any_color(tree);
    let flags = if tree.has_colors { FLAG_COLORS } else { 0 }
        | if tree.has_normals { FLAG_NORMALS } else { 0 }
        | if tree.one_sided { FLAG_ONE_SIDED } else { 0 }
        | if node_colors { FLAG_NODE_COLORS } else { 0 }
        | FLAG_WINDING
        | if tree.winds_inward() { FLAG_INWARD } else { 0 };
    for x in [
        tree.leaf_count,
        tree.nodes.len() as u32,
        tree.triangles.len() as u32,
        tree.metric.code(),
        flags,
        tree.parts.len() as u32,
        0,
        0,
    ] {
        meta.extend_from_slice(&x.to_le_bytes());
    }
    let mut parts = Vec::new();
    for p in &tree.parts {
        parts.extend_from_slice(&p.triangles.to_le_bytes());
        parts.extend_from_slice(&(p.name.len() as u32).to_le_bytes());
        parts.extend_from_slice(p.name.as_bytes());
    }
    // The in-memory layouts are little-endian Pod on every platform vunify targets.
    const { assert!(cfg!(target_endian = "little")) };
    let paged = match encoding {
        Encoding::Paged => Some(super::paged::encode(tree, node_colors, spill)?),
        Encoding::Exact => None,
    };
    crate::memory::trace_phase("encoding");
    // Each section as the pieces it is written from (the pages one after another, never copied
    // into one block: at 14 M triangles that copy was 420 MB on top of the tree).
    let (mut sections, mut tags): (Vec<Body>, Vec<[u8; 4]>) = match &paged {
        None => (
            vec![
                Body::one(&meta),
                Body::one(bytemuck::cast_slice(&tree.nodes)),
                Body::one(bytemuck::cast_slice(&tree.triangles)),
                Body::one(bytemuck::cast_slice(&tree.vanish_offsets)),
                Body::one(&parts),
            ],
            SECTIONS.to_vec(),
        ),
        Some(p) => (
            vec![
                Body::one(&meta),
                Body::one(&p.directory),
                Body::Pages(&p.pages),
                Body::one(&parts),
            ],
            PAGED_SECTIONS.to_vec(),
        ),
    };
    let base_sections = sections.len();
    // The sections that name nodes name them as the pages do: a paged file's leaves depth-first.
    let in_file = paged.as_ref().map(|p| FileOrder::new(&p.leaf_id, tree));
    let (mut uvtx, mut texs) = (Vec::new(), Vec::new());
    if let Some(a) = &tree.appearance {
        uvtx.reserve_exact(12 * a.uvs.len());
        let order = |n: usize| in_file.as_ref().map_or(n, |f| f.node_at(n));
        for (uv, t) in (0..a.uvs.len()).map(|n| (&a.uvs[order(n)], &a.texture_of[order(n)])) {
            uvtx.extend_from_slice(&uv[0].to_le_bytes());
            uvtx.extend_from_slice(&uv[1].to_le_bytes());
            uvtx.extend_from_slice(&t.to_le_bytes());
        }
        texs.extend_from_slice(&(a.textures.len() as u32).to_le_bytes());
        for t in &a.textures {
            texs.extend_from_slice(&(t.len() as u64).to_le_bytes());
            texs.extend_from_slice(t);
        }
        sections.extend([Body::one(&uvtx[..]), Body::one(&texs[..])]);
        tags.extend(&OPTIONAL[..2]);
    }
    let mut matl = Vec::new();
    if let Some(m) = &tree.materials {
        let json = serde_json::to_vec(&m.list).expect("materials serialize");
        matl.extend_from_slice(&(json.len() as u32).to_le_bytes());
        matl.extend_from_slice(&json);
        match &in_file {
            Some(f) => {
                for n in 0..m.of.len() {
                    matl.extend_from_slice(&m.of[f.node_at(n)].to_le_bytes());
                }
            }
            None => matl.extend_from_slice(bytemuck::cast_slice(&m.of)),
        }
        sections.push(Body::one(&matl));
        tags.push(OPTIONAL[2]);
    }
    let wedg = tree.wedges.as_ref().map(|w| match &in_file {
        Some(f) => super::paged::encode_wedges(w, |u| f.ids.id(u)),
        None => wedge_section(w),
    });
    if let Some(w) = &wedg {
        sections.push(Body::one(w));
        tags.push(OPTIONAL[3]);
    }
    let mut tint = Vec::new();
    if let Some(w) = tree.wedges.as_ref().filter(|w| !w.tint.is_empty()) {
        tint.extend_from_slice(&(w.tint.len() as u32).to_le_bytes());
        tint.extend_from_slice(bytemuck::cast_slice(&w.tint));
        sections.push(Body::one(&tint));
        tags.push(OPTIONAL[4]);
    }
    // Appearance is what version 2 added: a reader from before it would skip those sections as
    // unknown and draw the model untextured, so it is told the file is newer instead.
    // Wedges, version 3's, likewise.
    let version = if paged.is_some() {
        FORMAT_VERSION
    } else if tree.wedges.is_some() {
        WEDGE_VERSION
    } else if sections.len() > base_sections {
        2
    } else {
        OLDEST_FORMAT_VERSION
    };
    write_sections(out, version, &tags, &sections)
}

/// The header, the section table (each section's tag, offset, length and CRC-32) and its CRC,
/// then the sections.
fn write_sections(
    out: &mut dyn std::io::Write,
    version: u32,
    tags: &[[u8; 4]],
    sections: &[Body],
) -> std::io::Result<()> {
    let table_end = HEADER + TABLE_ENTRY * sections.len();
    let mut head = Vec::with_capacity(table_end + 4);
    head.extend_from_slice(&MAGIC);
    head.extend_from_slice(&version.to_le_bytes());
    head.extend_from_slice(&(sections.len() as u32).to_le_bytes());
    let mut offset = (table_end + 4) as u64;
    for (tag, body) in tags.iter().zip(sections) {
        let len = body.len();
        head.extend_from_slice(tag);
        head.extend_from_slice(&0u32.to_le_bytes());
        head.extend_from_slice(&offset.to_le_bytes());
        head.extend_from_slice(&len.to_le_bytes());
        head.extend_from_slice(&body.crc().to_le_bytes());
        head.extend_from_slice(&0u32.to_le_bytes());
        offset += len;
    }
    let table_crc = crc(&head);
    head.extend_from_slice(&table_crc.to_le_bytes());
    out.write_all(&head)?;
    for body in sections {
        body.write_to(out)?;
    }
    Ok(())
}

/// The `WEDG` section of an exact file: the count, then each per-wedge array whole, then the
/// corners (a paged file codes it small: [`super::paged::encode_wedges`]).
fn wedge_section(w: &super::Wedges) -> Vec<u8> {
    let mut out = Vec::with_capacity(4 + 48 * w.len() + 12 * w.corners.len());
    out.extend_from_slice(&(w.len() as u32).to_le_bytes());
    out.extend_from_slice(bytemuck::cast_slice(&w.node));
    out.extend_from_slice(bytemuck::cast_slice(&w.parent));
    out.extend_from_slice(bytemuck::cast_slice(&w.uv));
    out.extend_from_slice(bytemuck::cast_slice(&w.texture));
    out.extend_from_slice(bytemuck::cast_slice(&w.material));
    out.extend_from_slice(bytemuck::cast_slice(&w.color));
    out.extend_from_slice(bytemuck::cast_slice(&w.normal));
    out.extend_from_slice(bytemuck::cast_slice(&w.corners));
    out
}

/// A paged file's numbering of a tree's nodes (see [`super::paged::FileIds`]), with the tree's
/// leaf at each of the file's leaf ids: what writing per-node arrays in the file's order reads.
struct FileOrder<'a> {
    ids: super::paged::FileIds<'a>,
    leaf_at: Vec<u32>,
}

impl FileOrder<'_> {
    fn new<'a>(leaf_id: &'a [u32], tree: &VertexTree) -> FileOrder<'a> {
        let mut leaf_at = vec![0u32; tree.leaf_count as usize];
        for (u, &id) in leaf_id.iter().enumerate() {
            leaf_at[id as usize] = u as u32;
        }
        FileOrder {
            ids: super::paged::FileIds { leaf_id },
            leaf_at,
        }
    }

    /// The tree's node at id `n` of the file.
    fn node_at(&self, n: usize) -> usize {
        self.leaf_at.get(n).map_or(n, |&u| u as usize)
    }
}

/// Writes atomically: a temporary file beside `path`, flushed to disk, then renamed over it, so a
/// crash leaves either the old file or the new one, never half of one. A tree that the reader would
/// reject ([`check`](super::check)) is not written: that would be a bug, and it is reported as one.
pub fn write(tree: &VertexTree, path: &Path) -> std::io::Result<()> {
    write_with(tree, path, Encoding::Exact)
}

/// [`write`] with `encoding`.
pub fn write_with(tree: &VertexTree, path: &Path, encoding: Encoding) -> std::io::Result<()> {
    // The consistency check runs alongside the writing; an inconsistent tree never takes the
    // file's place.
    let check = || {
        super::check(tree).map_err(|problem| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!(
                    "the tree is inconsistent, so it was not written (a bug in vunify): {problem}"
                ),
            )
        })
    };
    // The coded pages wait beside the output, not in memory.
    let spill = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    crate::export::write_atomic_checked(
        path,
        |out| write_to(tree, encoding, Some(spill), out),
        check,
    )
}

pub fn read(path: &Path) -> Result<VertexTree, FormatError> {
    let bytes = std::fs::read(path).map_err(|e| FormatError {
        path: path.to_path_buf(),
        offset: None,
        kind: FormatErrorKind::Io,
        message: format!("cannot read: {e}"),
    })?;
    read_bytes(&bytes, path)
}

pub(super) struct Cursor<'a> {
    pub(super) bytes: &'a [u8],
}

impl Cursor<'_> {
    pub(super) fn u32(&self, at: usize) -> u32 {
        u32::from_le_bytes(self.bytes[at..at + 4].try_into().expect("4 bytes"))
    }
    pub(super) fn u64(&self, at: usize) -> u64 {
        u64::from_le_bytes(self.bytes[at..at + 8].try_into().expect("8 bytes"))
    }
}

/// Parses and validates `.vtree` bytes; `path` names the file in errors.
pub fn read_bytes(bytes: &[u8], path: &Path) -> Result<VertexTree, FormatError> {
    let fail = Fail { path };
    let (version, found) = sections(bytes, &fail)?;
    let get = |tag: &[u8; 4]| {
        found
            .iter()
            .find(|(t, _, _)| t == tag)
            .map(|&(_, at, b)| (at, b))
    };
    let need = |tag: &[u8; 4]| {
        get(tag).ok_or_else(|| {
            fail.invalid(format!(
                "section {} is missing",
                String::from_utf8_lossy(tag)
            ))
        })
    };
    let [uvtx, texs, matl, _, tint] = OPTIONAL.map(|t| get(&t).map(|(_, b)| b));
    let (_, meta) = need(b"META")?;
    let (_, part_bytes) = need(b"PART")?;
    if meta.len() != META_LEN {
        return Err(fail.at(
            None,
            FormatErrorKind::Invalid,
            format!("META is {} bytes, expected {META_LEN}", meta.len()),
        ));
    }
    let m = Cursor { bytes: meta };
    let (leaves, nodes, tris, metric, flags, parts) = (
        m.u32(0),
        m.u32(4),
        m.u32(8),
        m.u32(12),
        m.u32(16),
        m.u32(20),
    );
    let metric = Metric::from_code(metric)
        .ok_or_else(|| fail.invalid(format!("unknown metric code {metric}")))?;
    let want = |what: &str, have: usize, count: u64, size: u64| {
        if have as u64 != count * size {
            Err(fail.invalid(format!(
                "section {what} is {have} bytes, but META's counts need {}",
                count * size
            )))
        } else {
            Ok(())
        }
    };
    if leaves == 0 || nodes < leaves {
        return Err(fail.invalid(format!("META says {nodes} nodes for {leaves} leaves")));
    }
    let (node_list, triangles, vanish_offsets, position_error) = if version >= 4 {
        if nodes as u64 != 2 * leaves as u64 - 1 {
            return Err(fail.invalid(format!("META says {nodes} nodes for {leaves} leaves")));
        }
        let (_, dir) = need(b"PAGE")?;
        let (data_at, data) = need(b"PDAT")?;
        let (scale, position_error, entries) =
            super::paged::directory(dir, data.len() as u64, version, |m| fail.invalid(m))?;
        let roots = super::paged::RootLeaves::of(&entries);
        let cx = super::paged::PageContext {
            path,
            leaf_count: leaves,
            node_count: nodes,
            scale,
            colors: flags & FLAG_NODE_COLORS != 0,
            roots: roots.as_ref(),
            turns: version >= super::paged::TURN_VERSION,
        };
        let (n, t, o) = super::paged::decode_all(&cx, &entries, data, data_at)?;
        if t.len() != tris as usize {
            return Err(fail.invalid(format!(
                "the pages hold {} triangles, META says {tris}",
                t.len()
            )));
        }
        (n, t, o, position_error)
    } else {
        let (_, node_bytes) = need(b"NODE")?;
        let (_, tri_bytes) = need(b"TRIS")?;
        let (_, off_bytes) = need(b"VOFF")?;
        want("NODE", node_bytes.len(), nodes as u64, NODE_LEN)?;
        want("TRIS", tri_bytes.len(), tris as u64, 12)?;
        want("VOFF", off_bytes.len(), (nodes - leaves) as u64 + 1, 4)?;
        (
            bytemuck::pod_collect_to_vec(node_bytes),
            bytemuck::pod_collect_to_vec(tri_bytes),
            bytemuck::pod_collect_to_vec(off_bytes),
            0.0,
        )
    };
    let tree = VertexTree {
        leaf_count: leaves,
        nodes: node_list,
        triangles,
        vanish_offsets,
        position_error,
        metric,
        has_colors: flags & FLAG_COLORS != 0,
        has_normals: flags & FLAG_NORMALS != 0,
        one_sided: flags & FLAG_ONE_SIDED != 0,
        inward: recorded_winding(flags),
        parts: part_list(part_bytes, parts, &fail)?,
        appearance: match (uvtx, texs) {
            (Some(uvtx), Some(texs)) => Some(appearance(uvtx, texs, nodes, &fail)?),
            (None, None) => None,
            _ => return Err(fail.invalid("UVTX and TEXS come together".into())),
        },
        materials: None,
        wedges: None,
    };
    let mut tree = tree;
    if let Some(matl) = matl {
        let images = tree.appearance.as_ref().map_or(0, |a| a.textures.len());
        tree.materials = Some(materials(matl, nodes, images, &fail)?);
    }
    tree.wedges = read_wedges(version, get(b"WEDG"), tint, tris, path)?;
    super::check(&tree).map_err(|e| fail.invalid(format!("the tree is inconsistent: {e}")))?;
    Ok(tree)
}

/// The wedges of a file of `version`, from `WEDG` (where it lies in the file, and its bytes)
/// and `TINT`, for `triangles` triangles: the exact layout, or version 5's coded one.
fn read_wedges(
    version: u32,
    wedg: Option<(u64, &[u8])>,
    tint: Option<&[u8]>,
    triangles: u32,
    path: &Path,
) -> Result<Option<super::Wedges>, FormatError> {
    let fail = Fail { path };
    Ok(match (wedg, tint) {
        (Some((at, bytes)), tint) if version >= super::paged::DEPTH_FIRST_VERSION => {
            let mut w = super::paged::decode_wedges(bytes, at, triangles, path)?;
            if let Some(tint) = tint {
                w.tint = tints(tint, w.len(), &fail)?;
            }
            Some(w)
        }
        (Some((_, bytes)), tint) => Some(wedges(bytes, tint, triangles, &fail)?),
        (None, None) => None,
        (None, Some(_)) => return Err(fail.invalid("section TINT without WEDG".into())),
    })
}

/// The pages of a paged (version 4 or 5) file: each page's root and nodes, in file order; an empty
/// list for an exact file. Each page is decoded and checked as [`read_bytes`] does.
pub fn read_pages(bytes: &[u8], path: &Path) -> Result<Vec<super::PageNodes>, FormatError> {
    let fail = Fail { path };
    let (version, found) = sections(bytes, &fail)?;
    if version < 4 {
        return Ok(Vec::new());
    }
    let get = |tag: &[u8; 4]| {
        found
            .iter()
            .find(|(t, _, _)| t == tag)
            .map(|&(_, at, b)| (at, b))
            .ok_or_else(|| {
                fail.invalid(format!(
                    "section {} is missing",
                    String::from_utf8_lossy(tag)
                ))
            })
    };
    let (_, meta) = get(b"META")?;
    let (_, dir) = get(b"PAGE")?;
    let (data_at, data) = get(b"PDAT")?;
    if meta.len() != META_LEN {
        return Err(fail.invalid(format!("META is {} bytes, expected {META_LEN}", meta.len())));
    }
    let m = Cursor { bytes: meta };
    let (scale, _, entries) =
        super::paged::directory(dir, data.len() as u64, version, |m| fail.invalid(m))?;
    let roots = super::paged::RootLeaves::of(&entries);
    let cx = super::paged::PageContext {
        path,
        leaf_count: m.u32(0),
        node_count: m.u32(4),
        scale,
        colors: m.u32(16) & FLAG_NODE_COLORS != 0,
        roots: roots.as_ref(),
        turns: version >= super::paged::TURN_VERSION,
    };
    entries
        .iter()
        .enumerate()
        .map(|(p, e)| {
            let body = &data[e.offset as usize..(e.offset + e.length as u64) as usize];
            let page = super::paged::decode_page(&cx, p, e, body, data_at + e.offset)?;
            Ok(super::PageNodes {
                root: e.root,
                nodes: page.ids,
            })
        })
        .collect()
}

/// The WEDG section with its TINT, their lengths checked (what its numbers mean is checked with the tree, by
/// [`super::check`]).
fn wedges(
    wedg: &[u8],
    tint: Option<&[u8]>,
    triangles: u32,
    fail: &Fail,
) -> Result<super::Wedges, FormatError> {
    let count = (wedg.len() >= 4).then(|| Cursor { bytes: wedg }.u32(0) as u64);
    let want = count.map(|c| 4 + c * WEDGE_LEN + triangles as u64 * 12);
    let Some(count) = count.filter(|_| want == Some(wedg.len() as u64)) else {
        return Err(fail.invalid(format!(
            "section WEDG is {} bytes, which its wedge count and META's triangles do not add up to",
            wedg.len()
        )));
    };
    let count = count as usize;
    let mut at = 4;
    let mut take = |size: usize| {
        let part = &wedg[at..at + count * size];
        at += count * size;
        part
    };
    let (node, parent, uv, texture, material, color, normal) = (
        take(4),
        take(4),
        take(8),
        take(4),
        take(4),
        take(12),
        take(12),
    );
    Ok(super::Wedges {
        node: bytemuck::pod_collect_to_vec(node),
        parent: bytemuck::pod_collect_to_vec(parent),
        uv: bytemuck::pod_collect_to_vec(uv),
        texture: bytemuck::pod_collect_to_vec(texture),
        material: bytemuck::pod_collect_to_vec(material),
        color: bytemuck::pod_collect_to_vec(color),
        normal: bytemuck::pod_collect_to_vec(normal),
        corners: bytemuck::pod_collect_to_vec(&wedg[at..]),
        tint: match tint {
            Some(tint) => tints(tint, count, fail)?,
            None => Vec::new(),
        },
    })
}

/// The TINT section: a tint for each of `count` wedges.
fn tints(tint: &[u8], count: usize, fail: &Fail) -> Result<Vec<[f32; 3]>, FormatError> {
    let said = (tint.len() >= 4).then(|| Cursor { bytes: tint }.u32(0) as usize);
    if said != Some(count) || tint.len() != 4 + count * 12 {
        return Err(fail.invalid(format!(
            "section TINT is {} bytes, which is not a tint for each of the {count} wedges",
            tint.len()
        )));
    }
    Ok(bytemuck::pod_collect_to_vec(&tint[4..]))
}

/// The MATL section, checked: its JSON, one material per node, in range, and every texture in
/// range of the tree's `images`.
fn materials(
    matl: &[u8],
    nodes: u32,
    images: usize,
    fail: &Fail,
) -> Result<super::Materials, FormatError> {
    let c = Cursor { bytes: matl };
    let json_len = (matl.len() >= 4).then(|| c.u32(0) as usize);
    let json = json_len
        .and_then(|l| matl.get(4..4 + l))
        .ok_or_else(|| fail.invalid("section MATL is shorter than its JSON".into()))?;
    let list: Vec<crate::mesh::Material> = serde_json::from_slice(json)
        .map_err(|e| fail.invalid(format!("section MATL's materials: {e}")))?;
    let rest = &matl[4 + json.len()..];
    if rest.len() as u64 != nodes as u64 * 4 {
        return Err(fail.invalid(format!(
            "section MATL has {} bytes of node materials, but META's counts need {}",
            rest.len(),
            nodes as u64 * 4
        )));
    }
    let of: Vec<u32> = bytemuck::pod_collect_to_vec(rest);
    if let Some(i) = of.iter().position(|&m| m as usize >= list.len()) {
        return Err(fail.invalid(format!("node {i}'s material {} is out of range", of[i])));
    }
    if let Some(m) = list
        .iter()
        .find(|m| m.textures().any(|t| t as usize >= images))
    {
        return Err(fail.invalid(format!(
            "material {:?} names a texture the tree does not hold",
            m.name
        )));
    }
    Ok(super::Materials { list, of })
}

/// A textured tree's appearance sections, checked: one entry per node, each texture index in
/// range (or none), and the textures' lengths within their section.
fn appearance(
    uvtx: &[u8],
    texs: &[u8],
    nodes: u32,
    fail: &Fail,
) -> Result<super::Appearance, FormatError> {
    if uvtx.len() as u64 != nodes as u64 * UVTX_LEN {
        return Err(fail.invalid(format!(
            "section UVTX is {} bytes, but META's counts need {}",
            uvtx.len(),
            nodes as u64 * UVTX_LEN
        )));
    }
    let c = Cursor { bytes: texs };
    if texs.len() < 4 {
        return Err(fail.invalid("section TEXS is shorter than its count".into()));
    }
    let count = c.u32(0) as usize;
    let mut textures = Vec::new();
    let mut at = 4usize;
    for k in 0..count {
        let length = (at + 8 <= texs.len())
            .then(|| c.u64(at))
            .and_then(|l| usize::try_from(l).ok())
            .filter(|&l| at + 8 + l <= texs.len())
            .ok_or_else(|| fail.invalid(format!("texture {k} runs past section TEXS")))?;
        textures.push(std::sync::Arc::new(texs[at + 8..at + 8 + length].to_vec()));
        at += 8 + length;
    }
    if at != texs.len() {
        return Err(fail.invalid(format!("{} bytes after the last texture", texs.len() - at)));
    }
    let u = Cursor { bytes: uvtx };
    let mut uvs = Vec::with_capacity(nodes as usize);
    let mut texture_of = Vec::with_capacity(nodes as usize);
    for i in 0..nodes as usize {
        let at = i * UVTX_LEN as usize;
        let uv = [u.u32(at), u.u32(at + 4)].map(f32::from_bits);
        let t = u.u32(at + 8);
        if !uv.iter().all(|x| x.is_finite())
            || (t as usize >= count && t != crate::mesh::NO_TEXTURE)
        {
            return Err(fail.invalid(format!(
                "node {i}'s texture coordinates or texture are invalid"
            )));
        }
        uvs.push(uv);
        texture_of.push(t);
    }
    Ok(super::Appearance {
        uvs,
        texture_of,
        textures,
    })
}

/// The PART section: `count` parts, each a triangle count, a name length and a UTF-8 name.
pub(super) fn part_list(
    part_bytes: &[u8],
    count: u32,
    fail: &Fail,
) -> Result<Vec<PartInfo>, FormatError> {
    let mut parts = Vec::new();
    let mut at = 0usize;
    let p = Cursor { bytes: part_bytes };
    for i in 0..count {
        if at + 8 > part_bytes.len() {
            return Err(fail.invalid(format!("PART ends inside part {i}")));
        }
        let (triangles, name_len) = (p.u32(at), p.u32(at + 4) as usize);
        let name = part_bytes
            .get(at + 8..(at + 8).saturating_add(name_len))
            .ok_or_else(|| fail.invalid(format!("PART: name of part {i} runs past the section")))?;
        let name = std::str::from_utf8(name)
            .map_err(|_| fail.invalid(format!("PART: name of part {i} is not UTF-8")))?;
        parts.push(PartInfo {
            name: name.to_owned(),
            triangles,
        });
        at += 8 + name_len;
    }
    if at != part_bytes.len() {
        return Err(fail.invalid("PART has bytes after its last part".into()));
    }
    Ok(parts)
}

//! Reading pages: each checked alone (its checksum, every id and reference in range, every
//! number finite), and the whole tree from all of them.

use super::codes::*;
use super::{
    DEPTH_FIRST_VERSION, DIRECTORY_ENTRY, DIRECTORY_ENTRY_V4, DIRECTORY_HEAD, PAGE_NODES, PageEntry,
};
use crate::color::srgb_to_linear;
use crate::vtree::format::{FormatError, FormatErrorKind};
use crate::vtree::{NONE, Node};
use glam::Vec3;
use rayon::prelude::*;

/// What decoding a page gives: its nodes (ids and nodes, parents unset) and each internal node's
/// triangles.
pub struct DecodedPage {
    pub ids: Vec<u32>,
    pub nodes: Vec<Node>,
    /// Per internal node of the page, in order, how many triangles; then all of them.
    pub counts: Vec<u32>,
    pub triangles: Vec<[u32; 3]>,
    /// Per node, the leaves under it, `[first, past the last)`, with the file's leaves numbered
    /// depth-first (version 5; empty for version 4).
    pub leaves: Vec<[u32; 2]>,
    /// Per node, how far normals turn below it (see [`super::subtree_turns`]; 0 for a leaf,
    /// rounded up), from version 6; empty before.
    pub turns: Vec<f32>,
}

impl DecodedPage {
    /// The page with only the nodes at the indices `keep` holds (in increasing order), each
    /// with its triangles, leaves and turn: what a reader that needs only part of a page keeps.
    pub fn keep(&self, keep: &[usize]) -> DecodedPage {
        // Internal nodes have the greatest ids, and each a count: they are the page's last.
        let internal_from = self.ids.len() - self.counts.len();
        let mut start = Vec::with_capacity(self.counts.len() + 1);
        start.push(0usize);
        for &c in &self.counts {
            start.push(start.last().copied().unwrap_or(0) + c as usize);
        }
        let mut out = DecodedPage {
            ids: Vec::with_capacity(keep.len()),
            nodes: Vec::with_capacity(keep.len()),
            counts: Vec::new(),
            triangles: Vec::new(),
            leaves: Vec::new(),
            turns: Vec::new(),
        };
        for &i in keep {
            out.ids.push(self.ids[i]);
            out.nodes.push(self.nodes[i]);
            if let Some(&l) = self.leaves.get(i) {
                out.leaves.push(l);
            }
            if let Some(&t) = self.turns.get(i) {
                out.turns.push(t);
            }
            if i >= internal_from {
                let k = i - internal_from;
                out.counts.push(self.counts[k]);
                out.triangles
                    .extend_from_slice(&self.triangles[start[k]..start[k + 1]]);
            }
        }
        out
    }

    /// The bytes its arrays hold, as a cache counts them against its budget.
    pub fn bytes(&self) -> u64 {
        (self.ids.len() * 4
            + self.nodes.len() * std::mem::size_of::<Node>()
            + self.counts.len() * 4
            + self.triangles.len() * 12
            + self.leaves.len() * 8
            + self.turns.len() * 4) as u64
    }
}

/// The leaves under each page's root by the root's id, from the directory of a version 5 file:
/// what a page reads of the pages below it to know its own nodes' leaves.
pub struct RootLeaves(rustc_hash::FxHashMap<u32, [u32; 2]>);

impl RootLeaves {
    /// From the directory's entries; `None` for a version 4 file's, which have none.
    pub fn of(entries: &[PageEntry]) -> Option<RootLeaves> {
        entries
            .iter()
            .map(|e| e.leaves.map(|l| (e.root, l)))
            .collect::<Option<_>>()
            .map(RootLeaves)
    }

    pub fn get(&self, root: u32) -> Option<[u32; 2]> {
        self.0.get(&root).copied()
    }
}

/// Reads a page's (or another coded section's) bytes: a cursor that fails with its offset in
/// the file, naming what it reads (`label`: "page 3").
pub(super) struct Reader<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) at: usize,
    pub(super) base: u64,
    pub(super) label: String,
    pub(super) path: &'a std::path::Path,
}

impl Reader<'_> {
    pub(super) fn fail(&self, what: &str) -> FormatError {
        FormatError {
            path: self.path.to_path_buf(),
            offset: Some(self.base + self.at as u64),
            kind: FormatErrorKind::Invalid,
            message: format!("{}: {what}", self.label),
        }
    }
    pub(super) fn take<const N: usize>(&mut self) -> Result<[u8; N], FormatError> {
        let b = self
            .bytes
            .get(self.at..self.at + N)
            .ok_or_else(|| self.fail("ends too soon"))?;
        self.at += N;
        Ok(b.try_into().expect("N bytes"))
    }
    pub(super) fn u16(&mut self) -> Result<u16, FormatError> {
        Ok(u16::from_le_bytes(self.take()?))
    }
    pub(super) fn f32(&mut self) -> Result<f32, FormatError> {
        Ok(f32::from_le_bytes(self.take()?))
    }
    /// A triangle's corners as [`put_triangle`] codes them, `first` the previous triangle's
    /// first corner (this one's, after). Sums wrap: a damaged number gives a corner out of
    /// range, which the caller refuses, never an overflow.
    pub(super) fn triangle(&mut self, first: &mut i64) -> Result<[i64; 3], FormatError> {
        let c0 = first.wrapping_add(unzigzag(self.varint()?));
        *first = c0;
        let c1 = c0.wrapping_add(unzigzag(self.varint()?));
        let c2 = c0.wrapping_add(unzigzag(self.varint()?));
        Ok([c0, c1, c2])
    }

    pub(super) fn varint(&mut self) -> Result<u64, FormatError> {
        let mut x = 0u64;
        for shift in (0..64).step_by(7) {
            let [b] = self.take()?;
            x |= ((b & 0x7f) as u64) << shift;
            if b & 0x80 == 0 {
                return Ok(x);
            }
        }
        Err(self.fail("a number runs past 64 bits"))
    }
}

/// What every page of a file shares.
pub struct PageContext<'a> {
    pub path: &'a std::path::Path,
    pub leaf_count: u32,
    pub node_count: u32,
    pub scale: f32,
    pub colors: bool,
    /// Version 5's leaves of each page's root (`None` for version 4).
    pub roots: Option<&'a RootLeaves>,
    /// Internal nodes record their subtree's turn (version 6).
    pub turns: bool,
}

/// Decodes page `page` (`bytes`, at `base` in the file, with `entry`), checking its checksum,
/// every id and reference in range and every number finite.
pub fn decode_page(
    cx: &PageContext,
    page: usize,
    entry: &PageEntry,
    bytes: &[u8],
    base: u64,
) -> Result<DecodedPage, FormatError> {
    let mut r = Reader {
        bytes,
        at: 0,
        base,
        label: format!("page {page}"),
        path: cx.path,
    };
    if crc32fast::hash(bytes) != entry.crc {
        return Err(FormatError {
            kind: FormatErrorKind::Checksum,
            ..r.fail("is corrupt (checksum mismatch)")
        });
    }
    let mut v = [0f32; 7];
    for x in &mut v {
        *x = r.f32()?;
    }
    if !v.iter().all(|x| x.is_finite()) || v[6] < 0.0 || v[3..6].iter().any(|&s| s < 0.0) {
        return Err(r.fail("its grid or position error is not finite and non-negative"));
    }
    let grid = Grid {
        lo: Vec3::new(v[0], v[1], v[2]),
        step: Vec3::new(v[3], v[4], v[5]),
        inverse: Vec3::ZERO,
    };
    let leaf_error = v[6];
    let count = entry.nodes as usize;
    if count == 0 || count > PAGE_NODES {
        return Err(r.fail(&format!("{count} nodes; a page holds 1 to {PAGE_NODES}")));
    }
    let mut out = DecodedPage {
        ids: Vec::with_capacity(count),
        nodes: Vec::with_capacity(count),
        counts: Vec::new(),
        triangles: Vec::new(),
        leaves: Vec::new(),
        turns: Vec::new(),
    };
    let (mut previous, mut first_corner) = (0u64, 0i64);
    let mut children: Vec<[u64; 2]> = Vec::new();
    for k in 0..count {
        let id = previous + r.varint()?;
        if (k > 0 && id == previous) || id >= cx.node_count as u64 {
            return Err(r.fail(&format!("node id {id} out of order or range")));
        }
        previous = id;
        let position = grid.decode([r.u16()?, r.u16()?, r.u16()?]);
        let offset = r.take::<3>()?.map(|o| o as i8);
        let radius = decode_scaled(r.u16()?, cx.scale);
        let center = sphere_center(position, offset, radius);
        let normal = normal_of(r.take::<3>()?);
        let [a0, a1, cos] = r.take::<3>()?;
        let axis = oct_decode([a0 as u16, a1 as u16], CONE_BITS);
        let cos = cone_decode(cos);
        let color = if cx.colors {
            r.take::<3>()?.map(|c| srgb_to_linear(c as f32 / 255.0))
        } else {
            [1.0; 3]
        };
        let mut node = Node {
            position: position.to_array(),
            error: leaf_error,
            color,
            parent: NONE,
            normal: normal.to_array(),
            children: [NONE; 2],
            sphere: [center.x, center.y, center.z, radius],
            cone: [axis.x, axis.y, axis.z, cos],
        };
        let mut turn = 0.0;
        if id >= cx.leaf_count as u64 {
            node.error = decode_scaled(r.u16()?, cx.scale);
            if cx.turns {
                turn = super::turn_of_code(r.take::<1>()?[0]);
            }
            children.push([r.varint()?, r.varint()?]);
            let tris = r.varint()?;
            if tris > (bytes.len() - r.at) as u64 {
                return Err(r.fail(&format!("{tris} triangles cannot fit in what is left")));
            }
            out.counts.push(tris as u32);
            for _ in 0..tris {
                let t = r.triangle(&mut first_corner)?;
                if t.iter().any(|&c| c < 0 || c >= cx.leaf_count as i64) {
                    return Err(r.fail(&format!("triangle {t:?} names a leaf out of range")));
                }
                out.triangles.push(t.map(|c| c as u32));
            }
        }
        out.ids.push(id as u32);
        out.nodes.push(node);
        if cx.turns {
            out.turns.push(turn);
        }
    }
    if r.at != bytes.len() {
        return Err(r.fail(&format!("{} bytes after its last node", bytes.len() - r.at)));
    }
    link_children(&mut out, &children, cx.leaf_count, &r)?;
    if let Some(roots) = cx.roots {
        out.leaves = leaves_of(&out, roots, entry, cx.leaf_count, &r)?;
    }
    Ok(out)
}

/// Sets each internal node's children from their codes (`children`, in order): an earlier node
/// of this page by index, or a child page's root by id (below the node's own).
fn link_children(
    out: &mut DecodedPage,
    children: &[[u64; 2]],
    leaf_count: u32,
    r: &Reader,
) -> Result<(), FormatError> {
    let mut k = 0;
    for i in 0..out.ids.len() {
        if out.ids[i] < leaf_count {
            continue;
        }
        for (slot, &c) in children[k].iter().enumerate() {
            let id = if c & 1 == 0 {
                let j = (c / 2) as usize;
                *out.ids.get(j).filter(|_| j < i).ok_or_else(|| {
                    r.fail(&format!("node {} names a child at index {j}", out.ids[i]))
                })?
            } else {
                let id = c / 2;
                if id >= out.ids[i] as u64 {
                    return Err(r.fail(&format!("node {} names a later child {id}", out.ids[i])));
                }
                id as u32
            };
            out.nodes[i].children[slot] = id;
        }
        k += 1;
    }
    Ok(())
}

/// The leaves under each node of `page` (see [`DecodedPage::leaves`]), children first: a leaf's
/// its own id, a page root's from the directory (`roots`), an internal node's its first child's
/// followed at once by its second's. Anything else is not depth-first, and an error; so is a
/// page whose root's leaves are not those `entry` gives it.
fn leaves_of(
    page: &DecodedPage,
    roots: &RootLeaves,
    entry: &PageEntry,
    leaf_count: u32,
    r: &Reader,
) -> Result<Vec<[u32; 2]>, FormatError> {
    let mut leaves: Vec<[u32; 2]> = Vec::with_capacity(page.ids.len());
    for (i, (&id, node)) in page.ids.iter().zip(&page.nodes).enumerate() {
        if id < leaf_count {
            leaves.push([id, id + 1]);
            continue;
        }
        let [a, b] = node
            .children
            .map(|c| match page.ids[..i].binary_search(&c) {
                Ok(j) => Ok(leaves[j]),
                Err(_) => roots
                    .get(c)
                    .ok_or_else(|| r.fail(&format!("node {id}'s child {c} is no page's root"))),
            });
        let (a, b) = (a?, b?);
        if a[1] != b[0] {
            return Err(r.fail(&format!(
                "node {id}'s children hold leaves {}..{} and {}..{}: not numbered depth-first",
                a[0], a[1], b[0], b[1]
            )));
        }
        leaves.push([a[0], b[1]]);
    }
    let root = leaves.last().copied();
    if root != entry.leaves {
        return Err(r.fail(&format!(
            "its root holds leaves {root:?}; the directory says {:?}",
            entry.leaves
        )));
    }
    Ok(leaves)
}

/// The directory: page count, scale, position error and the entries, checked against the length
/// of `PDAT`, tiling it in order.
pub fn directory(
    bytes: &[u8],
    data_len: u64,
    version: u32,
    fail: impl Fn(String) -> FormatError,
) -> Result<(f32, f32, Vec<PageEntry>), FormatError> {
    let depth_first = version >= DEPTH_FIRST_VERSION;
    let entry_len = if depth_first {
        DIRECTORY_ENTRY
    } else {
        DIRECTORY_ENTRY_V4
    };
    if bytes.len() < DIRECTORY_HEAD {
        return Err(fail("PAGE is shorter than its head".into()));
    }
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let count = u32_at(0) as usize;
    let scale = f32::from_bits(u32_at(4));
    let position_error = f32::from_bits(u32_at(8));
    if bytes.len() as u64 != DIRECTORY_HEAD as u64 + count as u64 * entry_len as u64 {
        return Err(fail(format!(
            "PAGE is {} bytes, which {count} pages do not add up to",
            bytes.len()
        )));
    }
    if !(scale.is_finite() && scale > 0.0 && position_error.is_finite() && position_error >= 0.0) {
        return Err(fail(
            "PAGE's scale or position error is not a positive number".into(),
        ));
    }
    let mut entries = Vec::with_capacity(count);
    let mut expected = 0u64;
    for p in 0..count {
        let at = DIRECTORY_HEAD + p * entry_len;
        let entry = PageEntry {
            offset: u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes")),
            length: u32_at(at + 8),
            crc: u32_at(at + 12),
            nodes: u32_at(at + 16),
            root: u32_at(at + 20),
            leaves: depth_first.then(|| [u32_at(at + 24), u32_at(at + 28)]),
        };
        if let Some([first, end]) = entry.leaves
            && first >= end
        {
            return Err(fail(format!("page {p}'s root holds leaves {first}..{end}")));
        }
        if entry.offset != expected || entry.offset + entry.length as u64 > data_len {
            return Err(fail(format!(
                "page {p} at {} ({} bytes) does not follow the one before it inside PDAT",
                entry.offset, entry.length
            )));
        }
        expected += entry.length as u64;
        entries.push(entry);
    }
    if expected != data_len {
        return Err(fail(format!(
            "PDAT has {} bytes after its last page",
            data_len - expected
        )));
    }
    Ok((scale, position_error, entries))
}

/// Checks that the tree's root is the last page's root and, in a version 5 file, holds every
/// leaf (each page checks the rest of its leaves when it is read).
pub fn check_top(entries: &[PageEntry], leaf_count: u32, node_count: u32) -> Result<(), String> {
    let last = entries.last().ok_or("PAGE lists no pages")?;
    if node_count == 0 || last.root != node_count - 1 {
        return Err(format!(
            "the last page's root is node {}, not the tree's root {}",
            last.root,
            node_count - 1
        ));
    }
    match last.leaves {
        Some(l) if l != [0, leaf_count] => Err(format!(
            "the root's page holds leaves {}..{}, not all {leaf_count}",
            l[0], l[1]
        )),
        _ => Ok(()),
    }
}

/// A tree's nodes, triangles and their offsets, as [`decode_all`] returns them.
pub type Decoded = (Vec<Node>, Vec<[u32; 3]>, Vec<u32>);

/// Every page decoded (on every core, a batch at a time) into one tree's nodes, triangles and
/// offsets.
pub fn decode_all(
    cx: &PageContext,
    entries: &[PageEntry],
    data: &[u8],
    data_base: u64,
) -> Result<Decoded, FormatError> {
    let fail = |m: String| FormatError {
        path: cx.path.to_path_buf(),
        offset: None,
        kind: FormatErrorKind::Invalid,
        message: m,
    };
    let total: u64 = entries.iter().map(|e| e.nodes as u64).sum();
    if total != cx.node_count as u64 {
        return Err(fail(format!(
            "the pages hold {total} nodes, META says {}",
            cx.node_count
        )));
    }
    check_top(entries, cx.leaf_count, cx.node_count).map_err(fail)?;
    let n = cx.node_count as usize;
    let leaves = cx.leaf_count as usize;
    let mut nodes = vec![bytemuck::Zeroable::zeroed(); n];
    let mut seen = vec![false; n];
    let mut counts = vec![0u32; n - leaves];
    // Each page's ids of internal nodes and their triangles, until every count is known.
    let mut page_triangles: Vec<(Vec<u32>, Vec<[u32; 3]>)> = Vec::with_capacity(entries.len());
    // A few pages per core at a time: the decoded nodes go to their places, so that only the
    // finished tree and a batch of pages are ever in memory.
    let batch = rayon::current_num_threads() * 8;
    for (first, chunk) in entries.chunks(batch).enumerate() {
        let pages: Vec<DecodedPage> = chunk
            .par_iter()
            .enumerate()
            .map(|(i, e)| {
                let (start, end) = (e.offset as usize, e.offset as usize + e.length as usize);
                let p = first * batch + i;
                decode_page(cx, p, e, &data[start..end], data_base + e.offset)
            })
            .collect::<Result<_, _>>()?;
        for page in pages {
            let mut k = 0;
            let mut internal = Vec::with_capacity(page.counts.len());
            for (&id, node) in page.ids.iter().zip(&page.nodes) {
                let u = id as usize;
                if std::mem::replace(&mut seen[u], true) {
                    return Err(fail(format!("node {u} is in two pages")));
                }
                nodes[u] = *node;
                if u >= leaves {
                    counts[u - leaves] = page.counts[k];
                    internal.push(id);
                    k += 1;
                }
            }
            page_triangles.push((internal, page.triangles));
        }
    }
    let mut offsets = Vec::with_capacity(counts.len() + 1);
    offsets.push(0u32);
    let mut sum = 0u64;
    for &c in &counts {
        sum += c as u64;
        if sum > u32::MAX as u64 {
            return Err(fail("more than 2^32 triangles".into()));
        }
        offsets.push(sum as u32);
    }
    let mut triangles = vec![[0u32; 3]; sum as usize];
    for (internal, tris) in page_triangles {
        let mut at = 0usize;
        for id in internal {
            let k = id as usize - leaves;
            let len = counts[k] as usize;
            let start = offsets[k] as usize;
            triangles[start..start + len].copy_from_slice(&tris[at..at + len]);
            at += len;
        }
    }
    // Parents follow from the children; the tree check that reading ends with confirms the rest.
    for u in leaves..n {
        for c in nodes[u].children {
            if c != NONE && (c as usize) < n {
                nodes[c as usize].parent = u as u32;
            }
        }
    }
    Ok((nodes, triangles, offsets))
}

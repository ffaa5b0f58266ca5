//! A paged file opened for streaming: the header, the section table, `META` and the page
//! directory are read and checked, and nothing of `PDAT` until a page is asked for. `PDAT`'s own
//! checksum covers every page and cannot be checked without reading them all, so each page is
//! checked alone, against its own checksum in the directory, when it is read.

use super::PageEntry;
use super::read::{DecodedPage, PageContext, RootLeaves, check_top, decode_page, directory};
use crate::simplify::Metric;
use crate::vtree::PartInfo;
use crate::vtree::format::{
    FLAG_COLORS, FLAG_NODE_COLORS, FLAG_NORMALS, FLAG_ONE_SIDED, FormatError, FormatErrorKind,
    META_LEN, OPTIONAL, part_list, recorded_winding,
};
use crate::vtree::table::{Fail, HEAD_BYTES, check_body, table};
use glam::Vec3;
use rayon::prelude::*;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// A paged `.vtree` (format version 4 or 5) with its directory in memory and its pages on disk.
pub struct PagedFile {
    path: PathBuf,
    file: Mutex<std::fs::File>,
    pub leaf_count: u32,
    pub node_count: u32,
    /// The file's coordinate scale and largest position error (see [`super::directory`]).
    pub scale: f32,
    pub position_error: f32,
    /// Whether the pages store node colours.
    pub colors: bool,
    pub triangles: u32,
    pub metric: Metric,
    /// META's flags: the input had colours, normals; it is one-sided.
    pub has_colors: bool,
    pub has_normals: bool,
    pub one_sided: bool,
    /// The winding the file records (see [`crate::vtree::VertexTree::winds_inward`]).
    pub inward: Option<bool>,
    pub parts: Vec<PartInfo>,
    /// Whether the file has any section of appearance (texture coordinates, textures,
    /// materials, wedges), which this reader does not read.
    pub appearance: bool,
    pub entries: Vec<PageEntry>,
    /// The file's format version (4 and up).
    pub version: u32,
    /// Version 5's leaves of each page's root (`None` in a version 4 file).
    roots: Option<RootLeaves>,
    /// Where `PDAT` begins in the file.
    data_at: u64,
}

impl PagedFile {
    /// Opens `path`, reading only what every page shares: an exact (older) file, which keeps its
    /// nodes whole, is refused with the advice to rebuild it.
    pub fn open(path: &Path) -> Result<PagedFile, FormatError> {
        let fail = Fail { path };
        let io = |e: std::io::Error, what: &str| {
            fail.at(
                None,
                FormatErrorKind::Io,
                format!("cannot read {what}: {e}"),
            )
        };
        let mut file = std::fs::File::open(path).map_err(|e| io(e, "the file"))?;
        let len = file.metadata().map_err(|e| io(e, "the file"))?.len();
        let mut head = vec![0u8; HEAD_BYTES.min(len as usize)];
        file.read_exact(&mut head)
            .map_err(|e| io(e, "the header"))?;
        let (version, sections) = table(&head, len, &fail)?;
        if version < 4 {
            return Err(fail.at(
                Some(8),
                FormatErrorKind::WrongVersion { found: version },
                format!(
                    "format version {version} keeps its nodes whole, not in pages: rebuild it \
                     with `vunify build` to stream it"
                ),
            ));
        }
        let find = |tag: &[u8; 4]| {
            sections
                .iter()
                .find(|(t, ..)| t == tag)
                .copied()
                .ok_or_else(|| {
                    fail.invalid(format!(
                        "section {} is missing",
                        String::from_utf8_lossy(tag)
                    ))
                })
        };
        let mut body = |tag: &[u8; 4]| -> Result<Vec<u8>, FormatError> {
            let (tag, offset, length, sum) = find(tag)?;
            let mut bytes = vec![0u8; length as usize];
            file.seek(SeekFrom::Start(offset))
                .and_then(|_| file.read_exact(&mut bytes))
                .map_err(|e| io(e, "a section"))?;
            check_body(&tag, offset, &bytes, sum, &fail)?;
            Ok(bytes)
        };
        let meta = body(b"META")?;
        let dir = body(b"PAGE")?;
        let part_bytes = body(b"PART")?;
        let (_, data_at, data_len, _) = find(b"PDAT")?;
        if meta.len() != META_LEN {
            return Err(fail.invalid(format!("META is {} bytes, expected {META_LEN}", meta.len())));
        }
        let u32_at = |i: usize| u32::from_le_bytes(meta[i..i + 4].try_into().expect("4 bytes"));
        let (leaf_count, node_count, triangles, flags) =
            (u32_at(0), u32_at(4), u32_at(8), u32_at(16));
        let metric = Metric::from_code(u32_at(12))
            .ok_or_else(|| fail.invalid(format!("unknown metric code {}", u32_at(12))))?;
        let parts = part_list(&part_bytes, u32_at(20), &fail)?;
        let appearance = sections.iter().any(|(tag, ..)| OPTIONAL.contains(tag));
        if leaf_count == 0 || node_count as u64 != 2 * leaf_count as u64 - 1 {
            return Err(fail.invalid(format!(
                "META says {node_count} nodes for {leaf_count} leaves"
            )));
        }
        let (scale, position_error, entries) =
            directory(&dir, data_len, version, |m| fail.invalid(m))?;
        let total: u64 = entries.iter().map(|e| e.nodes as u64).sum();
        if total != node_count as u64 {
            return Err(fail.invalid(format!(
                "the pages hold {total} nodes, META says {node_count}"
            )));
        }
        check_top(&entries, leaf_count, node_count).map_err(|m| fail.invalid(m))?;
        Ok(PagedFile {
            path: path.to_path_buf(),
            file: Mutex::new(file),
            leaf_count,
            node_count,
            scale,
            position_error,
            colors: flags & FLAG_NODE_COLORS != 0,
            triangles,
            metric,
            has_colors: flags & FLAG_COLORS != 0,
            has_normals: flags & FLAG_NORMALS != 0,
            one_sided: flags & FLAG_ONE_SIDED != 0,
            inward: recorded_winding(flags),
            parts,
            appearance,
            roots: RootLeaves::of(&entries),
            entries,
            version,
            data_at,
        })
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The page each page's root heads, by the root's id.
    pub fn page_of_root(&self) -> rustc_hash::FxHashMap<u32, u32> {
        self.entries
            .iter()
            .enumerate()
            .map(|(p, e)| (e.root, p as u32))
            .collect()
    }

    /// Whether the file numbers its leaves depth-first, each page giving its nodes' leaves
    /// ([`DecodedPage::leaves`]): version 5, what a streaming reader needs.
    pub fn leaves_depth_first(&self) -> bool {
        self.roots.is_some()
    }

    /// Reads and decodes page `page`, checked alone (its checksum, every id and reference in
    /// range, every number finite).
    pub fn read_page(&self, page: usize) -> Result<DecodedPage, FormatError> {
        let fail = Fail { path: &self.path };
        let entry = self.entries.get(page).ok_or_else(|| {
            fail.invalid(format!(
                "page {page} asked for; the file has {}",
                self.entries.len()
            ))
        })?;
        let at = self.data_at + entry.offset;
        let mut bytes = vec![0u8; entry.length as usize];
        {
            let mut file = self.file.lock().unwrap_or_else(|e| e.into_inner());
            file.seek(SeekFrom::Start(at))
                .and_then(|_| file.read_exact(&mut bytes))
                .map_err(|e| {
                    fail.at(
                        Some(at),
                        FormatErrorKind::Io,
                        format!("cannot read page {page}: {e}"),
                    )
                })?;
        }
        let cx = PageContext {
            path: &self.path,
            leaf_count: self.leaf_count,
            node_count: self.node_count,
            scale: self.scale,
            colors: self.colors,
            roots: self.roots.as_ref(),
            turns: self.version >= super::TURN_VERSION,
        };
        decode_page(&cx, page, entry, &bytes, at)
    }

    /// What every node says of the whole tree, as the whole file's reader would (the leaves' box
    /// as [`crate::vtree::VertexTree::leaf_box`], the depth as [`crate::vtree::VertexTree::depth`],
    /// the root), from every page read in turn: a few pages a core in memory at a time, however
    /// large the tree. Pages are read from the root's (the last) down, so that each page's root
    /// knows its depth before its nodes are reached.
    pub fn survey(&self) -> Result<Survey, FormatError> {
        let mut survey = Survey {
            leaf_box: (Vec3::INFINITY, Vec3::NEG_INFINITY),
            depth: 0,
            root: None,
        };
        let root = self.node_count - 1;
        // The depth of each page's root, known once its parent's page is read.
        let mut root_depth = std::collections::HashMap::from([(root, 0u32)]);
        let batch = rayon::current_num_threads() * 4;
        let order: Vec<usize> = (0..self.entries.len()).rev().collect();
        for chunk in order.chunks(batch) {
            let pages: Vec<DecodedPage> = chunk
                .par_iter()
                .map(|&p| self.read_page(p))
                .collect::<Result<_, _>>()?;
            for (page, &p) in pages.iter().zip(chunk) {
                // A page's ids increase, and a parent follows its children (checked when it
                // was decoded): from the last node back, each node's depth is known.
                let mut depth = vec![0u32; page.ids.len()];
                let page_root = self.entries[p].root;
                for i in (0..page.ids.len()).rev() {
                    let (id, node) = (page.ids[i], &page.nodes[i]);
                    if id == page_root {
                        depth[i] = root_depth.remove(&id).ok_or_else(|| {
                            Fail { path: &self.path }
                                .invalid(format!("page {p}'s root {id} has no parent page"))
                        })?;
                    }
                    survey.depth = survey.depth.max(depth[i]);
                    if id == root {
                        survey.root = Some(*node);
                    }
                    if id < self.leaf_count {
                        let (lo, hi) = survey.leaf_box;
                        survey.leaf_box = (lo.min(node.position()), hi.max(node.position()));
                        continue;
                    }
                    for c in node.children {
                        match page.ids[..i].binary_search(&c) {
                            Ok(k) => depth[k] = depth[i] + 1,
                            Err(_) => {
                                root_depth.insert(c, depth[i] + 1);
                            }
                        }
                    }
                }
            }
        }
        Ok(survey)
    }
}

/// What [`PagedFile::survey`] finds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Survey {
    pub leaf_box: (Vec3, Vec3),
    pub depth: u32,
    pub root: Option<crate::vtree::Node>,
}

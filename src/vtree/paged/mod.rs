//! The paged, quantised node layout of `.vtree` versions 4 and 5 (docs/FORMAT.md): the tree cut into
//! *pages*, connected pieces of at most [`PAGE_NODES`] nodes (a page's root and its descendants
//! down to where other pages begin), each stored on its own with its own checksum, so that a
//! reader can fetch the pages it needs and check each alone.
//!
//! Inside a page every number is small: positions and sphere centres as 16-bit fractions of the
//! page's box, normals and cone axes octahedral, errors and radii in a 16-bit float rounded up,
//! ids and triangle corners as variable-length differences. Nothing promised gets weaker: every
//! error grows by how far its page moved its positions, every sphere by how far any position of
//! its subtree moved, every cone by how far its axis turned; the file states the largest position error, and
//! the strict bound adds it (see [`VertexTree::position_error`]).
//!
//! The cut is Kundu and Misra's greedy (*A linear tree partitioning algorithm*, SIAM J. Computing
//! 1977): children before parents, each node's open piece grows by its children's until it would
//! pass the page size, when its heaviest children's pieces close as pages. It makes the fewest
//! pages of a bounded size that are connected.
//!
//! Version 5 numbers the leaves depth-first (a node's first child's leaves before its second's),
//! so that the leaves under any node are a range of ids, and the directory gives each page's
//! root its range: a page read alone knows every one of its nodes' leaves (see
//! [`DecodedPage::leaves`]), and a triangle's corners (leaves) say which node of a cut holds them
//! without the pages below it. A streaming reader needs nothing else to place a triangle.
//! Internal nodes keep the builder's order (a parent after its children).

mod codes;
mod open;
mod read;
mod wedges;
mod write;

pub use open::{PagedFile, Survey};
pub use read::{DecodedPage, PageContext, RootLeaves, decode_all, decode_page, directory};
pub use wedges::{decode_wedges, encode_wedges};
pub use write::{DIRECTORY_HEAD, encode};

use super::{NONE, VertexTree};
use crate::color::srgb8;
use rayon::prelude::*;

/// Nodes at most in a page: a few thousand, as a streaming reader fetches them (about 80 KB).
pub const PAGE_NODES: usize = 4096;
/// Bytes of a page's entry in the directory (`PAGE`): its offset in `PDAT` (u64), length (u32),
/// CRC-32 (u32), node count (u32), root node (u32), and the root's leaves (u32 first, u32 past
/// the last).
pub const DIRECTORY_ENTRY: usize = 32;
/// The entry of version 4, without the leaves.
pub const DIRECTORY_ENTRY_V4: usize = 24;
/// The first version whose leaves are numbered depth-first.
pub const DEPTH_FIRST_VERSION: u32 = 5;
/// The first version whose internal nodes record how far normals turn below them (see
/// [`subtree_turns`]).
pub const TURN_VERSION: u32 = 6;

/// Per node, the largest angle between a node's normal and a child's anywhere in its subtree
/// (0 for a leaf): what the runtime's shading term weighs (see `refine::Hierarchy`), recorded so
/// that a reader of part of the tree knows it for a node whose subtree it has not read. Taken
/// between the normals as the pages store them, which is what every reader sees.
pub fn subtree_turns(tree: &VertexTree) -> Vec<f32> {
    let stored = |u: u32| {
        let n = glam::Vec3::from_array(tree.nodes[u as usize].normal);
        codes::normal_of(codes::normal_bytes(n))
    };
    let mut turn = vec![0f32; tree.nodes.len()];
    for u in tree.leaf_count..tree.nodes.len() as u32 {
        let n = stored(u);
        let mut t = 0f32;
        for c in tree.nodes[u as usize].children {
            let cn = stored(c);
            if n != glam::Vec3::ZERO && cn != glam::Vec3::ZERO {
                t = t.max(n.dot(cn).clamp(-1.0, 1.0).acos());
            }
            t = t.max(turn[c as usize]);
        }
        turn[u as usize] = t;
    }
    turn
}

/// A turn as a page stores it: a byte, in 255ths of a right angle, rounded up (the runtime
/// weighs no turn beyond a right angle).
pub fn turn_code(turn: f32) -> u8 {
    let share = (turn / std::f32::consts::FRAC_PI_2).clamp(0.0, 1.0);
    (share * 255.0).next_up().ceil().min(255.0) as u8
}

/// The turn a stored byte stands for: never less than the turn coded.
pub fn turn_of_code(code: u8) -> f32 {
    (code as f32 / 255.0 * std::f32::consts::FRAC_PI_2).next_up()
}

/// A page's place in the file and what it holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PageEntry {
    pub offset: u64,
    pub length: u32,
    pub crc: u32,
    pub nodes: u32,
    pub root: u32,
    /// The leaves under the page's root, `[first, past the last)` (version 5; `None` in a version
    /// 4 file, whose leaves keep the input's order).
    pub leaves: Option<[u32; 2]>,
}

/// What [`encode`] makes: the directory, and the pages, which the file holds back to back.
pub struct Encoded {
    pub directory: Vec<u8>,
    pub pages: Pages,
    /// Each leaf's id in the file, by its id in the tree (see [`depth_first_leaves`]): what the
    /// sections beside the pages that name nodes renumber them by.
    pub leaf_id: Vec<u32>,
}

/// The coded pages, in page order: in memory, or in a temporary file while a file is written
/// (at a hundred million triangles they are 2.8 GB, which need not share memory with the tree).
pub struct Pages {
    /// Each page's length and CRC-32.
    entries: Vec<(u32, u32)>,
    store: Store,
}

enum Store {
    Memory(Vec<Vec<u8>>),
    /// The pages as they were coded (children's pages first), and where each begins.
    File {
        file: std::fs::File,
        at: Vec<u64>,
    },
}

impl Pages {
    /// Room for `count` pages, in a temporary file in `spill` if given.
    fn new(count: usize, spill: Option<&std::path::Path>) -> std::io::Result<Pages> {
        let store = match spill {
            Some(dir) => Store::File {
                file: tempfile::tempfile_in(dir)?,
                at: vec![0; count],
            },
            None => Store::Memory(vec![Vec::new(); count]),
        };
        Ok(Pages {
            entries: vec![(0, 0); count],
            store,
        })
    }

    /// Page `p`'s bytes, in any order of pages.
    fn put(&mut self, p: usize, body: Vec<u8>) -> std::io::Result<()> {
        self.entries[p] = (body.len() as u32, crc32fast::hash(&body));
        match &mut self.store {
            Store::Memory(pages) => pages[p] = body,
            Store::File { file, at } => {
                use std::io::{Seek, Write};
                at[p] = file.stream_position()?;
                file.write_all(&body)?;
            }
        }
        Ok(())
    }

    /// Each page's length and CRC-32, in page order.
    pub fn entries(&self) -> &[(u32, u32)] {
        &self.entries
    }

    /// The bytes of all pages.
    pub fn bytes(&self) -> u64 {
        self.entries.iter().map(|&(len, _)| len as u64).sum()
    }

    /// The CRC-32 of all pages back to back, from each page's.
    pub fn crc(&self) -> u32 {
        let mut all = crc32fast::Hasher::new();
        for &(len, crc) in &self.entries {
            all.combine(&crc32fast::Hasher::new_with_initial_len(crc, len as u64));
        }
        all.finalize()
    }

    /// Writes the pages back to back in page order.
    pub fn write_to(&self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        match &self.store {
            Store::Memory(pages) => pages.iter().try_for_each(|p| out.write_all(p)),
            Store::File { file, at } => {
                use std::os::unix::fs::FileExt;
                let mut buffer = Vec::new();
                for (&(len, _), &offset) in self.entries.iter().zip(at) {
                    buffer.resize(len as usize, 0);
                    file.read_exact_at(&mut buffer, offset)?;
                    out.write_all(&buffer)?;
                }
                Ok(())
            }
        }
    }
}

/// The pages of `tree`: each node's page, numbered by their roots in increasing order (a page's
/// child pages come before it; the root's page is the last).
pub fn paginate(tree: &VertexTree) -> (Vec<u32>, Vec<u32>) {
    let n = tree.nodes.len();
    let mut weight = vec![1u32; n];
    let mut is_root = vec![false; n];
    for u in tree.leaf_count as usize..n {
        let mut kids = tree.nodes[u].children.map(|c| c as usize);
        if weight[kids[0]] < weight[kids[1]] {
            kids.swap(0, 1);
        }
        let mut w = 1 + weight[kids[0]] + weight[kids[1]];
        for c in kids {
            if w as usize > PAGE_NODES {
                is_root[c] = true;
                w -= weight[c];
            }
        }
        weight[u] = w;
    }
    is_root[n - 1] = true;
    let roots: Vec<u32> = (0..n as u32).filter(|&u| is_root[u as usize]).collect();
    let mut page_of = vec![NONE; n];
    let mut next = roots.len() as u32;
    for u in (0..n).rev() {
        page_of[u] = if is_root[u] {
            next -= 1;
            next
        } else {
            page_of[tree.nodes[u].parent as usize]
        };
    }
    // Pages were numbered from the last root down: page k holds root `roots[k]`.
    (page_of, roots)
}

/// The leaves numbered depth-first, a node's first child before its second: each leaf's new id
/// (by its id in `tree`), and the leaves under each page's root (by page, with `page_of` and
/// `roots` from [`paginate`]) as a range of new ids. Internal nodes keep their ids.
///
/// Two passes over the ids rather than a walk: children before parents, each node's leaf count;
/// then parents before children, each node's first leaf. A walk follows one node to the next, a
/// cache miss each that waits for the one before (seconds at a hundred million nodes); the passes'
/// misses do not wait for each other.
pub fn depth_first_leaves(
    tree: &VertexTree,
    page_of: &[u32],
    roots: &[u32],
) -> (Vec<u32>, Vec<[u32; 2]>) {
    let (leaves, n) = (tree.leaf_count as usize, tree.nodes.len());
    // Each node's leaf count, then (going down) its first leaf: one array, a node's count
    // replaced by its first leaf when its parent is reached.
    let mut at = vec![1u32; n];
    for u in leaves..n {
        at[u] = tree.nodes[u].children.map(|c| at[c as usize]).iter().sum();
    }
    let mut ranges = vec![[0u32; 2]; roots.len()];
    let mut note = |u: u32, first: u32, count: u32| {
        let p = page_of[u as usize] as usize;
        if roots[p] == u {
            ranges[p] = [first, first + count];
        }
    };
    note(tree.root(), 0, at[n - 1]);
    at[n - 1] = 0;
    for u in (leaves..n).rev() {
        let first = at[u];
        let [a, b] = tree.nodes[u].children;
        let count = at[a as usize];
        note(a, first, count);
        note(b, first + count, at[b as usize]);
        at[a as usize] = first;
        at[b as usize] = first + count;
    }
    at.truncate(leaves);
    (at, ranges)
}

/// A paged file's id of each node of a tree: a leaf's depth-first (by [`Encoded::leaf_id`]), an
/// internal node's its own.
#[derive(Clone, Copy)]
pub struct FileIds<'a> {
    pub leaf_id: &'a [u32],
}

impl FileIds<'_> {
    pub fn id(&self, u: u32) -> u32 {
        self.leaf_id.get(u as usize).copied().unwrap_or(u)
    }
}

/// Whether any node's colour differs from white as stored (a build blends white into
/// not-quite-white, which the pages need not store).
pub fn any_color(tree: &VertexTree) -> bool {
    // The least linear value stored as 255 (`srgb8` rises with its argument): a comparison a
    // channel instead of a power.
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if srgb8(mid) == 255 {
            hi = mid
        } else {
            lo = mid
        }
    }
    tree.nodes
        .par_iter()
        .any(|n| n.color.iter().any(|&c| c.is_nan() || c < hi) && n.color.map(srgb8) != [255; 3])
}

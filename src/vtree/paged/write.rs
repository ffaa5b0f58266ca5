//! Writing pages: [`encode`] cuts a tree into pages and codes each on its own.

use super::codes::*;
use super::{DIRECTORY_ENTRY, Encoded, FileIds, PageEntry, Pages, depth_first_leaves, paginate};
use crate::color::srgb8;
use crate::vtree::{NONE, Node, VertexTree};
use glam::Vec3;
use rayon::prelude::*;

/// Pages coded at once, on all cores.
const PAGES_AT_ONCE: usize = 256;

/// Serialises `tree`'s nodes and triangles as pages, its leaves numbered depth-first (see
/// [`depth_first_leaves`]; [`Encoded::leaf_id`] says how). `colors`: whether node colours are
/// stored (white otherwise).
/// The pages wait in a temporary file in `spill` when given, else in memory.
pub fn encode(
    tree: &VertexTree,
    colors: bool,
    spill: Option<&std::path::Path>,
) -> std::io::Result<Encoded> {
    let (page_of, roots) = paginate(tree);
    let (leaf_id, leaves) = depth_first_leaves(tree, &page_of, &roots);
    let n = tree.nodes.len();
    let scale = scale_for(tree.diagonal());
    let renumber = FileIds { leaf_id: &leaf_id };
    let turns: Vec<u8> = super::subtree_turns(tree)
        .into_iter()
        .map(super::turn_code)
        .collect();
    // Each page's nodes by their ids in the file (leaves first, in depth-first order).
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); roots.len()];
    for u in 0..n as u32 {
        members[page_of[u as usize] as usize].push(u);
    }
    members
        .par_iter_mut()
        .for_each(|m| m.sort_unstable_by_key(|&u| renumber.id(u)));
    // Children first, a page at a time: its grid and positions, then each node's error and
    // sphere, grown by what quantising moved, rounded up and never below a child's; then the
    // page's bytes. Pages in waves, each page's child pages in earlier waves: a wave's pages on
    // every core, each page's scattered nodes read into cache once for all three.
    let shared = Shared {
        page_of: &page_of,
        renumber,
        scale,
        colors,
        turns: &turns,
    };
    let mut done = Done {
        roots: vec![Stored::default(); roots.len()],
        page_error: vec![0f32; roots.len()],
    };
    let mut bodies = Pages::new(roots.len(), spill)?;
    // A few hundred pages at a time: the first wave is most pages, and holding all of their
    // bytes and codes at once was half a gigabyte at 14 M triangles.
    for wave in waves(tree, &members, &page_of) {
        for some in wave.chunks(PAGES_AT_ONCE) {
            let pages: Vec<(usize, Stored, f32, Vec<u8>)> = some
                .par_iter()
                .map(|&p| {
                    let page = PageWriter::new(tree, &members[p], p as u32, shared);
                    let codes = page.codes(&done);
                    let body = page.write(&codes);
                    // The page's root is its last node (a parent's id is above its children's).
                    let root = codes.stored(members[p].len() - 1);
                    (p, root, codes.page_error, body)
                })
                .collect();
            for (p, root, page_error, body) in pages {
                done.roots[p] = root;
                done.page_error[p] = page_error;
                bodies.put(p, body)?;
            }
        }
    }
    let position_error = done.page_error.iter().copied().fold(0.0, f32::max);
    let mut directory = Vec::with_capacity(4 + roots.len() * DIRECTORY_ENTRY);
    directory.extend_from_slice(&(roots.len() as u32).to_le_bytes());
    directory.extend_from_slice(&scale.to_le_bytes());
    directory.extend_from_slice(&position_error.to_le_bytes());
    let mut offset = 0u64;
    for (p, &(length, crc)) in bodies.entries().iter().enumerate() {
        let entry = PageEntry {
            offset,
            length,
            crc,
            nodes: members[p].len() as u32,
            root: renumber.id(roots[p]),
            leaves: Some(leaves[p]),
        };
        directory.extend_from_slice(&entry.offset.to_le_bytes());
        directory.extend_from_slice(&entry.length.to_le_bytes());
        directory.extend_from_slice(&entry.crc.to_le_bytes());
        directory.extend_from_slice(&entry.nodes.to_le_bytes());
        directory.extend_from_slice(&entry.root.to_le_bytes());
        for x in leaves[p] {
            directory.extend_from_slice(&x.to_le_bytes());
        }
        offset += length as u64;
    }
    Ok(Encoded {
        directory,
        pages: bodies,
        leaf_id,
    })
}

/// Bytes of the directory before its entries: page count (u32), scale (f32), position error (f32).
pub const DIRECTORY_HEAD: usize = 12;

struct PageWriter<'a> {
    tree: &'a VertexTree,
    /// The page's nodes, in increasing id in the file.
    ids: &'a [u32],
    /// Their ids in the file.
    file_ids: Vec<u32>,
    page: u32,
    page_of: &'a [u32],
    renumber: FileIds<'a>,
    /// The page's grid, over its nodes' positions.
    grid: Grid,
    scale: f32,
    colors: bool,
    /// Every node's [`super::turn_code`], by its id in the tree.
    turns: &'a [u8],
}

/// What the pages of earlier waves left, per page: what its parent page reads of its root (a
/// page reads no other node of another page), and its position error.
struct Done {
    roots: Vec<Stored>,
    page_error: Vec<f32>,
}

/// A node as its page stores it: its error's and sphere's codes, its position as stored, and how
/// far any stored position of its subtree lies from the tree's.
#[derive(Clone, Copy, Default)]
struct Stored {
    error: u16,
    sphere: ([i8; 3], u16),
    position: Vec3,
    moved: f32,
}

/// A page's nodes' codes and stored positions, in the page's order, and its position error.
struct Codes {
    errors: Vec<u16>,
    spheres: Vec<([i8; 3], u16)>,
    positions: Vec<Vec3>,
    moved: Vec<f32>,
    page_error: f32,
}

impl Codes {
    /// The page's `k`-th node as stored.
    fn stored(&self, k: usize) -> Stored {
        Stored {
            error: self.errors[k],
            sphere: self.spheres[k],
            position: self.positions[k],
            moved: self.moved[k],
        }
    }
}

/// The pages in waves: each page after every page below it (its child pages have smaller
/// numbers, so one pass in order finds each page's height).
fn waves(tree: &VertexTree, members: &[Vec<u32>], page_of: &[u32]) -> Vec<Vec<usize>> {
    let mut height = vec![0usize; members.len()];
    for (p, m) in members.iter().enumerate() {
        for &u in m {
            for c in tree.nodes[u as usize].children {
                if c != NONE && page_of[c as usize] as usize != p {
                    height[p] = height[p].max(height[page_of[c as usize] as usize] + 1);
                }
            }
        }
    }
    let mut out = vec![Vec::new(); height.iter().max().map_or(0, |h| h + 1)];
    for (p, &h) in height.iter().enumerate() {
        out[h].push(p);
    }
    out
}

/// What every page of one file is written with.
#[derive(Clone, Copy)]
struct Shared<'a> {
    page_of: &'a [u32],
    renumber: FileIds<'a>,
    scale: f32,
    colors: bool,
    turns: &'a [u8],
}

impl<'a> PageWriter<'a> {
    fn new(tree: &'a VertexTree, ids: &'a [u32], page: u32, shared: Shared<'a>) -> PageWriter<'a> {
        let Shared {
            page_of,
            renumber,
            scale,
            colors,
            turns,
        } = shared;
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for (k, &u) in ids.iter().enumerate() {
            if let Some(&ahead) = ids.get(k + 8) {
                crate::prefetch(&tree.nodes[ahead as usize]);
            }
            let p = tree.nodes[u as usize].position();
            lo = lo.min(p);
            hi = hi.max(p);
        }
        PageWriter {
            tree,
            ids,
            file_ids: ids.iter().map(|&u| renumber.id(u)).collect(),
            page,
            page_of,
            renumber,
            grid: Grid::new(lo, hi),
            scale,
            colors,
            turns,
        }
    }

    /// A node's index in the page, if it is in it: its place among the page's ids in the file.
    fn local(&self, u: u32) -> Option<usize> {
        if self.page_of[u as usize] != self.page {
            return None;
        }
        self.file_ids.binary_search(&self.renumber.id(u)).ok()
    }

    /// The page's nodes' codes, children first (ids increase): a child in this page from this
    /// page's codes so far, one in a child page from what earlier waves left (`done`).
    fn codes(&self, done: &Done) -> Codes {
        let (tree, scale, leaves) = (self.tree, self.scale, self.tree.leaf_count);
        let positions: Vec<Vec3> = self
            .ids
            .iter()
            .map(|&u| {
                self.grid
                    .decode(self.grid.encode(tree.nodes[u as usize].position()))
            })
            .collect();
        let moved = self
            .ids
            .iter()
            .zip(&positions)
            .map(|(&u, p)| p.distance(tree.nodes[u as usize].position()))
            .fold(0.0f32, f32::max);
        let page_error = if moved > 0.0 {
            (moved * (1.0 + 1e-5)).next_up()
        } else {
            0.0
        };
        let mut codes = Codes {
            errors: Vec::with_capacity(self.ids.len()),
            spheres: Vec::with_capacity(self.ids.len()),
            positions,
            moved: Vec::with_capacity(self.ids.len()),
            page_error,
        };
        for (k, &u) in self.ids.iter().enumerate() {
            let node = &tree.nodes[u as usize];
            let sphere = (Vec3::from_slice(&node.sphere), node.sphere[3]);
            let position = codes.positions[k];
            if u < leaves {
                let stored = store_sphere(position, sphere, page_error, &[], scale);
                codes.spheres.push(stored);
                codes.errors.push(0);
                codes.moved.push(page_error);
                continue;
            }
            let mut e = node.error + page_error;
            let mut below = page_error;
            let children = node.children.map(|c| {
                let child = match self.local(c) {
                    Some(j) => codes.stored(j),
                    None => done.roots[self.page_of[c as usize] as usize],
                };
                let (error, (offset, code), at, moved) =
                    (child.error, child.sphere, child.position, child.moved);
                e = e.max(if c < leaves {
                    let p = self.page_of[c as usize];
                    if p == self.page {
                        page_error
                    } else {
                        done.page_error[p as usize]
                    }
                } else {
                    decode_scaled(error, scale)
                });
                below = below.max(moved);
                let r = decode_scaled(code, scale);
                (sphere_center(at, offset, r), r)
            });
            codes
                .spheres
                .push(store_sphere(position, sphere, below, &children, scale));
            codes.moved.push(below);
            codes
                .errors
                .push(encode_scaled_up(e, scale).expect("errors lie within 2^8 of the extent"));
        }
        codes
    }

    /// A page: its grid (lo, step as f32 × 3 each) and position error (f32), then per node in
    /// increasing id: the id's difference from the previous (varint), position (u16 × 3), sphere
    /// centre's offset from it (i8 × 3, in 127ths of the radius), radius (u16), normal (two 12-bit
    /// octahedral components in three bytes, the first's low byte, then the first's high nibble
    /// and the second's low, then the second's high byte), cone axis (u8 × 2) and cosine
    /// (u8), colour (u8 × 3, sRGB) if the file has colours; then for an internal node its error
    /// (u16), both children (varint: twice the index in this page, or twice the id plus one for a
    /// child page's root), its triangle count (varint) and its triangles (varints: the first
    /// corner's difference from the page's previous first corner, the others' from the first,
    /// zigzagged).
    fn write(&self, codes: &Codes) -> Vec<u8> {
        let tree = self.tree;
        let mut out = Vec::with_capacity(self.ids.len() * 28);
        for x in [self.grid.lo, self.grid.step] {
            for k in 0..3 {
                out.extend_from_slice(&x[k].to_le_bytes());
            }
        }
        out.extend_from_slice(&codes.page_error.to_le_bytes());
        let (mut previous, mut first_corner) = (0u64, 0i64);
        let leaves = tree.leaf_count;
        for (k, &u) in self.ids.iter().enumerate() {
            // The nodes' triangles are scattered: ask for their offsets, then for them, ahead.
            if let Some(&ahead) = self.ids.get(k + 16).filter(|&&a| a >= leaves) {
                crate::prefetch(&tree.vanish_offsets[(ahead - leaves) as usize]);
            }
            if let Some(&ahead) = self.ids.get(k + 8).filter(|&&a| a >= leaves) {
                let start = tree.vanish_offsets[(ahead - leaves) as usize] as usize;
                if let Some(t) = tree.triangles.get(start) {
                    crate::prefetch(t);
                }
            }
            let node = &tree.nodes[u as usize];
            let id = self.file_ids[k] as u64;
            put_varint(&mut out, id - previous);
            previous = id;
            for c in self.grid.encode(node.position()) {
                out.extend_from_slice(&c.to_le_bytes());
            }
            let (offset, radius) = codes.spheres[k];
            out.extend(offset.map(|o| o as u8));
            out.extend_from_slice(&radius.to_le_bytes());
            out.extend(normal_bytes(Vec3::from_array(node.normal)));
            let (axis, cos) = cone_of(node);
            out.extend(axis.map(|c| c as u8));
            out.push(cos);
            if self.colors {
                out.extend(node.color.map(srgb8));
            }
            if node.is_leaf() {
                continue;
            }
            out.extend_from_slice(&codes.errors[k].to_le_bytes());
            out.push(self.turns[u as usize]);
            for c in node.children {
                match self.local(c) {
                    Some(i) => put_varint(&mut out, 2 * i as u64),
                    None => put_varint(&mut out, 2 * self.renumber.id(c) as u64 + 1),
                }
            }
            let tris = tree.vanishing(u);
            put_varint(&mut out, tris.len() as u64);
            for t in tris {
                put_triangle(&mut out, t.map(|c| self.renumber.id(c)), &mut first_corner);
            }
        }
        out
    }
}

/// A node's cone as stored: its axis octahedral in bytes, its cosine rounded down after widening
/// by how far coding turned the axis.
fn cone_of(node: &Node) -> ([u16; 2], u8) {
    let axis = Vec3::from_slice(&node.cone);
    let cos = node.cone[3];
    if cos <= -1.0 || axis == Vec3::ZERO {
        return ([0, 0], 0);
    }
    let code = oct_encode(axis, CONE_BITS);
    let stored = oct_decode(code, CONE_BITS);
    let turned = axis.normalize_or_zero().dot(stored).clamp(-1.0, 1.0).acos() + 1e-3;
    let half = cos.clamp(-1.0, 1.0).acos() + turned;
    let wide = if half >= std::f32::consts::PI {
        -1.0
    } else {
        half.cos()
    };
    let mut c = cone_code_down(wide);
    // Never narrower than the widened cone, whatever `cos` rounds to.
    while c > 0 && cone_decode(c) > wide {
        c -= 1;
    }
    (code, c)
}

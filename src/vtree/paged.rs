//! The paged, quantised node layout of `.vtree` version 4 (docs/FORMAT.md): the tree cut into
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

use super::format::{FormatError, FormatErrorKind};
use super::{NONE, Node, VertexTree};
use crate::color::{srgb_to_linear, srgb8};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Nodes at most in a page: a few thousand, as a streaming reader fetches them (about 80 KB).
pub const PAGE_NODES: usize = 4096;
/// Bytes of a page's entry in the directory (`PAGE`): its offset in `PDAT` (u64), length (u32),
/// CRC-32 (u32), node count (u32) and root node (u32).
pub const DIRECTORY_ENTRY: usize = 24;

/// A page's place in the file and what it holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PageEntry {
    pub offset: u64,
    pub length: u32,
    pub crc: u32,
    pub nodes: u32,
    pub root: u32,
}

/// What [`encode`] makes: the directory and the pages, back to back.
pub struct Encoded {
    pub directory: Vec<u8>,
    pub pages: Vec<u8>,
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

/// A 16-bit float for errors and radii, in units of the file's `scale` (a power of two): code 0 is
/// 0; code `c` > 0 is `(1 + M/1024) · 2^(E − 56)`, `E = (c − 1) >> 10`, `M = (c − 1) & 1023`, so
/// it spans 2^−56 to 2^8 of the scale at 0.1 % steps. Decoding is exact bit work: the reader gets
/// the writer's numbers on every machine.
fn decode_scaled(code: u16, scale: f32) -> f32 {
    if code == 0 {
        return 0.0;
    }
    let c = code as u32 - 1;
    let (e, m) = (c >> 10, c & 1023);
    f32::from_bits(((e + 127 - 56) << 23) | (m << 13)) * scale
}

/// The smallest code whose value is at least `x` (≥ 0, finite); `None` past the largest.
fn encode_scaled_up(x: f32, scale: f32) -> Option<u16> {
    if x <= 0.0 {
        return Some(0);
    }
    let y = x / scale;
    let bits = y.to_bits();
    let e = (bits >> 23) as i32 - 127 + 56;
    let mut code = if e < 0 {
        1
    } else {
        let m = (bits >> 13) & 1023;
        let c = ((e as u32) << 10 | m) + 1;
        if bits & 0x1fff != 0 { c + 1 } else { c }
    };
    // Division rounds: step up until the decoded value holds `x`.
    while code <= u16::MAX as u32 && decode_scaled(code as u16, scale) < x {
        code += 1;
    }
    u16::try_from(code).ok()
}

/// The power of two at or above `x` (the tree's extent), the unit of [`decode_scaled`].
pub fn scale_for(x: f32) -> f32 {
    let x = x.max(f32::MIN_POSITIVE);
    let e = x.log2().ceil().clamp(-120.0, 120.0) as i32;
    2f32.powi(e)
}

/// `x` (≥ 0; anything below is 0, NaN too) to the nearest integer, halves up, saturating: a
/// conversion, where `f32::round` is a call into libm on the baseline x86-64 target.
fn nearest(x: f32) -> u32 {
    (x + 0.5) as u32
}

/// A page's box and how a 16-bit coordinate maps into it.
#[derive(Clone, Copy)]
struct Grid {
    lo: Vec3,
    step: Vec3,
    /// `1 / step` (0 where the step is): the writer's, to multiply instead of divide.
    inverse: Vec3,
}

impl Grid {
    fn new(lo: Vec3, hi: Vec3) -> Grid {
        let step = (hi - lo) / 65535.0;
        Grid {
            lo,
            step,
            inverse: step
                .to_array()
                .map(|s| if s > 0.0 { 1.0 / s } else { 0.0 })
                .into(),
        }
    }
    /// The nearest code (give or take a rounding: [`Grid::decode`] of it is what is stored).
    fn encode(&self, p: Vec3) -> [u16; 3] {
        ((p - self.lo) * self.inverse)
            .to_array()
            .map(|q| nearest(q).min(65535) as u16)
    }
    fn decode(&self, c: [u16; 3]) -> Vec3 {
        self.lo + Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * self.step
    }
}

/// Octahedral coding of a unit vector in `bits` per component (Cigolle et al., *A survey of
/// efficient representations for independent unit vectors*, JCGT 2014); zero stays zero.
fn oct_encode(v: Vec3, bits: u32) -> [u16; 2] {
    let max = ((1u32 << bits) - 1) as f32;
    let l1 = v.x.abs() + v.y.abs() + v.z.abs();
    if l1.is_nan() || l1 <= 0.0 {
        return [0, 0];
    }
    let p = Vec2::new(v.x, v.y) / l1;
    let p = if v.z < 0.0 {
        (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * Vec2::new(sign(p.x), sign(p.y))
    } else {
        p
    };
    // Code 0 (both) stands for zero: the grid starts at 1.
    let q = |x: f32| (nearest((x * 0.5 + 0.5) * (max - 1.0)) + 1).min(max as u32) as u16;
    [q(p.x), q(p.y)]
}

fn sign(x: f32) -> f32 {
    if x >= 0.0 { 1.0 } else { -1.0 }
}

fn oct_decode(c: [u16; 2], bits: u32) -> Vec3 {
    if c == [0, 0] {
        return Vec3::ZERO;
    }
    let max = ((1u32 << bits) - 1) as f32;
    let f = |x: u16| ((x as f32 - 1.0) / (max - 1.0)) * 2.0 - 1.0;
    let (x, y) = (f(c[0]), f(c[1]));
    let z = 1.0 - x.abs() - y.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - y.abs()) * sign(x), (1.0 - x.abs()) * sign(y))
    } else {
        (x, y)
    };
    Vec3::new(x, y, z).normalize_or_zero()
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

/// Cone cosines as a byte, rounded down (a wider cone): 0 is −1, every direction.
fn cone_code_down(cos: f32) -> u8 {
    ((cos.clamp(-1.0, 1.0) + 1.0) * 127.5).floor() as u8
}

fn cone_decode(code: u8) -> f32 {
    code as f32 / 127.5 - 1.0
}

/// Cone axes: 8 bits a component; normals: 12 (three bytes for both).
const CONE_BITS: u32 = 8;
const NORMAL_BITS: u32 = 12;

fn put_varint(out: &mut Vec<u8>, mut x: u64) {
    while x >= 0x80 {
        out.push((x as u8) | 0x80);
        x >>= 7;
    }
    out.push(x as u8);
}

fn zigzag(x: i64) -> u64 {
    ((x << 1) ^ (x >> 63)) as u64
}

fn unzigzag(x: u64) -> i64 {
    (x >> 1) as i64 ^ -((x & 1) as i64)
}

/// A sphere's centre as stored: its node's position plus an offset in 127ths of the radius on
/// each axis (the centre lies within the radius of the position, which the sphere holds).
fn sphere_center(position: Vec3, offset: [i8; 3], radius: f32) -> Vec3 {
    position + Vec3::new(offset[0] as f32, offset[1] as f32, offset[2] as f32) * (radius / 127.0)
}

/// A node's stored sphere: an offset of its centre from `position` (stored) and a radius code
/// such that the sphere holds the tree's sphere (`center`, `radius`) with every position moved
/// by up to `moved`, and each of `children`'s stored spheres; `scale` is the radius code's unit.
fn store_sphere(
    position: Vec3,
    (center, radius): (Vec3, f32),
    moved: f32,
    children: &[(Vec3, f32)],
    scale: f32,
) -> ([i8; 3], u16) {
    let need = |c: Vec3| {
        let mut r = radius + c.distance(center) + moved;
        for &(cc, cr) in children {
            r = r.max(crate::mesh::diagonal_of(c - cc) + cr);
        }
        r.max(c.distance(position)) * (1.0 + 4e-6)
    };
    let code = |r: f32| encode_scaled_up(r, scale).expect("radii lie within 2^8 of the extent");
    // The offset is in units of the radius it is stored with: try, and grow the radius until the
    // sphere holds; a centre at the position itself always does.
    let mut guess = code(need(center).max(center.distance(position)));
    for _ in 0..8 {
        let r = decode_scaled(guess, scale);
        if r <= 0.0 {
            break;
        }
        let offset = ((center - position) / r * 127.0)
            .to_array()
            .map(|x| (nearest(x + 127.0) as i32 - 127).clamp(-127, 127) as i8);
        let c = sphere_center(position, offset, r);
        let want = code(need(c));
        if want <= guess {
            return (offset, guess);
        }
        guess = want;
    }
    ([0; 3], code(need(position)))
}

/// Serialises `tree`'s nodes and triangles as pages. `colors`: whether node colours are stored
/// (white otherwise).
pub fn encode(tree: &VertexTree, colors: bool) -> Encoded {
    let (page_of, roots) = paginate(tree);
    let n = tree.nodes.len();
    let scale = scale_for(tree.diagonal());
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); roots.len()];
    for u in 0..n as u32 {
        members[page_of[u as usize] as usize].push(u);
    }
    // Children first, a page at a time: its grid and positions, then each node's error and
    // sphere, grown by what quantising moved, rounded up and never below a child's; then the
    // page's bytes. Pages in waves, each page's child pages in earlier waves: a wave's pages on
    // every core, each page's scattered nodes read into cache once for all three.
    let mut done = Done {
        spheres: vec![([0i8; 3], 0u16); n],
        errors: vec![0u16; n],
        positions: vec![Vec3::ZERO; n],
        moved: vec![0f32; n],
        page_error: vec![0f32; roots.len()],
    };
    let mut bodies: Vec<Vec<u8>> = vec![Vec::new(); roots.len()];
    for wave in waves(tree, &members, &page_of) {
        let pages: Vec<(usize, Codes, Vec<u8>)> = wave
            .par_iter()
            .map(|&p| {
                let page = PageWriter::new(tree, &members[p], p as u32, &page_of, scale, colors);
                let codes = page.codes(&done);
                let body = page.write(&codes);
                (p, codes, body)
            })
            .collect();
        for (p, codes, body) in pages {
            for (k, &u) in members[p].iter().enumerate() {
                let u = u as usize;
                done.spheres[u] = codes.spheres[k];
                done.errors[u] = codes.errors[k];
                done.positions[u] = codes.positions[k];
                done.moved[u] = codes.moved[k];
            }
            done.page_error[p] = codes.page_error;
            bodies[p] = body;
        }
    }
    let position_error = done.page_error.iter().copied().fold(0.0, f32::max);
    let mut directory = Vec::with_capacity(4 + roots.len() * DIRECTORY_ENTRY);
    directory.extend_from_slice(&(roots.len() as u32).to_le_bytes());
    directory.extend_from_slice(&scale.to_le_bytes());
    directory.extend_from_slice(&position_error.to_le_bytes());
    let mut pages = Vec::with_capacity(bodies.iter().map(Vec::len).sum());
    for (p, body) in bodies.iter().enumerate() {
        let entry = PageEntry {
            offset: pages.len() as u64,
            length: body.len() as u32,
            crc: crc32fast::hash(body),
            nodes: members[p].len() as u32,
            root: roots[p],
        };
        directory.extend_from_slice(&entry.offset.to_le_bytes());
        directory.extend_from_slice(&entry.length.to_le_bytes());
        directory.extend_from_slice(&entry.crc.to_le_bytes());
        directory.extend_from_slice(&entry.nodes.to_le_bytes());
        directory.extend_from_slice(&entry.root.to_le_bytes());
        pages.extend_from_slice(body);
    }
    Encoded { directory, pages }
}

/// Bytes of the directory before its entries: page count (u32), scale (f32), position error (f32).
pub const DIRECTORY_HEAD: usize = 12;

struct PageWriter<'a> {
    tree: &'a VertexTree,
    /// The page's nodes, in increasing id.
    ids: &'a [u32],
    page: u32,
    page_of: &'a [u32],
    /// The page's grid, over its nodes' positions.
    grid: Grid,
    scale: f32,
    colors: bool,
}

/// What the pages of earlier waves left, per node (and per page).
struct Done {
    spheres: Vec<([i8; 3], u16)>,
    errors: Vec<u16>,
    /// Positions as stored.
    positions: Vec<Vec3>,
    /// How far any stored position of the node's subtree lies from the tree's.
    moved: Vec<f32>,
    /// Each page's position error.
    page_error: Vec<f32>,
}

/// A page's nodes' codes and stored positions, in the page's order, and its position error.
struct Codes {
    errors: Vec<u16>,
    spheres: Vec<([i8; 3], u16)>,
    positions: Vec<Vec3>,
    moved: Vec<f32>,
    page_error: f32,
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

impl<'a> PageWriter<'a> {
    fn new(
        tree: &'a VertexTree,
        ids: &'a [u32],
        page: u32,
        page_of: &'a [u32],
        scale: f32,
        colors: bool,
    ) -> PageWriter<'a> {
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
            page,
            page_of,
            grid: Grid::new(lo, hi),
            scale,
            colors,
        }
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
                let (error, (offset, code), at, moved) = match self.ids[..k].binary_search(&c) {
                    Ok(j) => (
                        codes.errors[j],
                        codes.spheres[j],
                        codes.positions[j],
                        codes.moved[j],
                    ),
                    Err(_) => {
                        let c = c as usize;
                        (
                            done.errors[c],
                            done.spheres[c],
                            done.positions[c],
                            done.moved[c],
                        )
                    }
                };
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
        let local = |id: u32| self.ids.binary_search(&id).ok();
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
            put_varint(&mut out, u as u64 - previous);
            previous = u as u64;
            for c in self.grid.encode(node.position()) {
                out.extend_from_slice(&c.to_le_bytes());
            }
            let (offset, radius) = codes.spheres[k];
            out.extend(offset.map(|o| o as u8));
            out.extend_from_slice(&radius.to_le_bytes());
            let [a, b] = oct_encode(Vec3::from_array(node.normal), NORMAL_BITS);
            out.extend([a as u8, (a >> 8) as u8 | (b << 4) as u8, (b >> 4) as u8]);
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
            for c in node.children {
                match local(c).filter(|_| self.page_of[c as usize] == self.page) {
                    Some(i) => put_varint(&mut out, 2 * i as u64),
                    None => put_varint(&mut out, 2 * c as u64 + 1),
                }
            }
            let tris = tree.vanishing(u);
            put_varint(&mut out, tris.len() as u64);
            for t in tris {
                let c0 = t[0] as i64;
                put_varint(&mut out, zigzag(c0 - first_corner));
                first_corner = c0;
                put_varint(&mut out, zigzag(t[1] as i64 - c0));
                put_varint(&mut out, zigzag(t[2] as i64 - c0));
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

/// What decoding a page gives: its nodes (ids and nodes, parents unset) and each internal node's
/// triangles.
pub struct DecodedPage {
    pub ids: Vec<u32>,
    pub nodes: Vec<Node>,
    /// Per internal node of the page, in order, how many triangles; then all of them.
    pub counts: Vec<u32>,
    pub triangles: Vec<[u32; 3]>,
}

/// Reads page bytes: a cursor that fails with the page's offset in the file.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    base: u64,
    page: usize,
    path: &'a std::path::Path,
}

impl Reader<'_> {
    fn fail(&self, what: &str) -> FormatError {
        FormatError {
            path: self.path.to_path_buf(),
            offset: Some(self.base + self.at as u64),
            kind: FormatErrorKind::Invalid,
            message: format!("page {}: {what}", self.page),
        }
    }
    fn take<const N: usize>(&mut self) -> Result<[u8; N], FormatError> {
        let b = self
            .bytes
            .get(self.at..self.at + N)
            .ok_or_else(|| self.fail("ends inside a node"))?;
        self.at += N;
        Ok(b.try_into().expect("N bytes"))
    }
    fn u16(&mut self) -> Result<u16, FormatError> {
        Ok(u16::from_le_bytes(self.take()?))
    }
    fn f32(&mut self) -> Result<f32, FormatError> {
        Ok(f32::from_le_bytes(self.take()?))
    }
    fn varint(&mut self) -> Result<u64, FormatError> {
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
        page,
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
        let [a, b, c] = r.take::<3>()?.map(u16::from);
        let normal = oct_decode([a | (b & 0xf) << 8, b >> 4 | c << 4], NORMAL_BITS);
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
        if id >= cx.leaf_count as u64 {
            node.error = decode_scaled(r.u16()?, cx.scale);
            children.push([r.varint()?, r.varint()?]);
            let tris = r.varint()?;
            if tris > (bytes.len() - r.at) as u64 {
                return Err(r.fail(&format!("{tris} triangles cannot fit in what is left")));
            }
            out.counts.push(tris as u32);
            for _ in 0..tris {
                let c0 = first_corner + unzigzag(r.varint()?);
                first_corner = c0;
                let c1 = c0 + unzigzag(r.varint()?);
                let c2 = c0 + unzigzag(r.varint()?);
                let t = [c0, c1, c2];
                if t.iter().any(|&c| c < 0 || c >= cx.leaf_count as i64) {
                    return Err(r.fail(&format!("triangle {t:?} names a leaf out of range")));
                }
                out.triangles.push(t.map(|c| c as u32));
            }
        }
        out.ids.push(id as u32);
        out.nodes.push(node);
    }
    if r.at != bytes.len() {
        return Err(r.fail(&format!("{} bytes after its last node", bytes.len() - r.at)));
    }
    // Children: in this page by index, or a child page's root by id.
    let mut k = 0;
    for i in 0..count {
        if out.ids[i] < cx.leaf_count {
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
    Ok(out)
}

/// The directory: page count, scale, position error and the entries, checked against the length
/// of `PDAT`, tiling it in order.
pub fn directory(
    bytes: &[u8],
    data_len: u64,
    fail: impl Fn(String) -> FormatError,
) -> Result<(f32, f32, Vec<PageEntry>), FormatError> {
    if bytes.len() < DIRECTORY_HEAD {
        return Err(fail("PAGE is shorter than its head".into()));
    }
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let count = u32_at(0) as usize;
    let scale = f32::from_bits(u32_at(4));
    let position_error = f32::from_bits(u32_at(8));
    if bytes.len() != DIRECTORY_HEAD + count * DIRECTORY_ENTRY {
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
        let at = DIRECTORY_HEAD + p * DIRECTORY_ENTRY;
        let entry = PageEntry {
            offset: u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes")),
            length: u32_at(at + 8),
            crc: u32_at(at + 12),
            nodes: u32_at(at + 16),
            root: u32_at(at + 20),
        };
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_codes_round_up_and_decode_exactly() {
        for scale in [1.0f32, 0.25, 1024.0] {
            let mut x = 1e-12f32;
            while x < 100.0 * scale {
                let c = encode_scaled_up(x, scale).expect("in range");
                let d = decode_scaled(c, scale);
                assert!(d >= x, "{x} coded to {d}");
                assert!(d <= x * 1.002 || c == 1, "{x} coded to {d}: a step too far");
                x *= 1.37;
            }
        }
        assert_eq!(encode_scaled_up(0.0, 1.0), Some(0));
        assert_eq!(decode_scaled(0, 1.0), 0.0);
    }

    #[test]
    fn octahedral_normals_come_back_within_a_tenth_of_a_degree() {
        let mut s = 12345u32;
        for _ in 0..10_000 {
            let mut r = || {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (s >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
            };
            let v = Vec3::new(r(), r(), r()).normalize_or_zero();
            if v == Vec3::ZERO {
                continue;
            }
            let back = oct_decode(oct_encode(v, NORMAL_BITS), NORMAL_BITS);
            assert!(
                v.dot(back) > (0.1f32.to_radians()).cos(),
                "{v} came back {back}"
            );
        }
        assert_eq!(oct_decode(oct_encode(Vec3::ZERO, 12), 12), Vec3::ZERO);
    }

    #[test]
    fn varints_and_zigzag_round_trip() {
        for x in [
            0i64,
            1,
            -1,
            63,
            -64,
            1 << 20,
            -(1 << 31),
            i64::from(u32::MAX),
        ] {
            assert_eq!(unzigzag(zigzag(x)), x);
        }
    }
}

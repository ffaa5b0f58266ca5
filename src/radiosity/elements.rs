//! The element mesh: the scene's polygons cut into triangles, refined where the lighting changes,
//! always **conforming** — no vertex lies inside another triangle's edge, so interpolated colours
//! have no cracks or leaks.
//!
//! Refinement is red–green (Bank, Sherman and Weiser 1983): a marked triangle is split into four at
//! its edge midpoints (red); a neighbour with two or three split edges is split red too, until none
//! is left; a neighbour with one split edge is halved through it (green). Edges are matched by their
//! end positions, not by vertex numbers, so the rule holds across polygons that meet along an edge
//! (where each keeps its own vertices: the floor's corner radiosity is not the wall's).

use super::scene::{Scene, newell};
use glam::DVec3;
use std::collections::{HashMap, HashSet};

/// An edge by its end positions (bit patterns, smaller first): the same edge in every polygon.
type EdgeKey = ([u64; 3], [u64; 3]);

fn key(a: DVec3, b: DVec3) -> EdgeKey {
    let bits = |p: DVec3| p.to_array().map(f64::to_bits);
    let (x, y) = (bits(a), bits(b));
    if x <= y { (x, y) } else { (y, x) }
}

#[derive(Clone, Debug, Default)]
pub struct Elements {
    pub positions: Vec<DVec3>,
    /// The polygon each vertex belongs to (its material and plane).
    pub vertex_polygon: Vec<u32>,
    pub triangles: Vec<[u32; 3]>,
    /// The shooting patch each element belongs to (the coarse triangle it was cut from).
    pub element_patch: Vec<u32>,
    /// Each polygon's unit normal (its front side, by the corners' winding).
    pub polygon_normal: Vec<DVec3>,
    /// Vertices by (polygon, position), so that each polygon's triangles share theirs.
    index: HashMap<(u32, [u64; 3]), u32>,
}

impl Elements {
    /// The scene's polygons as patches no longer than `patch_size` along any edge, and each patch's
    /// triangles as elements no longer than `element_size`. Returns the elements and the patches
    /// (as their own `Elements`, one element each).
    pub fn new(scene: &Scene, patch_size: f64, element_size: f64) -> (Elements, Elements) {
        let mut patches = Elements::default();
        for (p, polygon) in scene.polygons.iter().enumerate() {
            patches
                .polygon_normal
                .push(newell(&polygon.corners).normalize());
            let c = &polygon.corners;
            for i in 1..c.len() - 1 {
                let t = [c[0], c[i], c[i + 1]].map(|x| patches.vertex(p as u32, x));
                patches.triangles.push(t);
            }
        }
        patches.refine_to(patch_size);
        patches.element_patch = (0..patches.triangles.len() as u32).collect();
        let mut elements = patches.clone();
        elements.refine_to(element_size);
        (elements, patches)
    }

    fn vertex(&mut self, polygon: u32, p: DVec3) -> u32 {
        let n = self.positions.len() as u32;
        *self
            .index
            .entry((polygon, p.to_array().map(f64::to_bits)))
            .or_insert_with(|| {
                self.positions.push(p);
                self.vertex_polygon.push(polygon);
                n
            })
    }

    pub fn corners(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t].map(|v| self.positions[v as usize])
    }

    pub fn area(&self, t: usize) -> f64 {
        let [a, b, c] = self.corners(t);
        0.5 * (b - a).cross(c - a).length()
    }

    pub fn longest_edge(&self, t: usize) -> f64 {
        let [a, b, c] = self.corners(t);
        a.distance(b).max(b.distance(c)).max(c.distance(a))
    }

    /// Refines until no edge is longer than `size`.
    fn refine_to(&mut self, size: f64) {
        loop {
            let marked: Vec<bool> = (0..self.triangles.len())
                .map(|t| self.longest_edge(t) > size)
                .collect();
            if !marked.contains(&true) {
                return;
            }
            self.refine(&marked);
        }
    }

    /// Splits the marked triangles into four, and their neighbours as the red–green rule says.
    pub fn refine(&mut self, marked: &[bool]) {
        let mut red = marked.to_vec();
        let mut split: HashSet<EdgeKey> = HashSet::new();
        let edges = |e: &Elements, t: usize| {
            let [a, b, c] = e.corners(t);
            [key(a, b), key(b, c), key(c, a)]
        };
        loop {
            for t in (0..self.triangles.len()).filter(|&t| red[t]) {
                split.extend(edges(self, t));
            }
            let mut changed = false;
            for (t, red) in red.iter_mut().enumerate() {
                if !*red && edges(self, t).iter().filter(|k| split.contains(k)).count() >= 2 {
                    *red = true;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        let old = std::mem::take(&mut self.triangles);
        let patches = std::mem::take(&mut self.element_patch);
        for (t, &[a, b, c]) in old.iter().enumerate() {
            let patch = patches.get(t).copied().unwrap_or(0);
            let [pa, pb, pc] = [a, b, c].map(|v| self.positions[v as usize]);
            let polygon = self.vertex_polygon[a as usize];
            let mut mid = |x: DVec3, y: DVec3| self.vertex(polygon, (x + y) * 0.5);
            let new: Vec<[u32; 3]> = if red[t] {
                let (ab, bc, ca) = (mid(pa, pb), mid(pb, pc), mid(pc, pa));
                vec![[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            } else if split.contains(&key(pa, pb)) {
                let m = mid(pa, pb);
                vec![[a, m, c], [m, b, c]]
            } else if split.contains(&key(pb, pc)) {
                let m = mid(pb, pc);
                vec![[a, b, m], [a, m, c]]
            } else if split.contains(&key(pc, pa)) {
                let m = mid(pc, pa);
                vec![[a, b, m], [m, b, c]]
            } else {
                vec![[a, b, c]]
            };
            self.element_patch
                .extend(std::iter::repeat_n(patch, new.len()));
            self.triangles.extend(new);
        }
    }
}

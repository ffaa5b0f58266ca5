//! Huge test models, written as a stream of binary PLY: the mesh is never held in memory, so a
//! model of a hundred million triangles or more costs a few megabytes to make (what the
//! partitioned build and the streamed runtime are measured on; `examples/huge.rs` runs them).
//!
//! * [`write_city`]: copies of a few scanned models on a grid, each turned about the vertical and
//!   scaled (instances as a city or a CAD assembly repeats its parts). Vertices and faces are
//!   written in two passes over the copies, as PLY puts all vertices before all faces.
//! * [`write_terrain`]: one connected height field, a grid whose heights are fractal noise from
//!   the whole extent down to a cell (detail at every scale, as a scanned landscape has), its
//!   vertices jittered off the lattice and its cells split along either diagonal, so that it looks
//!   like a scan rather than a raster.
//!
//! Both are deterministic for a seed.

use crate::mesh::Mesh;
use glam::{Quat, Vec3};
use rayon::prelude::*;
use std::io::{self, Write};

/// Writes a binary little-endian PLY header for `vertices` float positions and `faces`
/// triangles (a `uchar` count and `uint` indices each).
fn header(out: &mut dyn Write, vertices: u64, faces: u64, comment: &str) -> io::Result<()> {
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment {comment}\nelement vertex {vertices}\n\
         property float x\nproperty float y\nproperty float z\nelement face {faces}\n\
         property list uchar uint vertex_indices\nend_header\n"
    )
}

/// One face record: the count and three indices.
fn face(out: &mut Vec<u8>, t: [u32; 3]) {
    out.push(3);
    for i in t {
        out.extend_from_slice(&i.to_le_bytes());
    }
}

/// A 64-bit mix of the inputs (SplitMix64's finaliser), for noise and placement.
fn hash(mut x: u64) -> u64 {
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// A uniform number in `[0, 1)` for the lattice point `(x, y)` of octave `k` under `seed`.
fn unit(seed: u64, k: u32, x: i64, y: i64) -> f32 {
    let h = hash(seed ^ hash((k as u64) << 48 ^ hash(x as u64 ^ hash(y as u64))));
    (h >> 40) as f32 / (1u64 << 24) as f32
}

/// A city: `copies` of `models` (in turn) on a square grid, each turned about the vertical by an
/// angle and scaled by a factor in `[0.6, 1.4]`, both from `seed`, and stood on the ground.
pub struct City<'m> {
    pub models: &'m [Mesh],
    pub copies: u32,
    pub seed: u64,
}

impl City<'_> {
    /// Vertices and triangles of the whole city.
    pub fn counts(&self) -> (u64, u64) {
        (0..self.copies as usize).fold((0, 0), |(v, t), i| {
            let m = &self.models[i % self.models.len()];
            (v + m.positions.len() as u64, t + m.triangles.len() as u64)
        })
    }

    /// Copy `i`'s model and where it puts the model's point `p`: turned and scaled about the
    /// centre of the model's footprint, which goes to the copy's cell on the ground.
    fn placement(&self, i: u32, spacing: f32, side: u32) -> (&Mesh, impl Fn(Vec3) -> Vec3) {
        let m = &self.models[i as usize % self.models.len()];
        let turn = Quat::from_rotation_y(unit(self.seed, 0, i as i64, 0) * std::f32::consts::TAU);
        let scale = 0.6 + 0.8 * unit(self.seed, 1, i as i64, 0);
        let (lo, hi) = bounds(&m.positions);
        let centre = Vec3::new((lo.x + hi.x) * 0.5, lo.y, (lo.z + hi.z) * 0.5);
        let cell = Vec3::new((i % side) as f32, 0.0, (i / side) as f32) * spacing;
        (m, move |p: Vec3| turn * ((p - centre) * scale) + cell)
    }
}

fn bounds(p: &[Vec3]) -> (Vec3, Vec3) {
    p.iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        })
}

/// Writes `city` as binary PLY to `out`, reporting `(copies written, copies)` twice over (the
/// vertex pass, then the face pass).
pub fn write_city(
    out: &mut dyn Write,
    city: &City,
    progress: &mut dyn FnMut(u64, u64),
) -> io::Result<()> {
    if city.models.is_empty() || city.copies == 0 {
        return Err(io::Error::other("a city needs a model and a copy"));
    }
    let (vertices, faces) = city.counts();
    if vertices > u32::MAX as u64 {
        return Err(io::Error::other(format!(
            "{vertices} vertices: PLY indices here are 32-bit, so at most {} fit",
            u32::MAX
        )));
    }
    let spacing = city
        .models
        .iter()
        .map(|m| {
            let (lo, hi) = bounds(&m.positions);
            (hi - lo).length()
        })
        .fold(0.0, f32::max)
        * 1.5;
    let side = (city.copies as f64).sqrt().ceil() as u32;
    header(out, vertices, faces, "vunify city")?;
    let total = 2 * city.copies as u64;
    let mut buffer = Vec::new();
    for i in 0..city.copies {
        let (m, place) = city.placement(i, spacing, side);
        buffer.clear();
        for &p in &m.positions {
            for c in place(p).to_array() {
                buffer.extend_from_slice(&c.to_le_bytes());
            }
        }
        out.write_all(&buffer)?;
        progress(i as u64 + 1, total);
    }
    let mut base = 0u32;
    for i in 0..city.copies {
        let m = &city.models[i as usize % city.models.len()];
        buffer.clear();
        for t in &m.triangles {
            face(&mut buffer, t.map(|v| v + base));
        }
        out.write_all(&buffer)?;
        base += m.positions.len() as u32;
        progress(city.copies as u64 + i as u64 + 1, total);
    }
    Ok(())
}

/// A terrain: a square height field of `cells` × `cells` cells over a side of `size`.
pub struct Terrain {
    pub cells: u32,
    pub size: f32,
    pub seed: u64,
}

impl Terrain {
    /// The terrain of at least `triangles` triangles (two a cell).
    pub fn with_triangles(triangles: u64, seed: u64) -> Terrain {
        let cells = ((triangles as f64 / 2.0).sqrt().ceil() as u32).max(1);
        Terrain {
            cells,
            size: 1000.0,
            seed,
        }
    }

    pub fn counts(&self) -> (u64, u64) {
        let side = self.cells as u64 + 1;
        (side * side, 2 * self.cells as u64 * self.cells as u64)
    }

    /// The height at lattice point `(i, j)`: octaves of smoothly interpolated value noise, from
    /// the whole extent down to two cells, each half the last's amplitude, the larger ones
    /// sharpened into ridges.
    fn height(&self, i: u32, j: u32) -> f32 {
        let mut h = 0.0;
        let mut amplitude = 0.12 * self.size;
        let mut period = self.cells as f32;
        let mut k = 0;
        while period >= 2.0 {
            let (x, y) = (i as f32 / period, j as f32 / period);
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = (smooth(x - x0), smooth(y - y0));
            let corner = |dx: i64, dy: i64| unit(self.seed, k, x0 as i64 + dx, y0 as i64 + dy);
            let top = corner(0, 0) + (corner(1, 0) - corner(0, 0)) * fx;
            let bottom = corner(0, 1) + (corner(1, 1) - corner(0, 1)) * fx;
            let n = top + (bottom - top) * fy;
            // Ridges at the larger scales, rolling detail at the small ones.
            h += amplitude
                * if k < 4 {
                    1.0 - (2.0 * n - 1.0).abs()
                } else {
                    n - 0.5
                };
            amplitude *= 0.5;
            period *= 0.5;
            k += 1;
        }
        h
    }

    /// Lattice point `(i, j)`'s position: jittered by up to a fifth of a cell off the lattice.
    fn position(&self, i: u32, j: u32) -> Vec3 {
        let cell = self.size / self.cells as f32;
        let inner = |c: u32| c > 0 && c < self.cells;
        // The border stays straight.
        let jitter = |k: u32| {
            if inner(i) && inner(j) {
                (unit(self.seed, 100 + k, i as i64, j as i64) - 0.5) * 0.4 * cell
            } else {
                0.0
            }
        };
        Vec3::new(
            i as f32 * cell + jitter(0),
            self.height(i, j),
            j as f32 * cell + jitter(1),
        )
    }
}

fn smooth(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

/// Rows of the terrain computed at once (on every core) before they are written.
const TERRAIN_ROWS: u32 = 64;

/// Writes `terrain` as binary PLY to `out`, reporting `(rows written, rows)` over the vertex pass
/// and then the face pass.
pub fn write_terrain(
    out: &mut dyn Write,
    terrain: &Terrain,
    progress: &mut dyn FnMut(u64, u64),
) -> io::Result<()> {
    let (vertices, faces) = terrain.counts();
    if vertices > u32::MAX as u64 {
        return Err(io::Error::other(format!(
            "{vertices} vertices: PLY indices here are 32-bit, so at most {} fit",
            u32::MAX
        )));
    }
    header(out, vertices, faces, "vunify terrain")?;
    let side = terrain.cells + 1;
    let total = 2 * side as u64;
    let mut buffer = Vec::new();
    for start in (0..side).step_by(TERRAIN_ROWS as usize) {
        let rows = start..(start + TERRAIN_ROWS).min(side);
        let block: Vec<Vec<u8>> = rows
            .clone()
            .into_par_iter()
            .map(|j| {
                let mut row = Vec::with_capacity(side as usize * 12);
                for i in 0..side {
                    for c in terrain.position(i, j).to_array() {
                        row.extend_from_slice(&c.to_le_bytes());
                    }
                }
                row
            })
            .collect();
        for row in block {
            out.write_all(&row)?;
        }
        progress(rows.end as u64, total);
    }
    for j in 0..terrain.cells {
        buffer.clear();
        for i in 0..terrain.cells {
            let v = |di: u32, dj: u32| (j + dj) * side + i + di;
            let (a, b, c, d) = (v(0, 0), v(1, 0), v(1, 1), v(0, 1));
            // Facing up (+y): counter-clockwise seen from above.
            if hash(terrain.seed ^ hash((j as u64) << 32 | i as u64)) & 1 == 0 {
                face(&mut buffer, [a, c, b]);
                face(&mut buffer, [a, d, c]);
            } else {
                face(&mut buffer, [a, d, b]);
                face(&mut buffer, [b, d, c]);
            }
        }
        out.write_all(&buffer)?;
        progress(side as u64 + j as u64 + 1, total);
    }
    Ok(())
}

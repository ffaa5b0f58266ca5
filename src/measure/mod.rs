//! Geometric error between two meshes: the symmetric Hausdorff distance by dense surface sampling, in
//! the Metro convention (Cignoni et al. 1998) — vertices, points along edges and points inside faces of
//! one mesh, each measured to the nearest point of the other; reported as fractions of the original's
//! bounding-box diagonal.

mod bvh;
mod certified;
mod partition;

pub use bvh::{Bvh, closest_point_on_triangle, closest_point_on_triangle64};
pub use certified::{
    Bounds, Certified, CertifyError, CertifyOptions, Target, Triangles, certified_hausdorff,
    within, within_by,
};

use crate::mesh::Mesh;
use glam::Vec3;
use rayon::prelude::*;

/// Distances from one mesh's samples to the other mesh, as fractions of the reference diagonal.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct OneSided {
    pub max: f64,
    pub mean: f64,
    pub rms: f64,
    pub samples: usize,
    /// Where the largest distance was found (a sample point on the `from` surface).
    pub max_at: [f32; 3],
}

/// Both directions and their combination.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Hausdorff {
    /// Original → simplified.
    pub forward: OneSided,
    /// Simplified → original.
    pub backward: OneSided,
    /// max of the two maxima; mean and RMS over all samples of both directions.
    pub symmetric: OneSided,
    /// The unit of every number above, in model units.
    pub diagonal: f64,
}

/// Sampling density: samples per mesh, at least.
pub const DEFAULT_SAMPLES: usize = 200_000;

/// A deterministic generator (SplitMix64), so a measurement is repeatable.
struct SplitMix(u64);
impl SplitMix {
    fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Metro-style samples of a surface: every vertex, `samples / 4` points along edges by length and the
/// rest inside faces by area (stratified by error diffusion, so each face gets its fair share).
pub fn sample_surface(mesh: &Mesh, samples: usize) -> Vec<Vec3> {
    let mut out: Vec<Vec3> = mesh.positions.clone();
    let mut rng = SplitMix(0x5EED);
    let p = &mesh.positions;
    let edge_budget = samples / 4;
    let face_budget = samples - edge_budget;
    let total_len: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            (0..3)
                .map(|k| p[t[k] as usize].distance(p[t[(k + 1) % 3] as usize]) as f64)
                .sum::<f64>()
        })
        .sum();
    let total_area: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            ((p[t[1] as usize] - p[t[0] as usize])
                .cross(p[t[2] as usize] - p[t[0] as usize])
                .length()
                * 0.5) as f64
        })
        .sum();
    let (mut carry_e, mut carry_f) = (0.0f64, 0.0f64);
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| p[v as usize]);
        // Each edge is shared by about two triangles: half the budget per side still covers it.
        for (u, v) in [(a, b), (b, c), (c, a)] {
            if total_len > 0.0 {
                carry_e += u.distance(v) as f64 / total_len * edge_budget as f64;
                while carry_e >= 1.0 {
                    carry_e -= 1.0;
                    out.push(u.lerp(v, rng.next_f32()));
                }
            }
        }
        if total_area > 0.0 {
            carry_f +=
                ((b - a).cross(c - a).length() * 0.5) as f64 / total_area * face_budget as f64;
            while carry_f >= 1.0 {
                carry_f -= 1.0;
                let (mut s, mut r) = (rng.next_f32(), rng.next_f32());
                if s + r > 1.0 {
                    s = 1.0 - s;
                    r = 1.0 - r;
                }
                out.push(a + (b - a) * s + (c - a) * r);
            }
        }
    }
    out
}

fn one_sided(from: &Mesh, to: &Bvh, samples: usize, unit: f64) -> (OneSided, f64, f64) {
    let points = sample_surface(from, samples);
    let (max, max_at, sum, sum2) = points
        .par_iter()
        .map(|&q| {
            let d = to.distance(q) as f64;
            (d, q, d, d * d)
        })
        .reduce(
            || (0.0, Vec3::ZERO, 0.0, 0.0),
            |x, y| {
                let (max, at) = if y.0 > x.0 { (y.0, y.1) } else { (x.0, x.1) };
                (max, at, x.2 + y.2, x.3 + y.3)
            },
        );
    let n = points.len().max(1) as f64;
    let side = OneSided {
        max: max / unit,
        mean: sum / n / unit,
        rms: (sum2 / n).sqrt() / unit,
        samples: points.len(),
        max_at: max_at.to_array(),
    };
    (side, sum, sum2)
}

/// Symmetric Hausdorff distance between `original` and `simplified`, with at least `samples` samples on
/// each, relative to the original's bounding-box diagonal.
pub fn hausdorff(original: &Mesh, simplified: &Mesh, samples: usize) -> Hausdorff {
    let unit = (original.diagonal() as f64).max(f64::MIN_POSITIVE);
    let (bvh_o, bvh_s) = rayon::join(
        || Bvh::new(&original.positions, &original.triangles),
        || Bvh::new(&simplified.positions, &simplified.triangles),
    );
    let (f, fs, fs2) = one_sided(original, &bvh_s, samples, unit);
    let (b, bs, bs2) = one_sided(simplified, &bvh_o, samples, unit);
    let n = (f.samples + b.samples).max(1) as f64;
    let symmetric = OneSided {
        max: f.max.max(b.max),
        mean: (fs + bs) / n / unit,
        rms: ((fs2 + bs2) / n).sqrt() / unit,
        samples: f.samples + b.samples,
        max_at: if f.max >= b.max { f.max_at } else { b.max_at },
    };
    Hausdorff {
        forward: f,
        backward: b,
        symmetric,
        diagonal: unit,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f32) -> Mesh {
        let p = vec![
            Vec3::new(0.0, 0.0, z),
            Vec3::new(1.0, 0.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(0.0, 1.0, z),
        ];
        Mesh::from_triangles(p, vec![[0, 1, 2], [0, 2, 3]])
    }

    #[test]
    fn parallel_squares_are_their_gap_apart() {
        // Two unit squares 0.1 apart: every sample is exactly 0.1 from the other (diagonal √2).
        let h = hausdorff(&square(0.0), &square(0.1), 2000);
        let expect = 0.1 / 2f64.sqrt();
        for side in [h.forward, h.backward, h.symmetric] {
            assert!((side.max - expect).abs() < 1e-6, "{side:?}");
            assert!((side.mean - expect).abs() < 1e-6);
            assert!((side.rms - expect).abs() < 1e-6);
        }
        assert!(h.symmetric.samples >= 4000);
    }

    #[test]
    fn identical_meshes_have_zero_distance() {
        let h = hausdorff(&square(0.0), &square(0.0), 1000);
        assert!(h.symmetric.max < 1e-7);
    }

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let near = |p: Vec3, want: Vec3| {
            let got = closest_point_on_triangle(p, a, b, c);
            assert!(got.distance(want) < 1e-6, "{p} -> {got}, expected {want}");
        };
        near(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.2, 0.2, 0.0)); // inside: straight down
        near(Vec3::new(-1.0, -1.0, 0.0), a); // vertex region
        near(Vec3::new(0.5, -1.0, 0.0), Vec3::new(0.5, 0.0, 0.0)); // edge region
        near(Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.5, 0.5, 0.0)); // hypotenuse
    }
}

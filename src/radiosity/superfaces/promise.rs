//! The superface's promise (docs/RADIOSITY.md): each superface's value, a linear fit kept by the
//! merge test so that what is drawn stays within ε of the lit mesh, and the colour error that checks
//! it afterwards.

use super::Patches;
use crate::mesh::Mesh;
use glam::DVec3;

/// The superface's value and promise, kept by the merge test. The value is a linear function `f`
/// over the superface's plane (fitted by least squares to its vertices' values, per channel), so a
/// smooth gradient costs no more superfaces than a flat colour. The promise: every vertex value `b`
/// on it lies within `e · S` of `f` at that vertex, in every channel, with `e = ε / (2 + ε)` and
/// `S = max(lowest f at a vertex, floor)`.
///
/// Why that keeps what is drawn within ε of the lit mesh: the new triangles interpolate values of
/// the superface's own vertices, and `f` is linear, so what is drawn at a point `x` is within
/// `e · S` of `f(x)`; so is the lit value there (it interpolates vertex values too); so the two are
/// within `2e · S`, and the lit value is at least `(1 − e) S` (or `S` is the floor), which makes that
/// at most `ε · max(lit, floor)`. This holds while the boundary keeps its shape (`distance` 0, the
/// default): straightened chains run between vertices of both superfaces they separate.
///
/// The fit is refitted as the superface doubles, and a refit is taken only when every member
/// still keeps the promise under it, so each join checks three corners, not every member.
pub(super) struct Fit {
    origin: DVec3,
    axes: [DVec3; 2],
    /// `f(s, t) = coef[0] + coef[1] s + coef[2] t`, per channel.
    coef: [DVec3; 3],
    /// The largest `|b − f|` over member vertices, per channel.
    residual: DVec3,
    /// The lowest `f` at a member vertex, per channel.
    low: DVec3,
    members: Vec<u32>,
    fitted_at: usize,
    /// The least-squares normal equations: `Σ [1 s t]ᵀ [1 s t]` and `Σ [1 s t]ᵀ b` per channel.
    normal: glam::DMat3,
    rhs: [DVec3; 3],
    e: f64,
    floor: f64,
}

impl Fit {
    /// The seed patch's own linear interpolation (exact at its corners).
    pub(super) fn new(patches: &Patches, seed: u32, epsilon: f64) -> Fit {
        let t = patches.mesh.triangles[seed as usize];
        let origin = patches.mesh.positions[t[0] as usize].as_dvec3();
        let (u, v) = patches.normal[seed as usize].any_orthonormal_pair();
        let mut fit = Fit {
            origin,
            axes: [u, v],
            coef: [DVec3::ZERO; 3],
            residual: DVec3::ZERO,
            low: DVec3::INFINITY,
            members: Vec::new(),
            fitted_at: 0,
            normal: glam::DMat3::ZERO,
            rhs: [DVec3::ZERO; 3],
            e: epsilon / (2.0 + epsilon),
            floor: patches.floor,
        };
        for v in t {
            fit.add(patches, v);
        }
        fit.coef = fit.solve().unwrap_or_else(|| {
            let mean = t.iter().map(|&v| patches.value[v as usize]).sum::<DVec3>() / 3.0;
            [mean, DVec3::ZERO, DVec3::ZERO]
        });
        fit.fitted_at = 3;
        (fit.residual, fit.low) = fit.measure(patches, fit.coef);
        fit
    }

    fn coords(&self, p: DVec3) -> DVec3 {
        let d = p - self.origin;
        DVec3::new(1.0, d.dot(self.axes[0]), d.dot(self.axes[1]))
    }

    fn eval(coef: [DVec3; 3], c: DVec3) -> DVec3 {
        coef[0] * c.x + coef[1] * c.y + coef[2] * c.z
    }

    fn add(&mut self, patches: &Patches, v: u32) {
        let c = self.coords(patches.mesh.positions[v as usize].as_dvec3());
        let b = patches.value[v as usize];
        self.normal += glam::DMat3::from_cols(c * c.x, c * c.y, c * c.z);
        for k in 0..3 {
            self.rhs[k] += b * c[k];
        }
        self.members.push(v);
    }

    /// The least-squares fit of the members so far, if the normal equations can be solved.
    fn solve(&self) -> Option<[DVec3; 3]> {
        // Dimensionless: the determinant against the product of the diagonal (Hadamard's bound),
        // near 0 when the members lie almost on a line.
        let m = &self.normal;
        let det = m.determinant();
        let scale = m.x_axis.x * m.y_axis.y * m.z_axis.z;
        if det.is_nan() || det <= 1e-9 * scale {
            return None;
        }
        let inverse = self.normal.inverse();
        // Per channel, coef = M⁻¹ rhs.
        let channel =
            |k: usize| inverse * DVec3::new(self.rhs[0][k], self.rhs[1][k], self.rhs[2][k]);
        let (r, g, b) = (channel(0), channel(1), channel(2));
        Some([
            DVec3::new(r.x, g.x, b.x),
            DVec3::new(r.y, g.y, b.y),
            DVec3::new(r.z, g.z, b.z),
        ])
    }

    /// The largest residual and the lowest value of `coef` over the members.
    fn measure(&self, patches: &Patches, coef: [DVec3; 3]) -> (DVec3, DVec3) {
        self.members
            .iter()
            .fold((DVec3::ZERO, DVec3::INFINITY), |(residual, low), &v| {
                let f = Fit::eval(
                    coef,
                    self.coords(patches.mesh.positions[v as usize].as_dvec3()),
                );
                (
                    residual.max((patches.value[v as usize] - f).abs()),
                    low.min(f),
                )
            })
    }

    /// How much of the window a residual and a lowest value use (at most 1 keeps the promise).
    fn used(&self, residual: DVec3, low: DVec3) -> f64 {
        (residual / (low.max(DVec3::splat(self.floor)) * self.e)).max_element()
    }

    /// Patch `p` joins if its corners keep the promise under the current fit (and the members
    /// still do with the lowest value it brings); then refits when the superface has doubled.
    pub(super) fn join(&mut self, patches: &Patches, p: u32) -> bool {
        let t = patches.mesh.triangles[p as usize];
        let (mut residual, mut low) = (self.residual, self.low);
        for &v in &t {
            let f = Fit::eval(
                self.coef,
                self.coords(patches.mesh.positions[v as usize].as_dvec3()),
            );
            residual = residual.max((patches.value[v as usize] - f).abs());
            low = low.min(f);
        }
        if self.used(residual, low) > 1.0 {
            return false;
        }
        (self.residual, self.low) = (residual, low);
        for v in t {
            self.add(patches, v);
        }
        if self.members.len() >= 2 * self.fitted_at {
            self.fitted_at = self.members.len();
            if let Some(coef) = self.solve() {
                let (r, l) = self.measure(patches, coef);
                if self.used(r, l) <= self.used(self.residual, self.low) {
                    (self.coef, self.residual, self.low) = (coef, r, l);
                }
            }
        }
        true
    }
}

/// [`SuperfaceStats::color_error_max`] and `…_mean` of `out` against the lit mesh.
pub(super) fn colour_error(patches: &Patches, out: &Mesh) -> (f64, f64) {
    let mesh = patches.mesh;
    let drawn: Vec<DVec3> = match (&mesh.radiosity, &out.radiosity, &out.colors) {
        (Some(_), Some(r), _) => r.iter().map(|c| c.as_dvec3()).collect(),
        (_, _, Some(c)) => c.iter().map(|c| c.as_dvec3() * 255.0).collect(),
        _ => return (f64::NAN, f64::NAN),
    };
    if out.triangles.is_empty() || mesh.positions.is_empty() {
        return (0.0, 0.0);
    }
    // Each lit vertex against the output triangles through its point in its own plane (a lit mesh
    // keeps each polygon's vertices apart, so at a crease the other side's triangles, at distance 0
    // too, are not what is drawn there); where several are (a seam within one plane), the closest
    // value counts.
    let mut normal_of = vec![DVec3::ZERO; mesh.positions.len()];
    for (f, t) in mesh.triangles.iter().enumerate() {
        for &v in t {
            normal_of[v as usize] = patches.normal[f];
        }
    }
    let bvh = crate::measure::Bvh::new(&out.positions, &out.triangles);
    let reach = 1e-6 * patches.diagonal;
    let errors: Vec<f64> = (0..mesh.positions.len())
        .filter_map(|v| {
            let p = mesh.positions[v].as_dvec3();
            let lit = patches.value[v];
            let scale = lit.max(DVec3::splat(patches.floor));
            let mut best: Option<f64> = None;
            bvh.any_overlapping(p - reach, p + reach, |t| {
                let [a, b, c] = bvh.triangle64(t);
                let n = (b - a).cross(c - a).normalize_or_zero();
                let q = crate::measure::closest_point_on_triangle64(p, a, b, c);
                if q.distance(p) <= reach && n.dot(normal_of[v]) >= 1.0 - 1e-6 {
                    let w = barycentric(p, a, b, c);
                    let at = out.triangles[bvh.input_index(t)].map(|u| drawn[u as usize]);
                    let value = at[0] * w[0] + at[1] * w[1] + at[2] * w[2];
                    let e = ((value - lit).abs() / scale).max_element();
                    best = Some(best.map_or(e, |b: f64| b.min(e)));
                }
                false
            });
            best
        })
        .collect();
    let max = errors.iter().copied().fold(0.0, f64::max);
    (max, errors.iter().sum::<f64>() / errors.len().max(1) as f64)
}

/// Barycentric weights of the point of triangle `abc` nearest to `p`.
fn barycentric(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    let q = crate::measure::closest_point_on_triangle64(p, a, b, c);
    let (v0, v1, v2) = (b - a, c - a, q - a);
    let (d00, d01, d11) = (v0.dot(v0), v0.dot(v1), v1.dot(v1));
    let (d20, d21) = (v2.dot(v0), v2.dot(v1));
    let denom = d00 * d11 - d01 * d01;
    if denom.abs() <= f64::MIN_POSITIVE {
        return [1.0, 0.0, 0.0];
    }
    let v = (d11 * d20 - d01 * d21) / denom;
    let w = (d00 * d21 - d01 * d20) / denom;
    [1.0 - v - w, v, w]
}

//! Progressive refinement radiosity (Cohen, Chen, Wallace and Greenberg, *A progressive refinement
//! approach to fast radiosity image generation*, SIGGRAPH 88), with form factors from the shooter to
//! the receiving elements by ray casting (Wallace, Elmquist and Haines, *A ray tracing
//! algorithm for progressive radiosity*, SIGGRAPH 89).
//!
//! - The shooter is the patch with the most unshot power. The form factor from each vertex facing
//!   it is the exact unoccluded one (Lambert's contour integral over the part of the patch above the
//!   vertex's plane) times the share of `k` sample points of the patch that a ray from the vertex
//!   reaches without meeting the scene (a BVH over its polygons): 16 on emitters, for soft shadow
//!   edges; 1 elsewhere, where the light is already soft. Receivers run in parallel (rayon).
//! - Light is received at element centroids (so no receiving point lies on the edge a source
//!   touches): an element gains `ρ · U · F`, and its patch's unshot radiosity gains that weighted
//!   by area. A vertex's radiosity is the area-weighted average of its elements' (C0 interpolation).
//! - **Adaptive subdivision** first: the emitters' direct light is shot, elements whose corners
//!   differ by more than a share of the mean radiosity are split (red–green, so the mesh stays
//!   conforming), down to a minimum size, and the direct light is shot again — a few rounds, so the
//!   shadow boundaries get fine elements. Then the full solution runs on the final mesh.
//! - **Overshooting** (Feda and Purgathofer, *Accelerating radiosity by overshooting*, Eurographics
//!   Workshop on Rendering 1992): a shooter sends its unshot radiosity plus `ρ · A`, the light the
//!   ambient estimate says it will still receive, and keeps `−ρ · A` as (negative) unshot, to be
//!   taken back later if the estimate was too high. The shooter is chosen by the magnitude of its
//!   unshot power. In bright closed rooms (high ρ), where plain progressive refinement sends most
//!   light round again and again, this converges in a few sweeps instead of hundreds.
//! - **The ambient term** of Cohen et al.: `A = R · Σ ΔB_p a_p / Σ a_p`, with `R = 1 / (1 − ρ̄)` the
//!   interreflection factor of the area-weighted mean reflectance, estimates the light still
//!   unshot; the result adds `ρ · A` to every element, so an early stop is an estimate of the
//!   converged solution, not a darker picture.
//! - It stops when the unshot power (absolute) is below a share of the emitted power, at a shot
//!   limit, at a time limit, or when asked to (Ctrl-C in the CLI); the result is always whole.

use super::elements::Elements;
use super::scene::Scene;
use crate::measure::Bvh;
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Settings of a solution; lengths are shares of the scene's bounding-box diagonal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiosityOptions {
    /// Stop when the unshot power is below this share of the emitted power.
    pub unshot: f64,
    /// Longest edge of a shooting patch.
    pub patch_size: f64,
    /// Longest edge of an element before adaptive subdivision.
    pub element_size: f64,
    /// Adaptive subdivision stops at elements this long.
    pub min_element_size: f64,
    /// Elements are split where their corners' radiosity differs by more than this share of the
    /// scene's mean radiosity.
    pub gradient: f64,
    /// Rounds of adaptive subdivision.
    pub rounds: usize,
    /// No further subdivision beyond this many elements.
    pub max_elements: usize,
    /// Stop after this many shots even if light is left.
    pub max_shots: usize,
    /// Stop after this many seconds of shooting even if light is left.
    pub max_seconds: f64,
    /// Shoot with overshooting (on by default; off gives plain progressive refinement).
    pub overshoot: bool,
    /// Add the ambient term to the result (on by default).
    pub ambient: bool,
}

impl Default for RadiosityOptions {
    fn default() -> Self {
        RadiosityOptions {
            unshot: 1e-3,
            patch_size: 0.12,
            element_size: 0.025,
            min_element_size: 0.002,
            gradient: 0.15,
            rounds: 4,
            max_elements: 400_000,
            max_shots: 100_000,
            max_seconds: f64::INFINITY,
            overshoot: true,
            ambient: true,
        }
    }
}

/// What a solution did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct RadiosityStats {
    pub patches: usize,
    pub elements: usize,
    pub vertices: usize,
    pub shots: usize,
    /// Unshot power left (its magnitude: overshooting leaves some negative), as a share of the
    /// emitted power.
    pub unshot: f64,
    pub seconds: f64,
    /// Why the solution stopped.
    pub stop: Stop,
    /// The ambient term added to the result (linear RGB, before each element's reflectance).
    pub ambient: [f64; 3],
}

/// Why a solution stopped shooting.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stop {
    /// The unshot power fell below the asked share.
    #[default]
    Converged,
    /// `max_shots` shots were made.
    MaxShots,
    /// `max_seconds` passed.
    MaxSeconds,
    /// The caller asked it to stop (Ctrl-C).
    Interrupted,
}

impl Stop {
    pub fn describe(self) -> &'static str {
        match self {
            Stop::Converged => "converged",
            Stop::MaxShots => "stopped at the shot limit",
            Stop::MaxSeconds => "stopped at the time limit",
            Stop::Interrupted => "interrupted",
        }
    }
}

/// A solved scene: the element mesh, radiosity (linear RGB) at its vertices and elements.
pub struct Solution {
    pub elements: Elements,
    /// Each vertex's radiosity: the area-weighted average of the elements around it.
    pub vertex_radiosity: Vec<DVec3>,
    /// Each element's radiosity, received at its centroid, and emitted.
    pub element_radiosity: Vec<DVec3>,
    pub stats: RadiosityStats,
}

/// Sample points per emitter patch (subdivision level 2: 16 sub-triangle centroids).
const EMITTER_LEVEL: u32 = 2;

struct Solver<'a> {
    scene: &'a Scene,
    occluders: Bvh,
    /// Each occluder's plane (unit normal, offset), in the hierarchy's order: a segment whose ends
    /// are both strictly on one side cannot cross it, which settles most tests with two dot products.
    occluder_planes: Vec<(DVec3, f64)>,
    elements: Elements,
    patches: Elements,
    patch_area: Vec<f64>,
    /// Radiosity of each element (received and emitted).
    element_b: Vec<DVec3>,
    unshot: Vec<DVec3>,
    /// Whether each patch has shot since the last reset: an emitter's first shot (its own light)
    /// gets many samples, for soft shadow edges; reflected light is soft already.
    has_shot: Vec<bool>,
    /// Each patch's reflectance.
    patch_rho: Vec<DVec3>,
    /// Offset of ray ends off their surfaces.
    lift: f64,
}

/// Solves `scene`; `progress(share of the light shot, what)` is called now and then.
pub fn solve(
    scene: &Scene,
    options: &RadiosityOptions,
    progress: &mut dyn FnMut(f64, &str),
) -> Solution {
    solve_until(scene, options, progress, &AtomicBool::new(false))
}

/// [`solve`], stopping early (with a whole result, its unshot share and the ambient term) once
/// `stop` is set — from a Ctrl-C handler, say.
pub fn solve_until(
    scene: &Scene,
    options: &RadiosityOptions,
    progress: &mut dyn FnMut(f64, &str),
    stop: &AtomicBool,
) -> Solution {
    let start = std::time::Instant::now();
    let (lo, hi) = scene
        .polygons
        .iter()
        .flat_map(|p| &p.corners)
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| {
            (lo.min(*c), hi.max(*c))
        });
    let diagonal = (hi - lo).length();
    let (elements, patches) = Elements::new(
        scene,
        options.patch_size * diagonal,
        options.element_size * diagonal,
    );
    let mut solver = Solver::new(scene, elements, patches, diagonal);
    let emitted = solver.emitted_power();
    // The direct light of the last round is the start of the solution when that round refined
    // nothing (the emitters have shot once on the final mesh); otherwise it starts afresh.
    let mut shots = 0;
    for round in 0..options.rounds {
        progress(0.0, &format!("adaptive subdivision, round {}", round + 1));
        solver.reset();
        shots = solver.shoot_emitters();
        let marked = solver.marked(options, diagonal);
        if !marked.contains(&true) || solver.elements.triangles.len() >= options.max_elements {
            break;
        }
        solver.elements.refine(&marked);
        shots = 0;
    }
    if shots == 0 {
        solver.reset();
    }
    let shooting = std::time::Instant::now();
    let (left, why) = loop {
        let left = solver.unshot_power() / emitted;
        if left < options.unshot {
            break (left, Stop::Converged);
        }
        if shots >= options.max_shots {
            break (left, Stop::MaxShots);
        }
        if shooting.elapsed().as_secs_f64() >= options.max_seconds {
            break (left, Stop::MaxSeconds);
        }
        if stop.load(Ordering::Relaxed) {
            break (left, Stop::Interrupted);
        }
        let (p, extra) = solver.next_shooter(options.overshoot);
        solver.shoot(p, extra);
        shots += 1;
        if shots % 16 == 0 {
            progress(
                (1.0 - left).clamp(0.0, 1.0),
                &format!("{shots} shots, unshot {:.3} %", 100.0 * left),
            );
        }
    };
    let ambient = if options.ambient {
        solver.ambient()
    } else {
        DVec3::ZERO
    };
    solver.add_ambient(ambient);
    let vertex_radiosity = vertex_average(&solver.elements, &solver.element_b);
    let stats = RadiosityStats {
        patches: solver.patches.triangles.len(),
        elements: solver.elements.triangles.len(),
        vertices: solver.elements.positions.len(),
        shots,
        unshot: left,
        seconds: start.elapsed().as_secs_f64(),
        stop: why,
        ambient: ambient.to_array(),
    };
    Solution {
        elements: solver.elements,
        vertex_radiosity,
        element_radiosity: solver.element_b,
        stats,
    }
}

impl<'a> Solver<'a> {
    fn new(scene: &'a Scene, elements: Elements, patches: Elements, diagonal: f64) -> Solver<'a> {
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for p in &scene.polygons {
            let base = positions.len() as u32;
            positions.extend(p.corners.iter().map(|c| c.as_vec3()));
            for i in 1..p.corners.len() as u32 - 1 {
                triangles.push([base, base + i, base + i + 1]);
            }
        }
        let patch_area = (0..patches.triangles.len())
            .map(|t| patches.area(t))
            .collect();
        let patch_rho = (0..patches.triangles.len())
            .map(|p| {
                let polygon = patches.vertex_polygon[patches.triangles[p][0] as usize];
                scene.materials[scene.polygons[polygon as usize].material as usize].reflectance
            })
            .collect();
        let occluders = Bvh::new(&positions, &triangles);
        let occluder_planes = (0..occluders.len())
            .map(|i| {
                let [a, b, c] = occluders.triangle64(i);
                let n = (b - a).cross(c - a).normalize_or_zero();
                (n, n.dot(a))
            })
            .collect();
        Solver {
            scene,
            occluders,
            occluder_planes,
            elements,
            patches,
            patch_area,
            element_b: Vec::new(),
            unshot: Vec::new(),
            has_shot: Vec::new(),
            patch_rho,
            lift: 1e-6 * diagonal,
        }
    }

    fn emission_of_patch(&self, p: usize) -> DVec3 {
        let polygon = self.patches.vertex_polygon[self.patches.triangles[p][0] as usize];
        self.scene.materials[self.scene.polygons[polygon as usize].material as usize].emission
    }

    fn emitted_power(&self) -> f64 {
        (0..self.patches.triangles.len())
            .map(|p| self.emission_of_patch(p).element_sum() * self.patch_area[p])
            .sum::<f64>()
            .max(f64::MIN_POSITIVE)
    }

    /// Every element at its emission, every emitter's full exitance unshot.
    fn reset(&mut self) {
        let e = &self.elements;
        self.element_b = (0..e.triangles.len())
            .map(|t| self.emission_of_polygon(e.vertex_polygon[e.triangles[t][0] as usize]))
            .collect();
        self.unshot = (0..self.patches.triangles.len())
            .map(|p| self.emission_of_patch(p))
            .collect();
        self.has_shot = vec![false; self.patches.triangles.len()];
    }

    fn emission_of_polygon(&self, polygon: u32) -> DVec3 {
        self.scene.materials[self.scene.polygons[polygon as usize].material as usize].emission
    }

    /// Every emitter shoots its own light once; returns how many shot.
    fn shoot_emitters(&mut self) -> usize {
        let mut shots = 0;
        for p in 0..self.patches.triangles.len() {
            if self.emission_of_patch(p).max_element() > 0.0 {
                self.shoot(p, DVec3::ZERO);
                shots += 1;
            }
        }
        shots
    }

    /// The next shooter and what it shoots beyond its unshot radiosity: the patch whose shot
    /// `ΔB_p + ρ_p · A` carries the most power in magnitude (summed over channels), with `A` the
    /// ambient term when overshooting (zero otherwise). A patch that has just overshot holds about
    /// `−ρ_p · A` unshot, so its next shot would be nearly empty and it is not picked again until
    /// the light it receives or a change of `A` makes it worth it.
    fn next_shooter(&self, overshoot: bool) -> (usize, DVec3) {
        let ambient = if overshoot {
            self.ambient()
        } else {
            DVec3::ZERO
        };
        let power = |p: usize| {
            (self.unshot[p] + self.patch_rho[p] * ambient)
                .element_sum()
                .abs()
                * self.patch_area[p]
        };
        let p = (0..self.unshot.len())
            .map(|p| (p, power(p)))
            .fold(
                (0, f64::NEG_INFINITY),
                |best, x| if x.1 > best.1 { x } else { best },
            )
            .0;
        (p, self.patch_rho[p] * ambient)
    }

    /// Unshot power of all patches, in magnitude (summed over channels).
    fn unshot_power(&self) -> f64 {
        (0..self.unshot.len())
            .map(|p| self.unshot[p].abs().element_sum() * self.patch_area[p])
            .sum()
    }

    /// Cohen et al.'s ambient term: the area-weighted mean unshot radiosity times the
    /// interreflection factor `1 / (1 − ρ̄)`, per channel.
    fn ambient(&self) -> DVec3 {
        let (mut unshot, mut rho, mut area) = (DVec3::ZERO, DVec3::ZERO, 0.0);
        for p in 0..self.unshot.len() {
            unshot += self.unshot[p] * self.patch_area[p];
            rho += self.patch_rho[p] * self.patch_area[p];
            area += self.patch_area[p];
        }
        if area <= 0.0 {
            return DVec3::ZERO;
        }
        unshot / area / (DVec3::ONE - rho / area)
    }

    /// Adds `ρ · ambient` to every element.
    fn add_ambient(&mut self, ambient: DVec3) {
        if ambient == DVec3::ZERO {
            return;
        }
        let e = &self.elements;
        for t in 0..e.triangles.len() {
            let polygon = e.vertex_polygon[e.triangles[t][0] as usize] as usize;
            let rho =
                self.scene.materials[self.scene.polygons[polygon].material as usize].reflectance;
            self.element_b[t] += rho * ambient;
        }
    }

    /// Shoots patch `p`'s unshot radiosity plus `extra` to every element; `−extra` stays unshot.
    fn shoot(&mut self, p: usize, extra: DVec3) {
        let u = std::mem::replace(&mut self.unshot[p], -extra) + extra;
        if u == DVec3::ZERO {
            return;
        }
        let first = !std::mem::replace(&mut self.has_shot[p], true);
        let level = if first && self.emission_of_patch(p).max_element() > 0.0 {
            EMITTER_LEVEL
        } else {
            0
        };
        let samples = sample_points(self.patches.corners(p), level);
        let source_normal = self.patches.polygon_normal
            [self.patches.vertex_polygon[self.patches.triangles[p][0] as usize] as usize];
        let e = &self.elements;
        let corners = self.patches.corners(p);
        let lifted: Vec<DVec3> = samples
            .iter()
            .map(|&s| s + source_normal * self.lift)
            .collect();
        let gains: Vec<DVec3> = (0..e.triangles.len())
            .into_par_iter()
            .map(|t| {
                let polygon = e.vertex_polygon[e.triangles[t][0] as usize] as usize;
                let n = e.polygon_normal[polygon];
                let [a, b, c] = e.corners(t);
                let x = (a + b + c) / 3.0;
                // Behind the source's plane, nothing arrives.
                if source_normal.dot(x - corners[0]) <= 0.0 {
                    return DVec3::ZERO;
                }
                let from = x + n * self.lift;
                // Many samples, and nothing can come between the receiver and the patch: the
                // rays need not be cast.
                let clear = samples.len() > 1 && self.shaft_clear(from, &lifted);
                let f = form_factor(x, n, corners, &samples, |s| {
                    clear || self.visible(from, s + source_normal * self.lift)
                });
                if f <= 0.0 {
                    return DVec3::ZERO;
                }
                let rho = self.scene.materials[self.scene.polygons[polygon].material as usize]
                    .reflectance;
                rho * u * f
            })
            .collect();
        for (t, gain) in gains.iter().enumerate() {
            if *gain != DVec3::ZERO {
                self.element_b[t] += *gain;
                let q = self.elements.element_patch[t] as usize;
                self.unshot[q] += *gain * (self.elements.area(t) / self.patch_area[q]);
            }
        }
    }

    /// Whether no scene polygon can cross any segment from `x` to one of the `points` (shaft
    /// culling, after Haines and Wallace, *Shaft culling for efficient ray-traced radiosity*,
    /// 1991, in its simplest form): every polygon whose box meets the shaft's box has all the
    /// points strictly on one side of its plane, so none crosses the shaft, the convex hull of the
    /// points and `x`. Conservative: `false` when it cannot tell.
    fn shaft_clear(&self, x: DVec3, points: &[DVec3]) -> bool {
        let (lo, hi) = points
            .iter()
            .fold((x, x), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let scale = lo.abs().max(hi.abs()).max_element();
        !self.occluders.any_overlapping(lo, hi, |i| {
            let (n, d) = self.occluder_planes[i];
            let slack = 1e-12 * (scale + d.abs());
            let side = |p: &DVec3| n.dot(*p) - d;
            let above = side(&x) > slack;
            if !above && side(&x) >= -slack {
                return true;
            }
            !points.iter().all(|p| {
                if above {
                    side(p) > slack
                } else {
                    side(p) < -slack
                }
            })
        })
    }

    /// Whether the open segment `a`–`b` misses every scene polygon.
    fn visible(&self, a: DVec3, b: DVec3) -> bool {
        let (lo, hi) = (a.min(b), a.max(b));
        !self.occluders.any_overlapping(lo, hi, |i| {
            let (n, d) = self.occluder_planes[i];
            let (sa, sb) = (n.dot(a) - d, n.dot(b) - d);
            // Both ends strictly on one side, by more than rounding: no crossing.
            let slack = 1e-12 * (a.abs().max_element() + b.abs().max_element() + d.abs());
            if (sa > slack && sb > slack) || (sa < -slack && sb < -slack) {
                return false;
            }
            segment_hits(a, b, &self.occluders.triangle64(i))
        })
    }

    /// Elements to split: corners apart by more than `gradient` × the mean radiosity, and longer
    /// than the minimum size.
    fn marked(&self, options: &RadiosityOptions, diagonal: f64) -> Vec<bool> {
        let at_vertices = vertex_average(&self.elements, &self.element_b);
        let mean = at_vertices.iter().map(|b| b.element_sum()).sum::<f64>()
            / at_vertices.len().max(1) as f64;
        let limit = options.gradient * mean;
        let min = options.min_element_size * diagonal;
        (0..self.elements.triangles.len())
            .map(|t| {
                let b = self.elements.triangles[t].map(|v| at_vertices[v as usize]);
                let spread = (b[0] - b[1])
                    .abs()
                    .max((b[1] - b[2]).abs())
                    .max((b[2] - b[0]).abs())
                    .element_sum();
                spread > limit && self.elements.longest_edge(t) > 2.0 * min
            })
            .collect()
    }
}

/// Each vertex's radiosity: the area-weighted average of the elements around it (the paper's C0
/// interpolation).
pub fn vertex_average(e: &Elements, element_b: &[DVec3]) -> Vec<DVec3> {
    let mut sum = vec![DVec3::ZERO; e.positions.len()];
    let mut weight = vec![0.0; e.positions.len()];
    for (t, tri) in e.triangles.iter().enumerate() {
        let a = e.area(t);
        for &v in tri {
            sum[v as usize] += element_b[t] * a;
            weight[v as usize] += a;
        }
    }
    sum.iter()
        .zip(&weight)
        .map(|(s, w)| if *w > 0.0 { *s / *w } else { DVec3::ZERO })
        .collect()
}

/// The form factor from a differential area at `x` with normal `n` to the patch `t`, occlusion
/// included: the exact unoccluded factor of the part of `t` above `x`'s tangent plane, times the
/// share of the `samples` **on that part** that `visible` reaches. The horizon is counted once: the
/// clipping already leaves out what lies below the plane, so samples there are not counted again as
/// unseen. When no sample lies above the plane but a sliver of the patch does, that sliver's centre
/// stands in for them.
pub(crate) fn form_factor(
    x: DVec3,
    n: DVec3,
    t: [DVec3; 3],
    samples: &[DVec3],
    visible: impl Fn(DVec3) -> bool,
) -> f64 {
    let f = point_to_triangle(x, n, t);
    if f <= 0.0 {
        return 0.0;
    }
    let (mut above, mut seen) = (0usize, 0usize);
    for &s in samples.iter().filter(|&&s| n.dot(s - x) > 0.0) {
        above += 1;
        seen += usize::from(visible(s));
    }
    if above == 0 {
        let part = clip_above(x, n, t);
        let centre = x + part.iter().sum::<DVec3>() / part.len().max(1) as f64;
        return if visible(centre) { f } else { 0.0 };
    }
    f * seen as f64 / above as f64
}

/// The part of triangle `t` on or above the plane through `x` with normal `n`, relative to `x`
/// (Sutherland–Hodgman against one plane): empty, or a polygon of 3 or 4 corners.
fn clip_above(x: DVec3, n: DVec3, t: [DVec3; 3]) -> Vec<DVec3> {
    let mut poly: Vec<DVec3> = Vec::with_capacity(4);
    for i in 0..3 {
        let (a, b) = (t[i] - x, t[(i + 1) % 3] - x);
        let (da, db) = (n.dot(a), n.dot(b));
        if da >= 0.0 {
            poly.push(a);
        }
        if (da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0) {
            poly.push(a + (b - a) * (da / (da - db)));
        }
    }
    if poly.len() < 3 {
        poly.clear();
    }
    poly
}

/// The form factor from a differential area at `x` with normal `n` to the triangle `t`, unoccluded:
/// Lambert's contour integral `(1 / 2π) Σ θ_i n · γ_i` over the part of `t` above `x`'s tangent
/// plane (exact, also where the triangle is near or touches `x`, unlike a point-to-disc estimate).
fn point_to_triangle(x: DVec3, n: DVec3, t: [DVec3; 3]) -> f64 {
    let poly = clip_above(x, n, t);
    if poly.is_empty() {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let c = a.cross(b);
        let len = c.length();
        if len <= 1e-300 || a.length_squared() == 0.0 || b.length_squared() == 0.0 {
            continue;
        }
        let theta = len.atan2(a.dot(b));
        sum += theta * n.dot(c) / len;
    }
    (sum / (2.0 * std::f64::consts::PI)).abs()
}

/// Points spread over a triangle: the centroids of its `4^level` sub-triangles.
fn sample_points(t: [DVec3; 3], level: u32) -> Vec<DVec3> {
    let mut tris = vec![t];
    for _ in 0..level {
        tris = tris
            .into_iter()
            .flat_map(|[a, b, c]| {
                let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    tris.iter().map(|[a, b, c]| (*a + *b + *c) / 3.0).collect()
}

/// Whether segment `ab` crosses triangle `t` strictly between its ends (Möller and Trumbore).
fn segment_hits(a: DVec3, b: DVec3, t: &[DVec3; 3]) -> bool {
    let d = b - a;
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return false;
    }
    let inv = 1.0 / det;
    let s = a - t[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let h = e2.dot(q) * inv;
    h > 1e-9 && h < 1.0 - 1e-9
}

#[cfg(test)]
mod tests {
    use super::*;

    /// From the middle of a cube's floor, the other five faces fill the hemisphere: their form
    /// factors sum to 1; the ceiling alone is Howell's C-13 closed form for a parallel square.
    #[test]
    fn form_factors_close_the_hemisphere() {
        let x = DVec3::new(0.5, 0.0, 0.5);
        let n = DVec3::Y;
        let quads = [
            [[0., 1., 0.], [1., 1., 0.], [1., 1., 1.], [0., 1., 1.]],
            [[0., 0., 0.], [0., 1., 0.], [0., 1., 1.], [0., 0., 1.]],
            [[1., 0., 0.], [1., 1., 0.], [1., 1., 1.], [1., 0., 1.]],
            [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]],
            [[0., 0., 1.], [1., 0., 1.], [1., 1., 1.], [0., 1., 1.]],
        ];
        let mut total = 0.0;
        let mut ceiling = 0.0;
        for (i, q) in quads.iter().enumerate() {
            let q = q.map(DVec3::from);
            let f = point_to_triangle(x, n, [q[0], q[1], q[2]])
                + point_to_triangle(x, n, [q[0], q[2], q[3]]);
            if i == 0 {
                ceiling = f;
            }
            total += f;
        }
        // Parallel square of side 1 centred at height 1: F = (2/π)(a/√(1+a²)) atan(a/√(1+a²)) · 2 …
        // with a = 0.5 per quadrant: 4 · (1/2π)(a/√(1+a²) atan(a/√(1+a²)) · 2).
        let a: f64 = 0.5;
        let quadrant = (1.0 / (2.0 * std::f64::consts::PI))
            * (2.0 * a / (1.0 + a * a).sqrt() * (a / (1.0 + a * a).sqrt()).atan());
        assert!((total - 1.0).abs() < 1e-9, "{total}");
        assert!(
            (ceiling - 4.0 * quadrant).abs() < 1e-9,
            "{ceiling} {}",
            4.0 * quadrant
        );
    }

    /// Reciprocity, `A_i F_ij = A_j F_ji`, on random pairs of triangles facing each other, each
    /// wholly in front of the other: the point-to-triangle factor integrated over each triangle (the
    /// midpoint rule on 24² sub-triangles) agrees both ways within 2 %.
    #[test]
    fn reciprocity_on_random_pairs() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut random = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let normal = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        let in_front = |t: &[DVec3; 3], of: &[DVec3; 3]| {
            let n = normal(of);
            t.iter().all(|p| n.dot(*p - of[0]) > 0.05)
        };
        // ∫ over `r` of the factor to `s`, as the midpoint rule on k² sub-triangles.
        let integral = |r: &[DVec3; 3], s: &[DVec3; 3]| {
            let k = 24;
            let n = normal(r);
            let area = 0.5 * (r[1] - r[0]).cross(r[2] - r[0]).length() / (k * k) as f64;
            let mut sum = 0.0;
            for i in 0..k {
                for j in 0..k - i {
                    // The upright sub-triangle at (i, j) and, but for the last in its row, the
                    // inverted one beside it: their centroids in barycentric steps of 1/k.
                    let mut centroids = vec![(i as f64 + 1.0 / 3.0, j as f64 + 1.0 / 3.0)];
                    if j + i + 1 < k {
                        centroids.push((i as f64 + 2.0 / 3.0, j as f64 + 2.0 / 3.0));
                    }
                    for (u, v) in centroids {
                        let x =
                            r[0] + (r[1] - r[0]) * (u / k as f64) + (r[2] - r[0]) * (v / k as f64);
                        sum += point_to_triangle(x, n, *s) * area;
                    }
                }
            }
            sum
        };
        let mut pairs = 0;
        while pairs < 25 {
            let mut corner = |y: f64| DVec3::new(2.0 * random(), y + random(), 2.0 * random());
            let mut a = [corner(0.0), corner(0.0), corner(0.0)];
            let mut b = [corner(1.5), corner(1.5), corner(1.5)];
            // Face each other: a's normal towards b, b's towards a.
            if normal(&a).dot(b[0] - a[0]) < 0.0 {
                a.swap(1, 2);
            }
            if normal(&b).dot(a[0] - b[0]) < 0.0 {
                b.swap(1, 2);
            }
            if !(in_front(&a, &b) && in_front(&b, &a)) {
                continue;
            }
            pairs += 1;
            let (ab, ba) = (integral(&a, &b), integral(&b, &a));
            assert!(ab > 0.0);
            assert!(
                (ab - ba).abs() <= 0.02 * ab.max(ba),
                "A_a F_ab = {ab}, A_b F_ba = {ba}"
            );
        }
    }

    /// Two parallel unit squares at distance 1: the area-to-area form factor is 0.1998 (closed
    /// form); averaging the point-to-square factor over the receiver gives it within 1 %.
    #[test]
    fn parallel_unit_squares() {
        let top = [[0., 1., 0.], [1., 1., 0.], [1., 1., 1.], [0., 1., 1.]].map(DVec3::from);
        let k = 40;
        let mut sum = 0.0;
        for i in 0..k {
            for j in 0..k {
                let x = DVec3::new(
                    (i as f64 + 0.5) / k as f64,
                    0.0,
                    (j as f64 + 0.5) / k as f64,
                );
                sum += point_to_triangle(x, DVec3::Y, [top[0], top[1], top[2]])
                    + point_to_triangle(x, DVec3::Y, [top[0], top[2], top[3]]);
            }
        }
        let f = sum / (k * k) as f64;
        assert!((f - 0.19982).abs() < 0.002, "{f}");
    }
}

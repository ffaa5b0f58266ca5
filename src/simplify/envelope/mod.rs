//! Simplification inside envelopes: the three methods compared by Zou Beiji, Shen Yuxiang and Peng
//! Qunsheng, *Triangulated surface model simplification using part offset-patches as errors
//! tolerance*, Acta Electronica Sinica 33(5), 2005, pp. 798–803 — each a loop of triangle collapses
//! (`work`), differing only in what a collapse must stay inside:
//!
//! - [`Method::OffsetPatch`], the paper's own: two local offset patches built per collapse (`patch`);
//! - [`Method::SingleEnvelope`], the authors' earlier method: one whole inner envelope (`whole`);
//! - [`Method::Cohen`], Cohen et al.'s *Simplification envelopes* (SIGGRAPH 96): whole inner and outer
//!   envelopes (`whole`).
//!
//! All three bound only how far the simplified surface strays (output → input), and the local one
//! only per step; `simplify --method bounded` is the one that certifies both directions. See
//! docs/ENVELOPES.md.

mod patch;
mod whole;
mod work;

use crate::measure::Bvh;
use crate::mesh::Mesh;
use crate::simplify::DistanceError;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicUsize, Ordering};
use work::{Refusal, Work};

/// Which envelope a collapse must stay inside.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    OffsetPatch,
    SingleEnvelope,
    Cohen,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::OffsetPatch => "offset-patch",
            Method::SingleEnvelope => "single-envelope",
            Method::Cohen => "cohen",
        }
    }
}

/// Settings of an envelope simplification.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvelopeOptions {
    pub method: Method,
    /// ε0, the largest offset, as a fraction of the input's bounding-box diagonal.
    pub epsilon: f64,
    /// Stop at this many triangles (or when no collapse passes).
    pub target_triangles: usize,
}

/// What a run did.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct EnvelopeStats {
    pub method: Method,
    pub triangles: usize,
    pub collapses_tried: usize,
    pub collapses_accepted: usize,
    /// Refused before any envelope test: a corner on a boundary or non-manifold edge, a result that
    /// would not be manifold, or a triangle that would turn over.
    pub refused_frozen: usize,
    pub refused_topology: usize,
    pub refused_fold: usize,
    /// Triangle–triangle intersection tests, building the envelopes and checking collapses.
    pub intersection_tests: usize,
    /// Seconds spent building whole envelopes (0 for the local patches).
    pub envelope_seconds: f64,
    /// Vertices whose whole-envelope offset ended at 0.
    pub pinned_vertices: usize,
    pub seconds: f64,
}

/// A thread-safe count of intersection tests.
#[derive(Default)]
pub(crate) struct Counter(AtomicUsize);

impl Counter {
    fn add(&self, n: usize) {
        self.0.fetch_add(n, Ordering::Relaxed);
    }

    fn get(&self) -> usize {
        self.0.load(Ordering::Relaxed)
    }
}

/// A triangle waiting in the queue, cheapest first.
#[derive(PartialEq)]
struct Candidate {
    cost: f64,
    face: u32,
    versions: [u32; 3],
}

impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Candidate {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        o.cost.total_cmp(&self.cost).then(o.face.cmp(&self.face))
    }
}

/// Simplifies `mesh` by triangle collapses inside the envelope of `options.method`;
/// `progress(triangles now)` is called now and then.
pub fn simplify_envelope(
    mesh: &Mesh,
    options: &EnvelopeOptions,
    progress: &mut dyn FnMut(usize),
) -> Result<(Mesh, EnvelopeStats), DistanceError> {
    let start = std::time::Instant::now();
    if mesh.triangles.is_empty() {
        return Err(DistanceError::Empty);
    }
    if !(options.epsilon > 0.0 && options.epsilon < 1.0) {
        return Err(DistanceError::Epsilon(options.epsilon));
    }
    let (lo, hi) = mesh.bounds();
    let eps0 = options.epsilon * (hi.as_dvec3() - lo.as_dvec3()).length();
    let original = Bvh::new(&mesh.positions, &mesh.triangles);
    let tests = Counter::default();
    let mut stats = EnvelopeStats {
        method: options.method,
        triangles: 0,
        collapses_tried: 0,
        collapses_accepted: 0,
        refused_frozen: 0,
        refused_topology: 0,
        refused_fold: 0,
        intersection_tests: 0,
        envelope_seconds: 0.0,
        pinned_vertices: 0,
        seconds: 0.0,
    };
    let envelope = match options.method {
        Method::OffsetPatch => None,
        Method::SingleEnvelope => Some(whole::Envelope::build(
            mesh,
            &original,
            eps0,
            &[-1.0],
            &tests,
        )),
        Method::Cohen => Some(whole::Envelope::build(
            mesh,
            &original,
            eps0,
            &[1.0, -1.0],
            &tests,
        )),
    };
    if envelope.is_some() {
        stats.envelope_seconds = start.elapsed().as_secs_f64();
    }
    stats.pinned_vertices = envelope.as_ref().map_or(0, |e| e.pinned);
    let mut w = Work::new(mesh);
    let mut queue: BinaryHeap<Candidate> = (0..w.faces.len() as u32)
        .map(|f| candidate(&w, f))
        .collect();
    while w.live_faces > options.target_triangles {
        let Some(c) = queue.pop() else { break };
        if !w.alive[c.face as usize] || w.versions(c.face) != c.versions {
            continue;
        }
        stats.collapses_tried += 1;
        let plan = match w.plan(c.face) {
            Ok(plan) => plan,
            Err(refusal) => {
                match refusal {
                    Refusal::Frozen => stats.refused_frozen += 1,
                    Refusal::Topology => stats.refused_topology += 1,
                    Refusal::Fold => stats.refused_fold += 1,
                }
                continue;
            }
        };
        let admitted = match &envelope {
            None => patch::admits(&w, &plan, eps0, &original, &tests),
            Some(e) => e.admits(&plan.deformed, &tests),
        };
        if admitted {
            let v = w.apply(plan);
            stats.collapses_accepted += 1;
            let around: Vec<u32> = w.live_around(v).collect();
            queue.extend(around.into_iter().map(|f| candidate(&w, f)));
            if stats.collapses_accepted.is_multiple_of(64) {
                progress(w.live_faces);
            }
        }
    }
    stats.triangles = w.live_faces;
    stats.intersection_tests = tests.get();
    stats.seconds = start.elapsed().as_secs_f64();
    progress(w.live_faces);
    Ok((w.into_mesh(mesh), stats))
}

fn candidate(w: &Work, face: u32) -> Candidate {
    Candidate {
        cost: w.cost(face),
        face,
        versions: w.versions(face),
    }
}

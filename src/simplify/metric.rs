//! What a merge costs and where the merged vertex goes: the four metrics `--metric` chooses from.

use super::attribute_quadric::LocalAttributeQuadric;
use super::features::{CREASE_WEIGHT, DART_WEIGHT};
use super::quadric::{LocalQuadric, Quadric};
use glam::{DVec3, Vec3};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Metric {
    /// Garland–Heckbert quadrics, vertex at the quadric's optimum (Chen's comparison, method 3).
    #[default]
    Qem,
    /// Quadric cost, vertex at the midpoint (Chen's comparison, method 2).
    QemMidpoint,
    /// Cost = squared edge length, vertex at the midpoint (Chen's comparison, method 1).
    EdgeLength,
    /// Tao, Cheng, Pan and Shi's eq. 2: w1·E_dist + w2·E_feature with Tables 1 and 2.
    Hybrid,
}

impl Metric {
    pub fn code(self) -> u32 {
        self as u32
    }
    pub fn from_code(code: u32) -> Option<Metric> {
        [
            Metric::Qem,
            Metric::QemMidpoint,
            Metric::EdgeLength,
            Metric::Hybrid,
        ]
        .get(code as usize)
        .copied()
    }
    pub fn name(self) -> &'static str {
        ["qem", "qem-midpoint", "edge-length", "hybrid"][self as usize]
    }
}

/// Table 2: pair weight by how the two vertices are connected.
pub const SMOOTH_EDGE_PAIR: f32 = 0.0;
pub const FEATURE_EDGE_PAIR: f32 = 0.5;
pub const NO_EDGE_PAIR: f32 = 10.0;

/// The optimum may not lie farther from the pair's midpoint than this many pair lengths: beyond, the
/// system is nearly singular in some direction and the "optimum" is numerical noise (meshoptimizer and
/// most QEM codes clamp similarly).
const PLACEMENT_REACH: f64 = 2.0;

/// Weight of the squared pair length added to quadric costs. On flat regions (CAD faces) every merge
/// costs zero and greedy order degenerates into one hub vertex swallowing its whole face, one merge at
/// a time: a tree thousands of levels deep. Preferring short pairs among equals keeps the tree balanced
/// and leaves non-zero costs practically untouched (at 1e-3 it already reorders real merges and costs
/// fandisk 2.5× the mean error).
const TIE_BREAK: f64 = 1e-5;

/// The tie-break's squared length is capped at this share of the area the pair's two ends stand
/// for (their quadrics' weights). A long pair over little area is a long edge of slivers: on a
/// finely tessellated CAD tube, merging along the tube's straight lines costs nothing, but uncapped
/// its length made each such merge cost like a real error, so the rings were thinned first and the
/// tube kept all its rings at 1 % (2.8× meshoptimizer's mean error; 0.5× capped). A hub that grew
/// over a flat face stands for its whole area, so the cap leaves it priced by length as before.
/// 0.02 of the table in BENCHMARKS.md's quality section, from 0.01–1 tried: the CAD-like models
/// and fandisk need ≤ 0.05, cessna's thin wings and fandisk at 1 % vary most with it.
const TIE_BREAK_AREA: f64 = 0.02;

/// Hybrid-metric weights (Tao et al.'s eq. 2).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HybridWeights {
    /// w1, on the squared distance in units of the input's mean edge length.
    pub distance: f32,
    /// w2, on the feature term.
    pub feature: f32,
}

impl Default for HybridWeights {
    fn default() -> Self {
        HybridWeights {
            distance: 1.0,
            feature: 1.0,
        }
    }
}

/// A priced merge.
#[derive(Clone, Copy, Debug)]
pub struct Candidate {
    /// What the queue is ordered by.
    pub cost: f64,
    pub position: Vec3,
    /// Geometric error estimate of the merged vertex (object-space length): the root-mean-square
    /// distance to the planes it stands for, and for a merge across a gap at least half the gap.
    pub error: f64,
}

/// Everything pricing reads of one end of a pair, in one cache line: a pass prices each vertex's
/// pairs with its neighbours, which lie scattered in memory.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub struct PairEnd {
    /// The vertex's quadric, about `position`.
    pub quadric: LocalQuadric,
    pub position: Vec3,
    /// Table 1 weight.
    pub weight: f32,
}

impl PairEnd {
    /// `quadric` is about the world's origin.
    pub fn new(quadric: &Quadric, position: Vec3, weight: f32) -> PairEnd {
        PairEnd {
            quadric: LocalQuadric::new(&quadric.shifted(position.as_dvec3())),
            position,
            weight,
        }
    }

    /// The quadric about `origin`.
    pub fn quadric_about(&self, origin: DVec3) -> Quadric {
        self.quadric
            .get()
            .shifted(origin - self.position.as_dvec3())
    }

    /// The end that `a` and `b` merge into, at `position`: the quadrics' sum, the features kept.
    pub fn merged(a: &PairEnd, b: &PairEnd, position: Vec3) -> PairEnd {
        let p = position.as_dvec3();
        let (qa, qb) = (a.quadric_about(p), b.quadric_about(p));
        PairEnd {
            quadric: LocalQuadric::new(&(qa + qb)),
            position,
            weight: merged_weight(a.weight, b.weight),
        }
    }

    /// The attribute quadric that `a`'s and `b`'s (`ca`, `cb`) merge into, about `position`.
    pub fn merged_color(
        (a, ca): (&PairEnd, &LocalAttributeQuadric),
        (b, cb): (&PairEnd, &LocalAttributeQuadric),
        position: Vec3,
    ) -> LocalAttributeQuadric {
        let p = position.as_dvec3();
        LocalAttributeQuadric::new(&(ca.about(a.position, p) + cb.about(b.position, p)))
    }
}

pub struct Pricing {
    pub metric: Metric,
    pub hybrid: HybridWeights,
    pub mean_edge_length: f32,
    /// Length that a colour difference of 1 (a full channel) counts as, 0 to ignore appearance: a
    /// merge's price gains the mean squared residual of its attribute quadrics at the merged vertex
    /// (see [`super::attribute_quadric`], whose channels are built in these units), as its shape
    /// price is the mean squared distance to its planes.
    pub color_scale: f32,
}

impl Pricing {
    /// What merging `a` and `b` costs and where the merged vertex goes; `colors`, the ends' colour
    /// quadrics for a mesh with colours.
    pub fn price(
        &self,
        a: &PairEnd,
        b: &PairEnd,
        edge: bool,
        colors: Option<[&LocalAttributeQuadric; 2]>,
    ) -> Candidate {
        let (da, db) = (a.position.as_dvec3(), b.position.as_dvec3());
        let mid = 0.5 * (da + db);
        // Both quadrics about the midpoint: positions below are relative to it.
        let q = a.quadric_about(mid) + b.quadric_about(mid);
        let (ra, rb) = (da - mid, db - mid);
        let gap2 = da.distance_squared(db);
        // A merge without an edge pulls two separate pieces of surface together: each moves by at least
        // half the gap, which the planes of two parallel sheets cannot see.
        let no_edge = if edge { 0.0 } else { 0.25 * gap2 };
        let area = (a.quadric.weight() + b.quadric.weight()) as f64;
        let tie = TIE_BREAK * gap2.min(TIE_BREAK_AREA * area);
        // The quadric's error at the position, where the metric has it already.
        let (wa, wb) = (a.weight, b.weight);
        // (position relative to the midpoint, cost, the quadric's error there where the metric has it)
        let (offset, cost, plane_error) = match self.metric {
            Metric::Qem => {
                let reach = PLACEMENT_REACH * gap2.sqrt();
                // A more featured end keeps its place (Table 1: a corner stays a corner, a crease vertex
                // stays on its crease): the optimum of a quadric near a feature slides along it, and
                // on CAD parts that rounds corners off (this halves fandisk's max error at 10 %).
                let best = if wa != wb {
                    if wa > wb { ra } else { rb }
                } else {
                    match q.optimum() {
                        Some(v) if v.length() <= reach.max(f64::EPSILON) => v,
                        // Ill-conditioned: the best of the two ends and the midpoint.
                        _ => [ra, rb, DVec3::ZERO]
                            .into_iter()
                            .min_by(|x, y| q.eval(*x).total_cmp(&q.eval(*y)))
                            .unwrap_or(DVec3::ZERO),
                    }
                };
                let e = q.error(best);
                (best, e + no_edge + tie, Some(e))
            }
            Metric::QemMidpoint => {
                let e = q.error(DVec3::ZERO);
                (DVec3::ZERO, e + no_edge + tie, Some(e))
            }
            Metric::EdgeLength => (DVec3::ZERO, gap2 + no_edge, None),
            Metric::Hybrid => {
                // Keep the more featured vertex where it is (a corner stays a corner).
                let position = if wa > wb {
                    ra
                } else if wb > wa {
                    rb
                } else {
                    DVec3::ZERO
                };
                let pair = if !edge {
                    NO_EDGE_PAIR
                } else if wa >= DART_WEIGHT && wb >= DART_WEIGHT {
                    FEATURE_EDGE_PAIR
                } else {
                    SMOOTH_EDGE_PAIR
                };
                let unit = (self.mean_edge_length as f64).max(f64::MIN_POSITIVE);
                let e_dist = gap2 / (unit * unit);
                let e_feature = (wa + wb + pair) as f64;
                (
                    position,
                    self.hybrid.distance as f64 * e_dist + self.hybrid.feature as f64 * e_feature,
                    None,
                )
            }
        };
        let error = plane_error
            .unwrap_or_else(|| q.error(offset))
            .sqrt()
            .max(if edge { 0.0 } else { 0.5 * gap2.sqrt() });
        // An end kept in place stays exactly where it was.
        let position = if offset == ra {
            a.position
        } else if offset == rb {
            b.position
        } else {
            (mid + offset).as_vec3()
        };
        let color = match colors {
            Some([ca, cb]) if self.color_scale > 0.0 => {
                LocalAttributeQuadric::pair_mean_residual(ca, offset - ra, cb, offset - rb)
            }
            _ => 0.0,
        };
        Candidate {
            cost: cost + color,
            position,
            error,
        }
    }
}

/// The merged vertex's Table 1 weight: a feature survives a merge.
pub fn merged_weight(a: f32, b: f32) -> f32 {
    a.max(b).max(if a >= DART_WEIGHT && b >= DART_WEIGHT {
        CREASE_WEIGHT
    } else {
        0.0
    })
}

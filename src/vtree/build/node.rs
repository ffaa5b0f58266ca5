//! A new node's attributes, bounds and error, from its children and the triangles around it.

use super::NONE;
use crate::simplify::bounds::{NormalCone, Sphere};
use crate::simplify::collapse::Collapser;
use crate::simplify::geometry::{LANES, nearest_squared};
use crate::vtree::Node;
use glam::Vec3;

/// Cheap cone around a set of unit normals: axis their mean, angle their largest deviation from it.
pub(super) fn cone_of(normals: impl Iterator<Item = Vec3> + Clone) -> NormalCone {
    let sum: Vec3 = normals.clone().sum();
    let axis = sum.normalize_or_zero();
    if axis == Vec3::ZERO {
        return if normals.clone().next().is_some() {
            NormalCone::FULL
        } else {
            NormalCone::EMPTY
        };
    }
    let min_dot = normals.map(|n| n.dot(axis)).fold(1.0f32, f32::min);
    if min_dot <= -0.999 {
        return NormalCone::FULL;
    }
    // Pad by about 0.1° so rounding never leaves a member outside.
    NormalCone {
        axis,
        cos_angle: (min_dot.clamp(-1.0, 1.0).acos() + 2e-3).cos(),
    }
}

/// A triangle around a merged vertex, as [`finish_node`] reads it.
pub(super) struct FanTriangle {
    pub(super) corners: [Vec3; 3],
    /// The slots at the corners.
    pub(super) slots: [u32; 3],
}

pub(super) fn sphere_of(n: &Node) -> Sphere {
    Sphere {
        center: Vec3::from_slice(&n.sphere),
        radius: n.sphere[3],
    }
}

pub(super) fn cone_of_node(n: &Node) -> NormalCone {
    NormalCone {
        axis: Vec3::from_slice(&n.cone),
        cos_angle: n.cone[3],
    }
}

/// A merge whose node [`finish_node`] has still to complete.
#[derive(Clone, Copy)]
pub(super) struct Merged {
    /// The children's shares of the attribute blend.
    pub(super) blend: [f32; 2],
    /// Both slots' error samples, from before the merge.
    pub(super) pending: Pending,
    /// The surviving slot, and the slot merged into it.
    pub(super) slot: u32,
    pub(super) gone: u32,
    pub(super) position: Vec3,
    /// No triangle joined the two slots: a merge across a gap (a proximity pair or a loose edge),
    /// whose triangles now stretch over empty space.
    pub(super) across_gap: bool,
    /// With wedges, the survivor's principal wedge's attribute quadric and texture (see
    /// [`super::wedges`]).
    pub(super) principal: Option<(
        crate::simplify::attribute_quadric::LocalAttributeQuadric,
        u32,
    )>,
    /// With wedges, how far the merge slides a texture at the children's places, in length: the
    /// most, over the wedges joined, between a child wedge's coordinates and the ones the new
    /// wedge's map gives at the child's place (see `WedgeState::merge`); 0 without.
    pub(super) slide: f32,
}

/// The triangles around a live slot, read once: corners and their slots, for the cone, every
/// distance in [`finish_node`] and the survivor's partners. Appended to `out`.
pub(super) fn fan_of(collapser: &Collapser, slot: u32, out: &mut Vec<FanTriangle>) {
    let c = collapser;
    out.extend(c.faces_of(slot).map(|(_, f)| {
        let [a, b, d] = f.map(|v| c.positions[v as usize]);
        FanTriangle {
            corners: [a, b, d],
            slots: f,
        }
    }));
}

/// Colour, normal, bounding sphere, normal cone and error of a new node, from its (finished)
/// children and `fan`, the triangles around its slot right after the merge ([`fan_of`]).
/// `color_scale` is the length a full channel's colour difference counts as (0: shape only);
/// `color`, the node's colour when its attribute quadric has one (else its children's blend).
pub(super) fn finish_node(
    node: &mut Node,
    done: &[Node],
    merged: &Merged,
    fan: &[FanTriangle],
    leaves: &[Vec3],
    (color_scale, color): (f32, Option<Vec3>),
) -> Samples {
    let Merged {
        blend,
        ref pending,
        across_gap,
        ..
    } = *merged;
    let (ns, nt) = (
        &done[node.children[0] as usize],
        &done[node.children[1] as usize],
    );
    // Never below a child's: the runtime's error test relies on errors growing towards the root.
    node.error = node.error.max(ns.error).max(nt.error);
    let mix =
        |x: [f32; 3], y: [f32; 3]| Vec3::from_array(x) * blend[0] + Vec3::from_array(y) * blend[1];
    node.color = color.unwrap_or_else(|| mix(ns.color, nt.color)).to_array();
    node.normal = mix(ns.normal, nt.normal).normalize_or_zero().to_array();
    let sphere = sphere_of(ns)
        .union(sphere_of(nt))
        .union_point(node.position());
    node.sphere = [
        sphere.center.x,
        sphere.center.y,
        sphere.center.z,
        sphere.radius,
    ];
    let mut cone = cone_of_node(ns).union(cone_of_node(nt));
    for t in fan {
        let [a, b, d] = t.corners;
        cone = cone.union_normal((b - a).cross(d - a).normalize_or_zero());
    }
    node.cone = [cone.axis.x, cone.axis.y, cone.axis.z, cone.cos_angle];
    // How far the merged surface strays from the input: Hoppe 1997's residuals, measured from a few
    // input vertices per node, the farthest so far, to the triangles now around the merged vertex
    // (the children's samples compete for the places). The RMS plane distance alone underestimates
    // the Hausdorff distance 2–5× (BENCHMARKS.md).
    // Lanes: the pending samples, then the two children's vertices (the rest repeat the node's).
    let here = node.position();
    const _: () = assert!(2 * SAMPLES + 2 <= LANES);
    let points: [Vec3; LANES] = std::array::from_fn(|i| match i.checked_sub(pending.len()) {
        None if pending[i] != NONE => leaves[pending[i] as usize],
        Some(0) => ns.position(),
        Some(1) => nt.position(),
        _ => here,
    });
    let distance: [f32; LANES] = if fan.is_empty() {
        points.map(|p| p.distance(here))
    } else {
        let mut best = [f32::INFINITY; LANES];
        nearest_squared(
            &points.map(|p| p.x),
            &points.map(|p| p.y),
            &points.map(|p| p.z),
            fan.iter().map(|t| t.corners),
            &mut best,
        );
        best.map(f32::sqrt)
    };
    let mut scored = [(f32::NEG_INFINITY, NONE); 2 * SAMPLES];
    for (i, (score, &q)) in scored.iter_mut().zip(pending).enumerate() {
        if q != NONE {
            *score = (distance[i], q);
        }
    }
    scored.sort_unstable_by(|x, y| y.0.total_cmp(&x.0));
    node.error = node.error.max(scored[0].0);
    // Each child's own vertex, on top of the child's error: its surface was that close to the
    // input, and its vertex's distance to the new fan is where a merge usually strays most. Summed
    // along a chain this grows like a geometric series, a small factor over the true deviation.
    // Colour the same way: a child's error covers its leaves' colour deviation from the child's
    // colour (times the scale), so adding the child's colour change bounds the node's, leaf by leaf
    // (the triangle inequality, in the largest channel).
    for (k, child) in [ns, nt].into_iter().enumerate() {
        let recolored = (Vec3::from_array(child.color) - Vec3::from_array(node.color))
            .abs()
            .max_element();
        node.error = node
            .error
            .max(child.error + distance[pending.len() + k])
            .max(child.error + color_scale * recolored)
            .max(child.error + merged.slide);
    }
    // A merge across a gap draws its children's triangles stretched to the new vertex, over empty
    // space: the measured distances above run from the input to the new surface and miss that
    // surface's own distance from the input (the slivers of issue 37). Each of those triangles moved
    // one corner by at most the child's move, so its points stray at most that far from the child's
    // surface: the child's error plus its move bounds them.
    if across_gap {
        for child in [ns, nt] {
            node.error = node
                .error
                .max(child.error + child.position().distance(here));
        }
    }
    let mut kept = [NONE; SAMPLES];
    for (k, &(_, q)) in kept.iter_mut().zip(&scored) {
        // NONE-padded entries sort last and stay NONE.
        *k = q;
    }
    kept
}

/// Input vertices each live slot keeps for measuring its deviation: the ones farthest from the surface
/// so far. Four: six gave the same Hausdorff-to-error ratios on cow, fandisk, cessna and bunny and
/// cost the dragon's build 0.2 s more; none at all (the children's vertices only) let the ratio reach
/// 2.7–5.5 on cow and cessna.
pub(super) const SAMPLES: usize = 4;
pub(super) type Samples = [u32; SAMPLES];
/// The samples of both merging slots, waiting for [`finish_node`] to keep the worst.
pub(super) type Pending = [u32; 2 * SAMPLES];

//! From-scratch checks of a live front, for tests: everything [`Front`] maintains incrementally,
//! recomputed the slow, obvious way.

use super::adapt::Refiner;
use super::front::{ACTIVE, BELOW, Front, SPLIT};
use super::hierarchy::{Hierarchy, NIL};
use std::collections::{HashMap, HashSet};

/// The front is a cut (every leaf has exactly one active ancestor-or-self, split nodes above it, none
/// below), and the drawn triangles are exactly the distinct non-degenerate images of the input
/// triangles under `g`, each once, in its input winding.
pub fn check_front(h: &Hierarchy, front: &Front) -> Result<(), String> {
    let count = h.node_count();
    // States, parents first.
    for u in h.top_down() {
        let s = front.state(u);
        let p = h.parent[u as usize];
        let allowed: &[u8] = if p == NIL || front.state(p) == SPLIT {
            &[ACTIVE, SPLIT]
        } else {
            &[BELOW]
        };
        if !allowed.contains(&s) {
            return Err(format!(
                "node {u} is in state {s} under parent {p} in state {}",
                if p == NIL { 255 } else { front.state(p) }
            ));
        }
        if s == SPLIT && h.is_leaf(u) {
            return Err(format!("leaf {u} is split"));
        }
    }
    let stated = (0..count).filter(|&u| front.state(u) == ACTIVE).count();
    if stated != front.active_count() {
        return Err(format!(
            "{} nodes counted on the front, {stated} active",
            front.active_count()
        ));
    }
    // g: the active node standing for every node, parents first.
    let mut rep = vec![NIL; count as usize];
    for u in h.top_down() {
        rep[u as usize] = match front.state(u) {
            ACTIVE => u,
            BELOW => rep[h.parent[u as usize] as usize],
            _ => NIL,
        };
    }
    for leaf in 0..h.leaf_count {
        let g = rep[leaf as usize];
        if g == NIL || front.representative(h, leaf) != g {
            return Err(format!(
                "leaf {leaf} has no active ancestor, or two disagree"
            ));
        }
    }
    // Expected: key → the windings the input gives it.
    let mut expected: HashMap<[u32; 3], Vec<[u32; 3]>> = HashMap::new();
    for t in &h.triangles {
        let c = t.map(|v| rep[v as usize]);
        if c[0] == c[1] || c[1] == c[2] || c[0] == c[2] {
            continue;
        }
        expected.entry(sorted(c)).or_default().push(c);
    }
    let mut drawn = HashSet::new();
    for (slot, &c) in front.indices().iter().enumerate() {
        if c[0] == c[1] || c[1] == c[2] || c[0] == c[2] {
            return Err(format!("drawn triangle {slot} {c:?} is degenerate"));
        }
        let key = sorted(c);
        if !drawn.insert(key) {
            return Err(format!("drawn triangle {slot} {c:?} is drawn twice"));
        }
        match expected.get(&key) {
            None => {
                return Err(format!(
                    "drawn triangle {slot} {c:?} is not implied by the cut"
                ));
            }
            Some(windings) if !windings.iter().any(|&w| same_winding(w, c)) => {
                return Err(format!(
                    "drawn triangle {slot} {c:?} has no input triangle's winding"
                ));
            }
            _ => {}
        }
    }
    if drawn.len() != expected.len() {
        return Err(format!(
            "{} triangles drawn, the cut implies {}",
            drawn.len(),
            expected.len()
        ));
    }
    check_wedges(h, front)
}

/// With wedges, each drawn corner shows the wedge of its node that its input triangle's leaf
/// wedge has become, found the slow way (walking up the wedges' parents).
fn check_wedges(h: &Hierarchy, front: &Front) -> Result<(), String> {
    let Some(w) = &h.wedges else {
        return Ok(());
    };
    let by_input: HashMap<[u32; 3], usize> = h
        .triangles
        .iter()
        .enumerate()
        .map(|(i, &t)| (t, i))
        .collect();
    let drawn = front.all_vertices(h);
    let inputs = front.drawn_input_triangles();
    for (slot, ((&c, &v), input)) in front.indices().iter().zip(&drawn).zip(inputs).enumerate() {
        let Some(&t) = by_input.get(&input) else {
            return Err(format!(
                "drawn triangle {slot}'s input {input:?} is no triangle"
            ));
        };
        for k in 0..3 {
            let mut x = w.corners[t][k];
            while x != NIL && w.node[x as usize] != c[k] {
                x = w.parent[x as usize];
            }
            if x != v[k] {
                return Err(format!(
                    "drawn triangle {slot}'s corner {k} at node {} shows wedge {}, not {x}",
                    c[k], v[k]
                ));
            }
        }
    }
    Ok(())
}

/// [`check_front`] of a runtime's front, and its visiting stream checked against that front
/// ([`Refiner::check_stream`]).
pub fn check_refiner(h: &Hierarchy, refiner: &Refiner) -> Result<(), String> {
    check_front(h, &refiner.front)?;
    refiner.check_stream(h)
}

fn sorted(mut c: [u32; 3]) -> [u32; 3] {
    c.sort_unstable();
    c
}

fn same_winding(a: [u32; 3], b: [u32; 3]) -> bool {
    (0..3).any(|r| [a[r], a[(r + 1) % 3], a[(r + 2) % 3]] == b)
}

/// Drawn triangles whose normal points against the normal of the input triangle behind them (a
/// foldover), and the number drawn.
pub fn foldovers(h: &Hierarchy, front: &Front) -> (usize, usize) {
    let normal = |c: [u32; 3]| {
        let [a, b, d] = c.map(|v| h.position[v as usize]);
        (b - a).cross(d - a)
    };
    let folded = front
        .indices()
        .iter()
        .zip(front.drawn_input_triangles())
        .filter(|&(&c, input)| normal(c).dot(normal(input)) < 0.0)
        .count();
    (folded, front.indices().len())
}

/// How far, in pixels, a front draws the input surface from where it belongs in one camera's image
/// (see [`screen_deviation`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ScreenDeviation {
    /// The largest distance in pixels between a point of an input triangle and its image on the
    /// front, over every sample of which either end is in the view.
    pub worst_px: f32,
    /// The input triangle (index into [`Hierarchy::triangles`]) where it was.
    pub worst_triangle: usize,
    /// Samples with an end in the view.
    pub checked: usize,
}

/// Barycentric samples of a triangle: the corners, edge points and interior points of a grid with
/// four steps a side (15 points).
fn barycentric_samples() -> impl Iterator<Item = [f32; 3]> {
    const STEPS: u32 = 4;
    (0..=STEPS).flat_map(|i| {
        (0..=STEPS - i).map(move |j| {
            let (a, b) = (i as f32 / STEPS as f32, j as f32 / STEPS as f32);
            [a, b, 1.0 - a - b]
        })
    })
}

/// Where a front draws the input surface in `camera`'s image, checked geometrically (no GPU): each
/// input triangle `(x, y, z)` is drawn as `(g(x), g(y), g(z))`, its corners' active nodes, and a
/// point `q = αx + βy + γz` of it as `p = αg(x) + βg(y) + γg(z)`. For samples of every input
/// triangle, wherever `p` or `q` is in the view, this measures the distance between their pixels
/// (infinite when one end is behind the eye). It bounds both ways the promise asks about:
/// every drawn point lies that close to the input surface, and every point of the input surface
/// that close to its image on the front (which is on a drawn triangle, or on the edge or corner a
/// collapsed triangle shrank to). Occlusion is not weighed: hidden points count as well.
pub fn screen_deviation(h: &Hierarchy, front: &Front, camera: &super::Camera) -> ScreenDeviation {
    let count = h.node_count();
    let mut rep = vec![NIL; count as usize];
    for u in h.top_down() {
        rep[u as usize] = match front.state(u) {
            ACTIVE => u,
            BELOW => rep[h.parent[u as usize] as usize],
            _ => NIL,
        };
    }
    let m = camera.clip_from_world();
    let [w, hgt] = camera.viewport_px.map(|v| v as f32);
    // Clip coordinates, and whether the point is in the view volume.
    let clip = |p: glam::Vec3| {
        let c = m * p.extend(1.0);
        let inside =
            c.w > 0.0 && c.x.abs() <= c.w && c.y.abs() <= c.w && (0.0..=c.w).contains(&c.z);
        (c, inside)
    };
    let pixel =
        |c: glam::Vec4| glam::Vec2::new((c.x / c.w + 1.0) * 0.5 * w, (1.0 - c.y / c.w) * 0.5 * hgt);
    let samples: Vec<[f32; 3]> = barycentric_samples().collect();
    let mut out = ScreenDeviation::default();
    for (i, t) in h.triangles.iter().enumerate() {
        let input = t.map(|v| h.position[v as usize]);
        let drawn = t.map(|v| h.position[rep[v as usize] as usize]);
        for b in &samples {
            let at = |c: [glam::Vec3; 3]| c[0] * b[0] + c[1] * b[1] + c[2] * b[2];
            let ((cq, q_in), (cp, p_in)) = (clip(at(input)), clip(at(drawn)));
            if !(q_in || p_in) {
                continue;
            }
            out.checked += 1;
            let px = if cq.w > 0.0 && cp.w > 0.0 {
                pixel(cq).distance(pixel(cp))
            } else {
                f32::INFINITY
            };
            if px > out.worst_px {
                out.worst_px = px;
                out.worst_triangle = i;
            }
        }
    }
    out
}

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

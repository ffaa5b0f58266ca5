//! A bounding-volume hierarchy over triangles for nearest-point queries (the inner loop of Hausdorff
//! measurement). Median split on the longest axis; leaves of up to `LEAF_SIZE` triangles.

use glam::{DVec3, Vec3};

/// Small leaves make tight boxes; below ~4 the tree walk costs more than the triangle tests it saves.
const LEAF_SIZE: usize = 4;

#[derive(Clone, Copy, Debug)]
struct BvhNode {
    lo: Vec3,
    hi: Vec3,
    /// Leaf: first triangle in `order`; inner: index of the left child (the right child follows it).
    start: u32,
    /// Leaf: triangle count; inner: 0.
    count: u32,
}

pub struct Bvh {
    nodes: Vec<BvhNode>,
    tris: Vec<[Vec3; 3]>,
    /// The input index of each triangle in the hierarchy's order.
    order: Vec<u32>,
}

pub use crate::simplify::geometry::closest_point_on_triangle;

fn box_distance_squared(p: Vec3, lo: Vec3, hi: Vec3) -> f32 {
    let d = (lo - p).max(p - hi).max(Vec3::ZERO);
    d.length_squared()
}

impl Bvh {
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> Bvh {
        let tris: Vec<[Vec3; 3]> = triangles
            .iter()
            .map(|t| t.map(|v| positions[v as usize]))
            .collect();
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        let centroids: Vec<Vec3> = tris.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
        let mut nodes = Vec::with_capacity(2 * tris.len() / LEAF_SIZE + 1);
        nodes.push(BvhNode {
            lo: Vec3::ZERO,
            hi: Vec3::ZERO,
            start: 0,
            count: 0,
        });
        let mut stack = vec![(0usize, 0usize, order.len())];
        while let Some((node, start, end)) = stack.pop() {
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for &t in &order[start..end] {
                for p in tris[t as usize] {
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
            }
            if end - start <= LEAF_SIZE {
                nodes[node] = BvhNode {
                    lo,
                    hi,
                    start: start as u32,
                    count: (end - start) as u32,
                };
                continue;
            }
            let (mut clo, mut chi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for &t in &order[start..end] {
                clo = clo.min(centroids[t as usize]);
                chi = chi.max(centroids[t as usize]);
            }
            let ext = chi - clo;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = start + (end - start) / 2;
            order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
                centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
            });
            let left = nodes.len();
            nodes.push(BvhNode {
                lo: Vec3::ZERO,
                hi: Vec3::ZERO,
                start: 0,
                count: 0,
            });
            nodes.push(BvhNode {
                lo: Vec3::ZERO,
                hi: Vec3::ZERO,
                start: 0,
                count: 0,
            });
            nodes[node] = BvhNode {
                lo,
                hi,
                start: left as u32,
                count: 0,
            };
            stack.push((left, start, mid));
            stack.push((left + 1, mid, end));
        }
        let tris = order.iter().map(|&t| tris[t as usize]).collect();
        Bvh { nodes, tris, order }
    }

    /// Distance from `p` to the nearest triangle (infinite for an empty BVH).
    pub fn distance(&self, p: Vec3) -> f32 {
        if self.tris.is_empty() {
            return f32::INFINITY;
        }
        let mut best = f32::INFINITY;
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = self.nodes[i as usize];
            if box_distance_squared(p, node.lo, node.hi) >= best {
                continue;
            }
            if node.count > 0 {
                for t in &self.tris[node.start as usize..(node.start + node.count) as usize] {
                    let q = closest_point_on_triangle(p, t[0], t[1], t[2]);
                    best = best.min(q.distance_squared(p));
                }
                continue;
            }
            let (l, r) = (node.start, node.start + 1);
            let dl = box_distance_squared(p, self.nodes[l as usize].lo, self.nodes[l as usize].hi);
            let dr = box_distance_squared(p, self.nodes[r as usize].lo, self.nodes[r as usize].hi);
            // Nearer child last, so it is popped first.
            if dl < dr {
                stack.push(r);
                stack.push(l);
            } else {
                stack.push(l);
                stack.push(r);
            }
        }
        best.sqrt()
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Triangle `i` in the hierarchy's own order (as [`Bvh::nearest64`] names them).
    pub fn triangle64(&self, i: usize) -> [DVec3; 3] {
        self.tris[i].map(|v| v.as_dvec3())
    }

    /// The input index (in the `triangles` given to [`Bvh::new`]) of triangle `i` in the hierarchy's
    /// order.
    pub fn input_index(&self, i: usize) -> usize {
        self.order[i] as usize
    }

    /// Calls `visit(i)` for each triangle `i` (in the hierarchy's order) whose box overlaps the
    /// closed box `lo..hi`, until a call returns `true`; returns whether one did. Boxes are compared
    /// in `f64`, where the hierarchy's `f32` boxes are exact, so no overlapping triangle is missed.
    pub fn any_overlapping(
        &self,
        lo: DVec3,
        hi: DVec3,
        mut visit: impl FnMut(usize) -> bool,
    ) -> bool {
        if self.tris.is_empty() {
            return false;
        }
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if node.lo.as_dvec3().cmpgt(hi).any() || lo.cmpgt(node.hi.as_dvec3()).any() {
                continue;
            }
            if node.count > 0 {
                for t in node.start as usize..(node.start + node.count) as usize {
                    if visit(t) {
                        return true;
                    }
                }
            } else {
                stack.push(node.start);
                stack.push(node.start + 1);
            }
        }
        false
    }

    /// The nearest triangle to `p` and its distance, in `f64` throughout (boxes and triangles are
    /// exact in `f64`, so the answer is the true nearest up to `f64` rounding): what certified
    /// bounds rest on. `None` for an empty hierarchy.
    pub fn nearest64(&self, p: DVec3) -> Option<(f64, usize)> {
        if self.tris.is_empty() {
            return None;
        }
        let box_d2 = |n: &BvhNode| {
            let d = (n.lo.as_dvec3() - p)
                .max(p - n.hi.as_dvec3())
                .max(DVec3::ZERO);
            d.length_squared()
        };
        let mut best = (f64::INFINITY, 0usize);
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if box_d2(node) > best.0 {
                continue;
            }
            if node.count > 0 {
                for t in node.start as usize..(node.start + node.count) as usize {
                    let [a, b, c] = self.triangle64(t);
                    let d2 = closest_point_on_triangle64(p, a, b, c).distance_squared(p);
                    if d2 < best.0 {
                        best = (d2, t);
                    }
                }
                continue;
            }
            let (l, r) = (node.start, node.start + 1);
            let (dl, dr) = (
                box_d2(&self.nodes[l as usize]),
                box_d2(&self.nodes[r as usize]),
            );
            if dl < dr {
                stack.push(r);
                stack.push(l);
            } else {
                stack.push(l);
                stack.push(r);
            }
        }
        Some((best.0.sqrt(), best.1))
    }
}

/// The point of triangle `abc` nearest to `p`, in `f64` (Ericson, *Real-Time Collision Detection*,
/// 5.1.5: the Voronoi region of `p`, then its projection).
pub fn closest_point_on_triangle64(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    if ab.cross(ac).length_squared() == 0.0 {
        return closest_point_on_edges(p, a, b, c);
    }
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    let (v, w) = (vb / denom, vc / denom);
    a + ab * v + ac * w
}

/// The nearest point to `p` on the edges of a degenerate (zero-area) triangle.
fn closest_point_on_edges(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    [(a, b), (b, c), (c, a)]
        .into_iter()
        .map(|(x, y)| {
            let e = y - x;
            let t = if e.length_squared() > 0.0 {
                ((p - x).dot(e) / e.length_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            x + e * t
        })
        .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
        .unwrap_or(a)
}

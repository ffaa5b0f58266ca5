//! The working mesh of the envelope methods and its one operation, the paper's **triangle
//! collapse**: the three corners of a triangle merge into one vertex at its centroid; the triangle
//! and its three edge neighbours degenerate and go (four triangles, two vertices fewer); the other
//! triangles around the corners deform, following the merged vertex (Zou, Shen and Peng, Fig. 3:
//! nine triangles become five).
//!
//! ```text
//!        x───────y                 x───────y
//!       ╱ ╲     ╱ ╲               ╱ ╲     ╱ ╲
//!      ╱   ╲   ╱   ╲             ╱   ╲   ╱   ╲
//!     w─────a─b─────z    ──►    w─────  v  ────z      a, b, c ─► v (the centroid of abc)
//!      ╲   ╱ ╲ ╲   ╱             ╲   ╱   ╲   ╱
//!       ╲ ╱   c ╲ ╱               ╲ ╱     ╲ ╱
//!        u───────t                 u───────t
//! ```
//!
//! Vertices on a boundary edge (one triangle) or a non-manifold edge (three or more) are **frozen**:
//! no triangle touching one is collapsed. An envelope is open at such an edge — its offset surface
//! ends there and nothing stops a moved triangle from leaving through the rim — so the methods keep
//! boundaries and non-manifold seams exactly instead of guarding them.

use crate::mesh::Mesh;
use crate::simplify::quadric::Quadric;
use glam::DVec3;
use std::collections::HashMap;

pub(super) struct Work {
    pub positions: Vec<DVec3>,
    pub faces: Vec<[u32; 3]>,
    pub alive: Vec<bool>,
    /// Faces around each vertex (may list dead faces, skipped).
    around: Vec<Vec<u32>>,
    quadric: Vec<Quadric>,
    /// A vertex's version changes when it moves or merges: a queued triangle is stale after that.
    pub version: Vec<u32>,
    pub frozen: Vec<bool>,
    pub live_faces: usize,
}

/// A triangle collapse worked out but not applied.
pub(super) struct Plan {
    /// The triangle's corners; the first survives as the merged vertex.
    pub corners: [u32; 3],
    /// Where the merged vertex goes (the centroid, rounded to `f32` as the output stores it).
    pub at: DVec3,
    /// All live faces around the three corners (the paper's `TT_i` with `T_i` itself).
    pub ring: Vec<u32>,
    /// The faces that degenerate: the triangle and its three edge neighbours.
    pub dying: Vec<u32>,
    /// The faces that deform, and their corners after the collapse.
    pub kept: Vec<u32>,
    pub deformed: Vec<[DVec3; 3]>,
}

/// Why a triangle cannot be collapsed, whatever the envelope says.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Refusal {
    /// A corner is on a boundary or non-manifold edge.
    Frozen,
    /// The result would not be a manifold around the merged vertex.
    Topology,
    /// A deformed triangle would turn over or collapse to a line.
    Fold,
}

impl Work {
    pub fn new(mesh: &Mesh) -> Work {
        let n = mesh.positions.len();
        let mut around = vec![Vec::new(); n];
        let mut quadric = vec![Quadric::default(); n];
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for (f, t) in mesh.triangles.iter().enumerate() {
            let [p0, p1, p2] = t.map(|v| mesh.positions[v as usize]);
            let q = Quadric::from_triangle(p0, p1, p2);
            for k in 0..3 {
                let v = t[k];
                around[v as usize].push(f as u32);
                quadric[v as usize] += q;
                let w = t[(k + 1) % 3];
                *edges.entry((v.min(w), v.max(w))).or_default() += 1;
            }
        }
        let mut frozen = vec![false; n];
        for (&(a, b), &count) in &edges {
            if count != 2 {
                frozen[a as usize] = true;
                frozen[b as usize] = true;
            }
        }
        Work {
            positions: mesh.positions.iter().map(|p| p.as_dvec3()).collect(),
            faces: mesh.triangles.clone(),
            alive: vec![true; mesh.triangles.len()],
            around,
            quadric,
            version: vec![0; n],
            frozen,
            live_faces: mesh.triangles.len(),
        }
    }

    pub fn live_around(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        self.around[v as usize]
            .iter()
            .copied()
            .filter(|&f| self.alive[f as usize])
    }

    pub fn triangle(&self, f: u32) -> [DVec3; 3] {
        self.faces[f as usize].map(|v| self.positions[v as usize])
    }

    /// The paper's vertex normal: the area-weighted average of the face normals around `v` (zero
    /// where they cancel).
    pub fn normal(&self, v: u32) -> DVec3 {
        self.live_around(v)
            .map(|f| {
                let [a, b, c] = self.triangle(f);
                (b - a).cross(c - a)
            })
            .sum::<DVec3>()
            .normalize_or_zero()
    }

    /// Cost of collapsing face `f`: the quadric error of its corners at its centroid. Triangles are
    /// tried cheapest first — the paper gives no order, and the quadric one (Garland and Heckbert)
    /// tries flat, small triangles first, the ones most likely to pass the envelope, so fewer tests
    /// are wasted and the early collapses do not spend the envelope where the surface bends.
    pub fn cost(&self, f: u32) -> f64 {
        let t = self.faces[f as usize];
        let q =
            self.quadric[t[0] as usize] + self.quadric[t[1] as usize] + self.quadric[t[2] as usize];
        q.eval(self.centroid(f))
    }

    fn centroid(&self, f: u32) -> DVec3 {
        let [a, b, c] = self.triangle(f);
        ((a + b + c) / 3.0).as_vec3().as_dvec3()
    }

    pub fn versions(&self, f: u32) -> [u32; 3] {
        self.faces[f as usize].map(|v| self.version[v as usize])
    }

    /// Works out the collapse of face `f`, or says why it cannot be made.
    pub fn plan(&self, f: u32) -> Result<Plan, Refusal> {
        let corners = self.faces[f as usize];
        if corners.iter().any(|&v| self.frozen[v as usize]) {
            return Err(Refusal::Frozen);
        }
        let mut ring: Vec<u32> = corners.iter().flat_map(|&v| self.live_around(v)).collect();
        ring.sort_unstable();
        ring.dedup();
        let shared = |g: u32| {
            self.faces[g as usize]
                .iter()
                .filter(|v| corners.contains(v))
                .count()
        };
        let (dying, kept): (Vec<u32>, Vec<u32>) = ring.iter().partition(|&&g| shared(g) >= 2);
        if dying.len() != 4 || kept.len() < 3 || !self.fan_is_a_disc(&corners, &kept) {
            return Err(Refusal::Topology);
        }
        let at = self.centroid(f);
        let deformed: Vec<[DVec3; 3]> = kept
            .iter()
            .map(|&g| {
                self.faces[g as usize].map(|v| {
                    if corners.contains(&v) {
                        at
                    } else {
                        self.positions[v as usize]
                    }
                })
            })
            .collect();
        for (&g, d) in kept.iter().zip(&deformed) {
            let [p0, p1, p2] = self.triangle(g);
            let before = (p1 - p0).cross(p2 - p0);
            let after = (d[1] - d[0]).cross(d[2] - d[0]);
            if after.length_squared() == 0.0 || before.dot(after) <= 0.0 {
                return Err(Refusal::Fold);
            }
        }
        Ok(Plan {
            corners,
            at,
            ring,
            dying,
            kept,
            deformed,
        })
    }

    /// Whether the faces kept around the merged vertex form one closed fan: their outer edges (the
    /// ones without a corner) make a single cycle through distinct vertices. Otherwise the merged
    /// vertex would pinch two sheets together or two faces would coincide.
    fn fan_is_a_disc(&self, corners: &[u32; 3], kept: &[u32]) -> bool {
        let mut links: Vec<[u32; 2]> = Vec::with_capacity(kept.len());
        for &g in kept {
            let t = self.faces[g as usize];
            let k = t.iter().position(|v| corners.contains(v)).unwrap_or(0);
            let (x, y) = (t[(k + 1) % 3], t[(k + 2) % 3]);
            if corners.contains(&x) || corners.contains(&y) {
                return false;
            }
            links.push([x, y]);
        }
        // Each link vertex starts exactly one link edge and ends exactly one; then walk the cycle.
        let mut next: HashMap<u32, u32> = HashMap::with_capacity(links.len());
        for &[x, y] in &links {
            if next.insert(x, y).is_some() {
                return false;
            }
        }
        let start = links[0][0];
        let (mut v, mut steps) = (start, 0);
        loop {
            let Some(&w) = next.get(&v) else { return false };
            steps += 1;
            v = w;
            if v == start {
                return steps == links.len();
            }
            if steps > links.len() {
                return false;
            }
        }
    }

    /// Applies a planned collapse; returns the merged vertex.
    pub fn apply(&mut self, plan: Plan) -> u32 {
        let [a, b, c] = plan.corners;
        for &g in &plan.dying {
            self.alive[g as usize] = false;
            self.live_faces -= 1;
        }
        for &g in &plan.kept {
            for v in &mut self.faces[g as usize] {
                if *v == b || *v == c {
                    *v = a;
                }
            }
        }
        self.around[a as usize] = plan.kept;
        self.around[b as usize] = Vec::new();
        self.around[c as usize] = Vec::new();
        self.positions[a as usize] = plan.at;
        let q = self.quadric[b as usize] + self.quadric[c as usize];
        self.quadric[a as usize] += q;
        for v in plan.corners {
            self.version[v as usize] += 1;
        }
        a
    }

    pub fn into_mesh(self, input: &Mesh) -> Mesh {
        crate::simplify::live_mesh(&self.positions, &self.faces, &self.alive, input)
    }
}

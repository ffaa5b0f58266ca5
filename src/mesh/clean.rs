//! Welding and clean-up: what every loader's raw output goes through before building.

use super::{Mesh, Part};
use std::collections::HashMap;
use std::collections::hash_map::Entry;

/// How [`clean`] treats its input.
#[derive(Clone, Debug)]
pub struct CleanOptions {
    /// Merge vertices with bit-identical positions (after `-0.0` → `0.0`). Default: on. OBJ exporters split
    /// vertices at UV and normal seams; without welding, the builder would see cracks that are not there.
    pub weld: bool,
}

impl Default for CleanOptions {
    fn default() -> Self {
        CleanOptions { weld: true }
    }
}

/// What [`clean`] changed, for the build summary.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct CleanReport {
    /// Vertices merged into an earlier vertex at the same position.
    pub welded_vertices: usize,
    /// Vertices that no face uses.
    pub unused_vertices: usize,
    /// Faces with a repeated corner (after welding).
    pub degenerate_faces: usize,
    /// Faces over the same three vertices as an earlier face (either orientation).
    pub duplicate_faces: usize,
}

/// Welds, drops degenerate and duplicate faces, then drops unused vertices. Parts keep their order; a
/// part left with no faces is removed. Attributes of welded vertices come from the first one.
pub fn clean(mesh: Mesh, options: &CleanOptions) -> (Mesh, CleanReport) {
    let mut report = CleanReport {
        unused_vertices: mesh.unreferenced_vertices,
        ..CleanReport::default()
    };
    let n = mesh.positions.len();

    // 1. Weld: remap[v] = the first vertex with v's position (and colour: vertices at one place
    // with different colours are a colour seam, such as the corner between two walls of a lit
    // scene, and keep their own colours).
    let mut remap: Vec<u32> = (0..n as u32).collect();
    if options.weld {
        let mut first: HashMap<[u32; 6], u32> = HashMap::with_capacity(n);
        for (i, p) in mesh.positions.iter().enumerate() {
            let bits = |v: glam::Vec3| (v + glam::Vec3::ZERO).to_array().map(f32::to_bits); // + 0.0 turns -0.0 into 0.0
            let [x, y, z] = bits(*p);
            let [r, g, b] = mesh.colors.as_ref().map_or([0; 3], |c| bits(c[i]));
            let key = [x, y, z, r, g, b];
            match first.entry(key) {
                Entry::Occupied(e) => {
                    remap[i] = *e.get();
                    report.welded_vertices += 1;
                }
                Entry::Vacant(e) => {
                    e.insert(i as u32);
                }
            }
        }
    }

    // 2. Faces: drop degenerate and duplicate ones, part by part.
    let mut seen: std::collections::HashSet<[u32; 3]> =
        std::collections::HashSet::with_capacity(mesh.triangles.len());
    let mut triangles = Vec::with_capacity(mesh.triangles.len());
    let mut parts = Vec::with_capacity(mesh.parts.len());
    for part in &mesh.parts {
        let start = triangles.len() as u32;
        for t in &mesh.triangles[part.triangles.start as usize..part.triangles.end as usize] {
            let t = t.map(|v| remap[v as usize]);
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                report.degenerate_faces += 1;
                continue;
            }
            let mut key = t;
            key.sort_unstable();
            if !seen.insert(key) {
                report.duplicate_faces += 1;
                continue;
            }
            triangles.push(t);
        }
        let end = triangles.len() as u32;
        if end > start {
            parts.push(Part {
                name: part.name.clone(),
                triangles: start..end,
            });
        }
    }

    // 3. Compact: keep used vertices in their original order.
    let mut new_index = vec![u32::MAX; n];
    for t in &triangles {
        for &v in t {
            new_index[v as usize] = 0;
        }
    }
    let mut kept = Vec::new();
    for (v, slot) in new_index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = kept.len() as u32;
            kept.push(v);
        } else if remap[v] == v as u32 {
            report.unused_vertices += 1;
        }
    }
    for t in &mut triangles {
        *t = t.map(|v| new_index[v as usize]);
    }
    let pick = |a: &Vec<glam::Vec3>| kept.iter().map(|&v| a[v]).collect::<Vec<_>>();
    let out = Mesh {
        positions: pick(&mesh.positions),
        colors: mesh.colors.as_ref().map(pick),
        normals: mesh.normals.as_ref().map(pick),
        triangles,
        parts,
        unreferenced_vertices: 0,
        one_sided: mesh.one_sided,
    };
    debug_assert!(out.check().is_ok());
    (out, report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// ```text
    ///  2 ---- 1/4        two triangles sharing the edge 1-2, written with a seam: vertex 4 repeats
    ///  |    / |          vertex 1's position, vertex 5 is unused, face 2 is degenerate and face 3
    ///  |  /   |          repeats face 0 in the other orientation.
    ///  0      3
    /// ```
    #[test]
    fn welds_and_drops() {
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(9.0, 9.0, 9.0),
        ];
        let mesh = Mesh::from_triangles(p, vec![[0, 1, 2], [0, 3, 4], [0, 0, 3], [2, 4, 0]]);
        let (out, report) = clean(mesh, &CleanOptions::default());
        assert_eq!(
            report,
            CleanReport {
                welded_vertices: 1,
                unused_vertices: 1,
                degenerate_faces: 1,
                duplicate_faces: 1
            }
        );
        assert_eq!(out.positions.len(), 4);
        assert_eq!(out.triangles, vec![[0, 1, 2], [0, 3, 1]]);
    }
}

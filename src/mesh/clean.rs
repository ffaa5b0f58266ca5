//! Welding and clean-up: what every loader's raw output goes through before building.

use super::{Mesh, Part};
use rustc_hash::FxHashMap;
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
        let mut first: FxHashMap<[u32; 6], u32> =
            FxHashMap::with_capacity_and_hasher(n, Default::default());
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
    let remapped: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| remap[v as usize]))
        .collect();
    let degenerate: Vec<bool> = remapped
        .iter()
        .map(|t| t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
        .collect();
    let duplicate = duplicates(&remapped, &degenerate, n);
    let mut triangles = Vec::with_capacity(mesh.triangles.len());
    let mut parts = Vec::with_capacity(mesh.parts.len());
    for part in &mesh.parts {
        let start = triangles.len() as u32;
        for f in part.triangles.start as usize..part.triangles.end as usize {
            if degenerate[f] {
                report.degenerate_faces += 1;
            } else if duplicate[f] {
                report.duplicate_faces += 1;
            } else {
                triangles.push(remapped[f]);
            }
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

/// Which faces repeat the three vertices of an earlier face (either orientation), among those not
/// `skip`ped. Faces are bucketed by their smallest vertex (a counting sort, in face order) and each
/// bucket sorted by the other two: linear but for the buckets' small sorts, where a hash set of
/// every face took most of the clean-up's time.
fn duplicates(faces: &[[u32; 3]], skip: &[bool], vertices: usize) -> Vec<bool> {
    let key = |t: [u32; 3]| {
        let mut k = t;
        k.sort_unstable();
        k
    };
    let mut start = vec![0u32; vertices + 1];
    for (t, _) in faces.iter().zip(skip).filter(|(_, s)| !**s) {
        start[key(*t)[0] as usize + 1] += 1;
    }
    for v in 0..vertices {
        start[v + 1] += start[v];
    }
    let mut order = vec![0u32; start[vertices] as usize];
    let mut fill = start.clone();
    for (f, t) in faces.iter().enumerate().filter(|(f, _)| !skip[*f]) {
        let k = key(*t)[0] as usize;
        order[fill[k] as usize] = f as u32;
        fill[k] += 1;
    }
    let mut duplicate = vec![false; faces.len()];
    for v in 0..vertices {
        let bucket = &mut order[start[v] as usize..start[v + 1] as usize];
        if bucket.len() < 2 {
            continue;
        }
        // By the other two vertices, then face order: the first of equal faces comes first.
        bucket.sort_unstable_by_key(|&f| {
            let k = key(faces[f as usize]);
            (k[1], k[2], f)
        });
        for w in bucket.windows(2) {
            if key(faces[w[0] as usize]) == key(faces[w[1] as usize]) {
                duplicate[w[1] as usize] = true;
            }
        }
    }
    duplicate
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
    /// Faces over the same three vertices, in any order, are duplicates of the first of them; a
    /// skipped face is neither.
    #[test]
    fn duplicates_are_found_in_any_order() {
        let faces = [
            [0, 1, 2],
            [2, 1, 0],
            [1, 2, 0],
            [0, 2, 3],
            [3, 0, 2],
            [0, 1, 3],
            [4, 4, 4],
        ];
        let skip = [false, false, false, false, false, false, true];
        assert_eq!(
            duplicates(&faces, &skip, 5),
            [false, true, true, false, true, false, false]
        );
    }

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

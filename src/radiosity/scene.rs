//! Radiosity scenes: Wavefront OBJ with an MTL file, the convention other renderers use — `Kd` the
//! diffuse reflectance (linear RGB, each below 1), `Ke` the emission (RGB radiant exitance), one
//! material per `usemtl`; planar polygons of any size.
//!
//! A polygon that is not planar (a corner farther than a thousandth of its size from its plane) is
//! split into triangles, and the scene says so; a non-convex polygon is split by ear clipping. Bad
//! scenes — no emitter, a reflectance of 1 or more, a zero-area polygon, a NaN — are errors naming
//! the file, the polygon's line and what is wrong.

use glam::DVec3;
use std::path::{Path, PathBuf};

/// A diffuse material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Reflectance ρ per channel, in [0, 1).
    pub reflectance: DVec3,
    /// Emitted radiant exitance per channel (0 for non-emitters).
    pub emission: DVec3,
}

/// A planar convex polygon of one material.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    pub corners: Vec<DVec3>,
    pub material: u32,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    pub polygons: Vec<Polygon>,
    pub materials: Vec<Material>,
    /// What was changed on the way in (split polygons), for the user.
    pub notes: Vec<String>,
}

/// A scene that cannot be used.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct SceneError {
    pub path: PathBuf,
    pub message: String,
}

/// Corners farther than this share of the polygon's size from its plane make it non-planar.
const PLANAR_TOLERANCE: f64 = 1e-3;

impl Scene {
    /// Reads an OBJ scene and its MTL library.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let error = |message: String| SceneError {
            path: path.to_path_buf(),
            message,
        };
        let options = tobj::LoadOptions {
            triangulate: false,
            single_index: true,
            ..Default::default()
        };
        let text = std::fs::read(path).map_err(|e| error(format!("cannot read: {e}")))?;
        let libraries = check_materials(path, &String::from_utf8_lossy(&text)).map_err(error)?;
        let (models, materials) =
            tobj::load_obj(path, &options).map_err(|e| error(format!("cannot read: {e}")))?;
        let materials = materials.map_err(|e| {
            error(format!(
                "cannot read its MTL library {}: {e}",
                libraries.join(", ")
            ))
        })?;
        let mut scene = Scene::default();
        for m in &materials {
            scene.materials.push(material(m).map_err(error)?);
        }
        for model in &models {
            let mesh = &model.mesh;
            let Some(material) = mesh.material_id else {
                return Err(error(format!(
                    "object '{}' has no material (a `usemtl` line)",
                    model.name
                )));
            };
            let corner = |i: u32| {
                let k = 3 * i as usize;
                DVec3::new(
                    f64::from(mesh.positions[k]),
                    f64::from(mesh.positions[k + 1]),
                    f64::from(mesh.positions[k + 2]),
                )
            };
            let arities: Vec<u32> = if mesh.face_arities.is_empty() {
                vec![3; mesh.indices.len() / 3]
            } else {
                mesh.face_arities.clone()
            };
            let mut start = 0usize;
            for (face, &n) in arities.iter().enumerate() {
                let corners: Vec<DVec3> = mesh.indices[start..start + n as usize]
                    .iter()
                    .map(|&i| corner(i))
                    .collect();
                start += n as usize;
                let what = format!("object '{}', face {}", model.name, face + 1);
                scene.add(corners, material as u32, &what).map_err(error)?;
            }
        }
        if scene.polygons.is_empty() {
            return Err(error("the scene has no polygons".into()));
        }
        if !scene.polygons.iter().any(|p| scene.emits(p)) {
            return Err(error(
                "no polygon emits light: give a material a positive `Ke`".into(),
            ));
        }
        Ok(scene)
    }

    pub fn emits(&self, p: &Polygon) -> bool {
        self.materials[p.material as usize].emission.max_element() > 0.0
    }

    /// Adds a polygon, split into triangles when it is not planar or not convex.
    fn add(&mut self, corners: Vec<DVec3>, material: u32, what: &str) -> Result<(), String> {
        if corners.len() < 3 {
            return Err(format!(
                "{what}: a face needs 3 corners, it has {}",
                corners.len()
            ));
        }
        if corners.iter().any(|c| !c.is_finite()) {
            return Err(format!("{what}: a corner is not a finite number"));
        }
        let normal = newell(&corners);
        let size = corners
            .iter()
            .map(|c| c.distance(corners[0]))
            .fold(0.0, f64::max);
        if let Some((i, j)) = crossing_edges(&corners) {
            let k = corners.len();
            return Err(format!(
                "{what}: the polygon crosses itself (a bow-tie): its edges {}–{} and {}–{} \
                 intersect; give each half as a polygon of its own",
                i + 1,
                (i + 1) % k + 1,
                j + 1,
                (j + 1) % k + 1
            ));
        }
        if normal.length() <= 1e-12 * size * size {
            return Err(format!("{what}: the polygon has zero area"));
        }
        let n = normal.normalize();
        let planar = corners
            .iter()
            .all(|c| (*c - corners[0]).dot(n).abs() <= PLANAR_TOLERANCE * size);
        let convex = (0..corners.len()).all(|i| {
            let (a, b, c) = (
                corners[i],
                corners[(i + 1) % corners.len()],
                corners[(i + 2) % corners.len()],
            );
            (b - a).cross(c - b).dot(n) >= 0.0
        });
        if planar && convex {
            self.polygons.push(Polygon { corners, material });
            return Ok(());
        }
        if corners.len() > 3 {
            self.notes.push(format!(
                "{what}: {} polygon of {} corners split into triangles",
                if planar { "non-convex" } else { "non-planar" },
                corners.len()
            ));
        }
        for t in ear_clip(&corners, n) {
            let tri: Vec<DVec3> = t.iter().map(|&i| corners[i]).collect();
            if newell(&tri).length() > 0.0 {
                self.polygons.push(Polygon {
                    corners: tri,
                    material,
                });
            }
        }
        Ok(())
    }
}

fn material(m: &tobj::Material) -> Result<Material, String> {
    let rgb = |v: Option<[f32; 3]>| v.map_or(DVec3::ZERO, |c| DVec3::from(c.map(f64::from)));
    let reflectance = rgb(m.diffuse);
    let emission = rgb(m.emissive);
    let name = &m.name;
    if !reflectance.is_finite() || !emission.is_finite() {
        return Err(format!(
            "material '{name}': a colour is not a finite number"
        ));
    }
    if reflectance.max_element() >= 1.0 || reflectance.min_element() < 0.0 {
        return Err(format!(
            "material '{name}': Kd {reflectance} must be at least 0 and below 1 in every channel \
             (a surface cannot reflect all the light it gets)"
        ));
    }
    if emission.min_element() < 0.0 {
        return Err(format!("material '{name}': Ke {emission} is negative"));
    }
    Ok(Material {
        name: name.clone(),
        reflectance,
        emission,
    })
}

/// Checks the OBJ text's `mtllib` and `usemtl` lines before tobj reads them (tobj drops an unknown
/// material silently and names no file when a library is missing): every library exists and every
/// material used is defined in one. Returns the libraries' paths.
fn check_materials(path: &Path, text: &str) -> Result<Vec<String>, String> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut defined: Vec<String> = Vec::new();
    let mut libraries = Vec::new();
    for (number, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("mtllib") => {
                for name in words {
                    let file = dir.join(name);
                    let mtl = std::fs::read_to_string(&file).map_err(|e| {
                        format!(
                            "line {}: material library {} cannot be read: {e}",
                            number + 1,
                            file.display()
                        )
                    })?;
                    defined.extend(mtl.lines().filter_map(|l| {
                        let mut w = l.split_whitespace();
                        (w.next() == Some("newmtl")).then(|| w.collect::<Vec<_>>().join(" "))
                    }));
                    libraries.push(file.display().to_string());
                }
            }
            Some("usemtl") => {
                let name = words.collect::<Vec<_>>().join(" ");
                if !defined.contains(&name) {
                    return Err(format!(
                        "line {}: material '{name}' is not defined in {} (it defines: {})",
                        number + 1,
                        if libraries.is_empty() {
                            "any material library (no `mtllib` line before it)".to_string()
                        } else {
                            libraries.join(", ")
                        },
                        if defined.is_empty() {
                            "none".to_string()
                        } else {
                            defined.join(", ")
                        }
                    ));
                }
            }
            _ => {}
        }
    }
    Ok(libraries)
}

/// Two edges of the polygon that cross (not neighbours), in its own plane: a bow-tie. `None` for
/// a simple polygon. The plane is the one of the largest triangle of corner 0 and two others, so a
/// symmetric bow-tie (whose Newell normal is zero) has one too.
fn crossing_edges(corners: &[DVec3]) -> Option<(usize, usize)> {
    let k = corners.len();
    if k < 4 {
        return None;
    }
    let mut n = DVec3::ZERO;
    for i in 1..k {
        for j in i + 1..k {
            let c = (corners[i] - corners[0]).cross(corners[j] - corners[0]);
            if c.length_squared() > n.length_squared() {
                n = c;
            }
        }
    }
    if n == DVec3::ZERO {
        return None;
    }
    let n = n.normalize();
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let p: Vec<(f64, f64)> = corners.iter().map(|c| (c.dot(u), c.dot(v))).collect();
    let orient = |a: (f64, f64), b: (f64, f64), c: (f64, f64)| {
        (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
    };
    for i in 0..k {
        for j in i + 2..k {
            if (j + 1) % k == i {
                continue;
            }
            let (a, b, c, d) = (p[i], p[(i + 1) % k], p[j], p[(j + 1) % k]);
            let (d1, d2) = (orient(a, b, c), orient(a, b, d));
            let (d3, d4) = (orient(c, d, a), orient(c, d, b));
            if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
                return Some((i, j));
            }
        }
    }
    None
}

/// Newell's normal: twice the polygon's vector area.
pub(crate) fn newell(corners: &[DVec3]) -> DVec3 {
    (0..corners.len())
        .map(|i| corners[i].cross(corners[(i + 1) % corners.len()]))
        .sum()
}

/// Triangles of a simple polygon by ear clipping in the plane normal to `n` (corner indices).
fn ear_clip(corners: &[DVec3], n: DVec3) -> Vec<[usize; 3]> {
    let mut ring: Vec<usize> = (0..corners.len()).collect();
    let mut out = Vec::new();
    let turn = |a: usize, b: usize, c: usize| {
        (corners[b] - corners[a])
            .cross(corners[c] - corners[b])
            .dot(n)
    };
    while ring.len() > 3 {
        let k = ring.len();
        let ear = (0..k).find(|&i| {
            let (a, b, c) = (ring[(i + k - 1) % k], ring[i], ring[(i + 1) % k]);
            turn(a, b, c) > 0.0
                && ring.iter().all(|&p| {
                    p == a
                        || p == b
                        || p == c
                        || turn(a, b, p) < 0.0
                        || turn(b, c, p) < 0.0
                        || turn(c, a, p) < 0.0
                })
        });
        // A polygon with no ear (self-intersecting, or not planar enough to project): cut a fan.
        let i = ear.unwrap_or(1);
        out.push([ring[(i + k - 1) % k], ring[i], ring[(i + 1) % k]]);
        ring.remove(i);
    }
    out.push([ring[0], ring[1], ring[2]]);
    out
}

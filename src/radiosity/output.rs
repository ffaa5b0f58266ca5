//! Lit meshes on disk: PLY with each vertex's radiosity (`float radiosity_r/g/b`, linear RGB) and its
//! display colour (`uchar red/green/blue`), each face's element radiosity, and the exposure used for
//! display in a comment; or OBJ `v x y z r g b` with the display colours. Both written atomically.

use super::solve::Solution;
use glam::DVec3;
use std::fmt::Write as _;
use std::path::Path;

/// The exposure that maps the scene's bright receiving surfaces to near white: 0.9 over the 95th
/// percentile of the vertices' radiosity (largest channel), emitters left out (they saturate).
pub fn auto_exposure(colours: &[DVec3], emitting: &[bool]) -> f64 {
    let mut values: Vec<f64> = colours
        .iter()
        .zip(emitting)
        .filter(|(_, e)| !**e)
        .map(|(c, _)| c.max_element())
        .filter(|v| *v > 0.0)
        .collect();
    if values.is_empty() {
        return 1.0;
    }
    values.sort_by(f64::total_cmp);
    0.9 / values[(values.len() * 95 / 100).min(values.len() - 1)]
}

/// The 8-bit display colour of a radiosity at an exposure: linear, clamped, then sRGB-encoded.
pub fn display(radiosity: DVec3, exposure: f64) -> [u8; 3] {
    (radiosity * exposure).to_array().map(|x| {
        let x = x.clamp(0.0, 1.0);
        let s = if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0).round() as u8
    })
}

/// Writes the lit mesh in the format of `path`'s name (`.ply` or `.obj`); returns the exposure used.
pub fn write(solution: &Solution, emitting: &[bool], path: &Path) -> std::io::Result<f64> {
    let positions: Vec<glam::Vec3> = solution
        .elements
        .positions
        .iter()
        .map(|p| p.as_vec3())
        .collect();
    let colours = &solution.vertex_radiosity;
    let vertex_emits: Vec<bool> = solution
        .elements
        .vertex_polygon
        .iter()
        .map(|&p| emitting[p as usize])
        .collect();
    let exposure = auto_exposure(colours, &vertex_emits);
    let is_obj = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    let bytes = if is_obj {
        let mut s = String::new();
        let _ = writeln!(s, "# lit by vunify radiosity; display exposure {exposure}");
        for (p, c) in positions.iter().zip(colours) {
            let d = display(*c, exposure).map(|x| f32::from(x) / 255.0);
            let _ = writeln!(s, "v {} {} {} {} {} {}", p.x, p.y, p.z, d[0], d[1], d[2]);
        }
        for [a, b, c] in &solution.elements.triangles {
            let _ = writeln!(s, "f {} {} {}", a + 1, b + 1, c + 1);
        }
        s.into_bytes()
    } else {
        let mut h = String::new();
        h.push_str("ply\nformat binary_little_endian 1.0\n");
        let _ = writeln!(h, "comment lit by vunify radiosity");
        let _ = writeln!(
            h,
            "comment {}: faces are lit and seen on the side they wind counter-clockwise around",
            crate::mesh::ONE_SIDED_COMMENT
        );
        let _ = writeln!(h, "comment exposure {exposure}");
        let _ = writeln!(h, "element vertex {}", positions.len());
        for p in ["x", "y", "z", "radiosity_r", "radiosity_g", "radiosity_b"] {
            let _ = writeln!(h, "property float {p}");
        }
        h.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
        let _ = writeln!(h, "element face {}", solution.elements.triangles.len());
        h.push_str("property list uchar int vertex_indices\n");
        for p in ["radiosity_r", "radiosity_g", "radiosity_b"] {
            let _ = writeln!(h, "property float {p}");
        }
        h.push_str("end_header\n");
        let mut out = h.into_bytes();
        for (p, c) in positions.iter().zip(colours) {
            for x in p.to_array() {
                out.extend_from_slice(&x.to_le_bytes());
            }
            for x in c.to_array() {
                out.extend_from_slice(&(x as f32).to_le_bytes());
            }
            out.extend(display(*c, exposure));
        }
        for (t, b) in solution
            .elements
            .triangles
            .iter()
            .zip(&solution.element_radiosity)
        {
            out.push(3);
            for v in t {
                out.extend_from_slice(&(*v as i32).to_le_bytes());
            }
            for x in b.to_array() {
                out.extend_from_slice(&(x as f32).to_le_bytes());
            }
        }
        out
    };
    crate::export::write_atomic(path, &bytes)?;
    Ok(exposure)
}

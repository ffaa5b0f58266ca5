//! The wedges of a paged file (`WEDG` in version 5), coded small: the exact layout's 48 bytes a
//! wedge and 12 a triangle were most of a textured file (61 of the textured dragon's 101 MB).
//!
//! Per wedge, in order: its node's difference from the previous wedge's (a zigzagged varint:
//! wedges are made merge by merge, so after the leaves' they climb by 0 or 1), its parent's
//! distance from it (zigzagged, plus one: 0 is none), texture
//! coordinates (`f32` × 2, exact), texture + 1 and material (varints: none is 0), colour (sRGB
//! bytes, as the pages store node colours) and normal (the pages' three octahedral bytes), each
//! of the last two only when the section's flags say any wedge has one. Then per triangle its
//! corners' wedges, coded as the pages code triangles.

use super::codes::{normal_bytes, normal_of, put_triangle, put_varint, unzigzag, zigzag};
use super::read::Reader;
use crate::color::{srgb_to_linear, srgb8};
use crate::vtree::format::FormatError;
use crate::vtree::{NONE, Wedges};
use glam::Vec3;
use std::path::Path;

/// The section's flags: which optional fields its wedges carry.
const COLORS: u32 = 1;
const NORMALS: u32 = 2;

/// `w`'s section, each wedge's node renumbered by `node_id`.
pub fn encode_wedges(w: &Wedges, node_id: impl Fn(u32) -> u32) -> Vec<u8> {
    let colors = w.color.iter().any(|c| *c != [1.0; 3]);
    let normals = w.normal.iter().any(|n| *n != [0.0; 3]);
    let flags = if colors { COLORS } else { 0 } | if normals { NORMALS } else { 0 };
    let mut out = Vec::with_capacity(8 + 20 * w.len() + 6 * w.corners.len());
    out.extend_from_slice(&(w.len() as u32).to_le_bytes());
    out.extend_from_slice(&flags.to_le_bytes());
    let mut previous = 0i64;
    for k in 0..w.len() {
        let node = node_id(w.node[k]) as i64;
        put_varint(&mut out, zigzag(node - previous));
        previous = node;
        let parent = w.parent[k];
        put_varint(
            &mut out,
            if parent == NONE {
                0
            } else {
                zigzag(parent as i64 - k as i64) + 1
            },
        );
        out.extend_from_slice(&w.uv[k][0].to_le_bytes());
        out.extend_from_slice(&w.uv[k][1].to_le_bytes());
        put_varint(&mut out, w.texture[k].wrapping_add(1) as u64);
        put_varint(&mut out, w.material[k] as u64);
        if colors {
            out.extend(w.color[k].map(srgb8));
        }
        if normals {
            out.extend(normal_bytes(Vec3::from_array(w.normal[k])));
        }
    }
    let mut first = 0i64;
    for &t in &w.corners {
        put_triangle(&mut out, t, &mut first);
    }
    out
}

/// Reads `bytes` (the section, at `base` in `path`) into wedges for `triangles` triangles: every
/// number read in range of what it counts (what they mean is checked with the tree), nothing
/// left over. Tints come from their own section.
pub fn decode_wedges(
    bytes: &[u8],
    base: u64,
    triangles: u32,
    path: &Path,
) -> Result<Wedges, FormatError> {
    let mut r = Reader {
        bytes,
        at: 0,
        base,
        label: "WEDG".into(),
        path,
    };
    let count = u32::from_le_bytes(r.take()?) as usize;
    let flags = u32::from_le_bytes(r.take()?);
    // Each wedge takes at least 12 bytes: a count past that is a lie, refused before allocating.
    if count > bytes.len() / 12 || flags & !(COLORS | NORMALS) != 0 {
        return Err(r.fail(&format!("{count} wedges with flags {flags} cannot be")));
    }
    let mut w = Wedges {
        node: Vec::with_capacity(count),
        parent: Vec::with_capacity(count),
        uv: Vec::with_capacity(count),
        texture: Vec::with_capacity(count),
        material: Vec::with_capacity(count),
        color: Vec::with_capacity(count),
        normal: Vec::with_capacity(count),
        corners: Vec::new(),
        tint: Vec::new(),
    };
    let mut node = 0i64;
    for k in 0..count {
        // Wrapping: a damaged difference gives a node out of range, refused below.
        node = node.wrapping_add(unzigzag(r.varint()?));
        let parent = match r.varint()? {
            0 => Some(NONE),
            up => (k as i64)
                .checked_add(unzigzag(up - 1))
                .filter(|p| (0..count as i64).contains(p))
                .map(|p| p as u32),
        };
        let (Ok(id), Some(parent)) = (u32::try_from(node), parent) else {
            return Err(r.fail(&format!("wedge {k}'s node or parent is out of range")));
        };
        w.node.push(id);
        w.parent.push(parent);
        w.uv.push([r.f32()?, r.f32()?]);
        let texture = r.varint()?;
        let material = r.varint()?;
        let (Ok(texture), Ok(material)) = (u32::try_from(texture), u32::try_from(material)) else {
            return Err(r.fail(&format!("wedge {k}'s texture or material is out of range")));
        };
        w.texture.push(texture.wrapping_sub(1));
        w.material.push(material);
        w.color.push(if flags & COLORS != 0 {
            r.take::<3>()?.map(|c| srgb_to_linear(c as f32 / 255.0))
        } else {
            [1.0; 3]
        });
        w.normal.push(if flags & NORMALS != 0 {
            normal_of(r.take()?).to_array()
        } else {
            [0.0; 3]
        });
    }
    // Each triangle takes at least 3 bytes.
    if triangles as usize > (bytes.len() - r.at) / 3 {
        return Err(r.fail(&format!(
            "{triangles} triangles' corners cannot fit in what is left"
        )));
    }
    w.corners.reserve_exact(triangles as usize);
    let mut first = 0i64;
    for f in 0..triangles {
        let c = r.triangle(&mut first)?;
        if c.iter().any(|&c| c < 0 || c >= count as i64) {
            return Err(r.fail(&format!("triangle {f}'s corners {c:?} are no wedges")));
        }
        w.corners.push(c.map(|c| c as u32));
    }
    if r.at != bytes.len() {
        return Err(r.fail(&format!(
            "{} bytes after the last triangle",
            bytes.len() - r.at
        )));
    }
    Ok(w)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two wedges, then a triangle whose second corner's difference is the largest a varint
    /// holds: summed without wrapping it would overflow (a panic where overflow is checked); it
    /// is a corner out of range, refused.
    #[test]
    fn a_corner_past_any_number_is_an_error() {
        let mut bytes = Vec::new();
        bytes.extend_from_slice(&2u32.to_le_bytes());
        bytes.extend_from_slice(&0u32.to_le_bytes());
        for _ in 0..2 {
            // Node +0, no parent, uv (0, 0), no texture, material 0.
            bytes.extend([0, 0]);
            bytes.extend([0; 8]);
            bytes.extend([0, 0]);
        }
        put_varint(&mut bytes, zigzag(1));
        put_varint(&mut bytes, u64::MAX - 1);
        put_varint(&mut bytes, 0);
        let error = decode_wedges(&bytes, 0, 1, Path::new("w.vtree")).unwrap_err();
        assert!(error.to_string().contains("are no wedges"), "{error}");
    }
}

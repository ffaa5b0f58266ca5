//! glTF 2.0 output: one mesh of one primitive (positions, unit normals when every vertex has one,
//! linear vertex colours, 32-bit indices), as a `.glb` or as a `.gltf` with its `.bin` beside it.
//! Textures and materials are not written yet (issue 38): the colours written are the vertex
//! colours (a textured input's texture means).

use crate::mesh::Mesh;
use serde_json::{Value, json};

/// The binary buffer and the JSON document that describes it (`uri`: the buffer's file, for
/// `.gltf`; `None` for the GLB's own chunk).
pub fn document(mesh: &Mesh, uri: Option<&str>) -> (Value, Vec<u8>) {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut attributes = serde_json::Map::new();
    let mut push = |bytes: &[u8], target: u32, accessor: Value| -> usize {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len(), "target": target}));
        bin.extend_from_slice(bytes);
        let mut a = accessor;
        a["bufferView"] = json!(views.len() - 1);
        accessors.push(a);
        accessors.len() - 1
    };
    const VERTICES: u32 = 34962;
    const INDICES: u32 = 34963;
    let floats =
        |v: &mut dyn Iterator<Item = f32>| -> Vec<u8> { v.flat_map(f32::to_le_bytes).collect() };
    let n = mesh.positions.len();
    let (lo, hi) = mesh.positions.iter().fold(
        (glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let position = push(
        &floats(&mut mesh.positions.iter().flat_map(|p| p.to_array())),
        VERTICES,
        json!({"componentType": 5126, "count": n, "type": "VEC3", "min": lo.to_array(), "max": hi.to_array()}),
    );
    attributes.insert("POSITION".into(), json!(position));
    if let Some(normals) = &mesh.normals {
        // glTF's normals are unit vectors: written only when every vertex has one.
        let unit: Option<Vec<glam::Vec3>> = normals.iter().map(|v| v.try_normalize()).collect();
        if let Some(unit) = unit {
            let a = push(
                &floats(&mut unit.iter().flat_map(|p| p.to_array())),
                VERTICES,
                json!({"componentType": 5126, "count": n, "type": "VEC3"}),
            );
            attributes.insert("NORMAL".into(), json!(a));
        }
    }
    if let Some(colors) = &mesh.colors {
        let a = push(
            &floats(
                &mut colors
                    .iter()
                    .flat_map(|c| c.clamp(glam::Vec3::ZERO, glam::Vec3::ONE).to_array()),
            ),
            VERTICES,
            json!({"componentType": 5126, "count": n, "type": "VEC3"}),
        );
        attributes.insert("COLOR_0".into(), json!(a));
    }
    let indices: Vec<u8> = mesh
        .triangles
        .iter()
        .flatten()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let index = push(
        &indices,
        INDICES,
        json!({"componentType": 5125, "count": mesh.triangles.len() * 3, "type": "SCALAR"}),
    );
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let mut buffer = json!({"byteLength": bin.len()});
    if let Some(uri) = uri {
        buffer["uri"] = json!(uri);
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": format!("vunify {}", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": index, "mode": 4}]}],
        "buffers": [buffer],
        "bufferViews": views,
        "accessors": accessors,
    });
    (doc, bin)
}

/// The mesh as one GLB file: a 12-byte header, the JSON chunk (padded with spaces) and the binary
/// chunk (padded with zeros).
pub fn glb_bytes(mesh: &Mesh) -> Vec<u8> {
    let (doc, bin) = document(mesh, None);
    let mut json = serde_json::to_vec(&doc).expect("a JSON value serializes");
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

//! Shared by the benchmarks: `--name value` options and the model folder.
#![allow(dead_code)]

use std::path::PathBuf;

/// The value after `--name` on the command line, or `default`.
pub fn arg(name: &str, default: &str) -> String {
    let argv: Vec<String> = std::env::args().collect();
    argv.iter()
        .position(|a| a == name)
        .and_then(|i| argv.get(i + 1).cloned())
        .unwrap_or_else(|| default.to_string())
}

/// A model named on the command line (`dragon`, `bunny`, `cow`, or a file name) in `$VUNIFY_MODELS`
/// (required).
pub fn model_file(name: &str) -> PathBuf {
    let file = match name {
        "dragon" => "stanford-dragon.obj.xz".to_string(),
        "bunny" => "stanford-bunny.obj".to_string(),
        m if m.contains('.') => m.to_string(),
        m => format!("{m}.obj"),
    };
    models_dir().join(file)
}

pub fn models_dir() -> PathBuf {
    PathBuf::from(
        std::env::var_os("VUNIFY_MODELS")
            .expect("set VUNIFY_MODELS to the folder of the test models (see the README)"),
    )
}

/// The model named on the command line, or `None` after saying why it cannot be read.
pub fn model_or_skip(name: &str) -> Option<vunify::mesh::Mesh> {
    match vunify::mesh::load(&model_file(name), &vunify::mesh::CleanOptions::default()) {
        Ok((mesh, _)) => Some(mesh),
        Err(e) => {
            eprintln!("skipping {name}: {e}");
            None
        }
    }
}

/// meshoptimizer's edge collapse (`meshopt::simplify`) to `target` triangles, positions only, no
/// error limit; the result keeps the input's vertex array.
pub fn meshopt_simplify(mesh: &vunify::mesh::Mesh, target: usize) -> vunify::mesh::Mesh {
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let adapter = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&mesh.positions), 12, 0)
        .expect("positions");
    let out = meshopt::simplify(
        &indices,
        &adapter,
        target * 3,
        f32::MAX,
        meshopt::SimplifyOptions::empty(),
        None,
    );
    let triangles: Vec<[u32; 3]> = out.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    vunify::mesh::Mesh {
        parts: vec![vunify::mesh::Part {
            name: "meshopt".into(),
            triangles: 0..triangles.len() as u32,
        }],
        triangles,
        colors: None,
        normals: None,
        radiosity: None,
        unreferenced_vertices: 0,
        one_sided: false,
        ..mesh.clone()
    }
}

/// meshoptimizer with the vertex colours as attributes (weight 1) to `target` triangles.
pub fn meshopt_with_colours(mesh: &vunify::mesh::Mesh, target: usize) -> vunify::mesh::Mesh {
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let adapter = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&mesh.positions), 12, 0)
        .expect("positions");
    let colours: Vec<f32> = mesh
        .colors
        .as_ref()
        .expect("a lit mesh")
        .iter()
        .flat_map(|c| c.to_array())
        .collect();
    let out = meshopt::simplify_with_attributes_and_locks(
        &indices,
        &adapter,
        &colours,
        &[1.0, 1.0, 1.0],
        12,
        &vec![false; mesh.positions.len()],
        target * 3,
        f32::MAX,
        meshopt::SimplifyOptions::empty(),
        None,
    );
    let triangles = out.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let mut m = vunify::mesh::Mesh::from_triangles(mesh.positions.clone(), triangles);
    m.colors = mesh.colors.clone();
    m
}

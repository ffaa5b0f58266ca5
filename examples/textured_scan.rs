//! Makes a textured test model from any mesh, as a scanned asset would come: texture charts with
//! seams (each triangle goes to the chart of its normal's dominant axis, six charts packed 3 × 2
//! in one atlas, so every chart border is a UV seam), a generated 1024² texture (a coloured
//! checker with a smooth gradient: stretch, seams and smearing all show), written as `.glb`.
//!
//!   cargo run --release --example textured_scan -- IN.obj[.xz] OUT.glb
//!
//! Also writes `OUT.plain.ply`, the same geometry without any attribute, for comparisons, and
//! `OUT.scene.glb`, a scene of three instances of it under nested transforms, one mirrored, on a
//! ground of a second material (`vunify::fixtures::textured_scene_glb`).

use vunify::mesh::{CleanOptions, Mesh};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, output] = args.as_slice() else {
        return Err("usage: textured_scan IN OUT.glb".into());
    };
    let (mesh, _) = vunify::mesh::load(input.as_ref(), &CleanOptions::default())?;
    let plain = Mesh::from_triangles(mesh.positions.clone(), mesh.triangles.clone());
    let plain_path = std::path::Path::new(output).with_extension("plain.ply");
    vunify::export::write_mesh(&plain, &plain_path)?;
    let textured = vunify::fixtures::textured_scan(&mesh);
    vunify::export::write_mesh(&textured, output.as_ref())?;
    let scene_path = std::path::Path::new(output).with_extension("scene.glb");
    vunify::export::write_atomic(
        &scene_path,
        &vunify::fixtures::textured_scene_glb(&textured),
    )?;
    println!(
        "wrote {output}: {} vertices ({} at seams), {} triangles; and {}, {}",
        textured.positions.len(),
        textured.positions.len() - mesh.positions.len(),
        textured.triangles.len(),
        plain_path.display(),
        scene_path.display()
    );
    Ok(())
}

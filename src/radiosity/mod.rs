//! Radiosity illumination meshes (the input of Liu and Wu's simplification): a progressive refinement solver with adaptive,
//! conforming subdivision along shadow boundaries (`solve`), over scenes read from OBJ + MTL
//! (`scene`), written as lit meshes with per-vertex and per-element radiosity (`output`). See
//! docs/RADIOSITY.md.

pub mod earclip;
pub mod elements;
pub mod output;
pub mod scene;
pub mod solve;
pub mod superfaces;

pub use scene::{Material, Polygon, Scene, SceneError};
pub use solve::{RadiosityOptions, RadiosityStats, Solution, solve};

use std::path::Path;

/// Whether `path` is a scene to light rather than a mesh to view: an `.obj` whose material library
/// (`mtllib`, read from the first 64 KiB, where exporters put it) gives some material a positive
/// `Ke`. Cheap: the geometry is not parsed.
pub fn is_scene(path: &Path) -> bool {
    use std::io::Read;
    let is_obj = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    let mut head = Vec::new();
    let read = std::fs::File::open(path).and_then(|f| f.take(1 << 16).read_to_end(&mut head));
    if !is_obj || read.is_err() {
        return false;
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    String::from_utf8_lossy(&head)
        .lines()
        .filter_map(|l| l.trim().strip_prefix("mtllib "))
        .flat_map(|names| names.split_whitespace())
        .filter_map(|name| std::fs::read_to_string(dir.join(name)).ok())
        .any(|mtl| {
            mtl.lines().any(|l| {
                let mut words = l.split_whitespace();
                words.next() == Some("Ke") && words.any(|w| w.parse::<f64>().is_ok_and(|x| x > 0.0))
            })
        })
}

/// Lights the scene at `path` with the default settings and writes the lit mesh (PLY) to `out`:
/// what `vunify radiosity SCENE -o OUT` does, for the viewer and `render` to open a scene directly.
/// `progress(share of the light shot, what)`.
pub fn light(
    path: &Path,
    out: &Path,
    progress: &mut dyn FnMut(f64, &str),
) -> Result<RadiosityStats, String> {
    let scene = Scene::load(path).map_err(|e| e.to_string())?;
    let solution = solve(&scene, &RadiosityOptions::default(), progress);
    let emitting: Vec<bool> = scene.polygons.iter().map(|p| scene.emits(p)).collect();
    output::write(&solution, &emitting, out)
        .map_err(|e| format!("cannot write {}: {e}", out.display()))?;
    Ok(solution.stats)
}

//! The whole `vunify build` process against meshoptimizer's whole process, as a user meets them:
//! each a fresh process from an OBJ on disk to its result, run alternately.
//!
//! ```sh
//! cargo bench --bench process -- [--model dragon] [--repeat 5]
//! ```
//!
//! The peer is this same program run as `--peer FILE`: tobj loads the OBJ (triangulated, one
//! index), `meshopt::simplify` takes it to 1 % of its triangles. vunify's side is `vunify build FILE
//! -o OUT --json`, which also says where its time went. A `.xz` model is unpacked to a temporary
//! `.obj` first, so that both read the same plain file (and the page cache holds it for both).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

fn main() {
    let argv: Vec<String> = std::env::args().collect();
    if let Some(i) = argv.iter().position(|a| a == "--peer") {
        peer(Path::new(&argv[i + 1]));
        return;
    }
    let name = common::arg("--model", "dragon");
    let repeat: usize = common::arg("--repeat", "5").parse().expect("--repeat N");
    let model = common::model_file(&name);
    let dir = std::env::temp_dir().join(format!("vunify-process-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    let obj = plain_obj(&model, &dir);
    let out = dir.join("out.vtree");
    let vunify = env!("CARGO_BIN_EXE_vunify");
    let me = std::env::current_exe().expect("own path");

    let (mut ours, mut peers) = (Vec::new(), Vec::new());
    let mut phases: Vec<serde_json::Value> = Vec::new();
    for _ in 0..repeat {
        let start = Instant::now();
        let output = Command::new(vunify)
            .args([
                "build",
                obj.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--json",
            ])
            .output()
            .expect("vunify build");
        ours.push(start.elapsed().as_secs_f64());
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        phases.push(serde_json::from_slice(&output.stdout).expect("--json"));

        let start = Instant::now();
        let status = Command::new(&me)
            .args(["--peer", obj.to_str().unwrap()])
            .status()
            .expect("peer");
        peers.push(start.elapsed().as_secs_f64());
        assert!(status.success());
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (a, b) = (median(&mut ours), median(&mut peers));
    let field = |key: &str| {
        let mut v: Vec<f64> = phases
            .iter()
            .filter_map(|j| j.pointer(key).and_then(|x| x.as_f64()))
            .collect();
        if v.is_empty() {
            f64::NAN
        } else {
            median(&mut v)
        }
    };
    println!("## The whole build process: `vunify build` vs tobj + meshopt::simplify to 1 %\n");
    println!(
        "{name}: median of {repeat} alternating runs. vunify build {a:.3} s (load {:.3}, build {:.3}), peer {b:.3} s: ratio **{:.2}×**",
        field("/load_seconds"),
        field("/build/seconds"),
        a / b
    );
    println!(
        "phases (median): features {:.3}, close pairs {:.3}, leaves {:.3}, pricing {:.3}, merging {:.3}, re-pricing {:.3} s",
        field("/build/phases/features"),
        field("/build/phases/close_pairs"),
        field("/build/phases/leaves"),
        field("/build/phases/pricing"),
        field("/build/phases/merging"),
        field("/build/phases/repricing"),
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The model as a plain `.obj` in `dir` (unpacked if it is `.xz`).
fn plain_obj(model: &Path, dir: &Path) -> PathBuf {
    let name = model.file_name().unwrap().to_string_lossy();
    let Some(stem) = name.strip_suffix(".xz") else {
        return model.to_path_buf();
    };
    let bytes = std::fs::read(model).expect("model");
    let mut text = Vec::new();
    std::io::Read::read_to_end(&mut xz2::read::XzDecoder::new(&bytes[..]), &mut text).expect("xz");
    let path = dir.join(stem);
    std::fs::write(&path, text).expect("unpacked model");
    path
}

/// meshoptimizer's whole job: tobj load, then simplify to 1 % of the triangles.
fn peer(path: &Path) {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj(path, &options).expect("tobj");
    let mut positions: Vec<f32> = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    for m in &models {
        let base = (positions.len() / 3) as u32;
        positions.extend(&m.mesh.positions);
        indices.extend(m.mesh.indices.iter().map(|i| base + i));
    }
    let adapter = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&positions), 12, 0)
        .expect("positions");
    let target = indices.len() / 100 / 3 * 3;
    let out = meshopt::simplify(
        &indices,
        &adapter,
        target,
        f32::MAX,
        meshopt::SimplifyOptions::empty(),
        None,
    );
    std::hint::black_box(out);
}

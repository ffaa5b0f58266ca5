//! Writes the fuzzers' seed corpora (`fuzz/seeds/TARGET/`): small meshes in every format vunify
//! reads (ASCII and binary PLY, OFF, OBJ with groups, normals, colours and polygons), pieces of the
//! bundled cessna, `.vtree` files built from them, camera paths and viewer scripts. With a folder of
//! real models as second argument (`VUNIFY_MODELS`), the first 48 KB of each are added too.
//!
//!     cargo run --example fuzz_seeds --no-default-features -- fuzz/seeds [MODELS]

use glam::Vec3;
use std::path::{Path, PathBuf};
use vunify::mesh::{self, CleanOptions, Mesh};

fn main() {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().unwrap_or_else(|| "fuzz/seeds".into()));
    let models = args.next().map(PathBuf::from);
    let cessna = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cessna.obj");
    let (cessna, _) =
        mesh::load(&cessna, &CleanOptions::default()).expect("the bundled model loads");
    let meshes = [
        ("tetra", tetrahedron()),
        ("cessna-part", first_triangles(&cessna, 60)),
    ];
    for (name, m) in &meshes {
        write(&out, "obj", &format!("{name}.obj"), obj(m).as_bytes());
        write(&out, "off", &format!("{name}.off"), off(m).as_bytes());
        write(
            &out,
            "ply",
            &format!("{name}-ascii.ply"),
            ply_ascii(m).as_bytes(),
        );
        write(&out, "ply", &format!("{name}-binary.ply"), &ply_binary(m));
        let (tree, _) =
            vunify::vtree::build(m, &Default::default(), &mut |_, _| {}).expect("builds");
        write(
            &out,
            "vtree",
            &format!("{name}.vtree"),
            &vunify::vtree::to_bytes(&tree),
        );
    }
    write(
        &out,
        "obj",
        "features.obj",
        b"mtllib none.mtl\no first\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nv 1 1 0.5 1 1 1\nvn 0 0 1\ng g1\ns 1\nusemtl m\nf 1//1 2//1 3//1\nf 2/1 4/1 3/1\no second\nf -1 -2 -3 -4\n",
    );
    write(&out, "off", "colored.off", b"COFF\n# comment\n4 2 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n1 1 1 9 9 9 255\n3 0 1 2\n4 0 1 3 2\n");
    let path = vunify::camera_path::CameraPath::orbit(Vec3::ZERO, 1.0, 4.0);
    write(&out, "camera_path", "orbit.json", path.to_json().as_bytes());
    write(&out, "camera_path", "keys.json", br#"{"keyframes":[{"time":0,"position":[0,1,5],"look_at":[0,0,0],"fov_deg":50},{"time":4,"position":[5,1,0],"orientation":[0,0.38,0,0.92],"up":[0,1,0]}]}"#);
    write(&out, "script", "demo.json", br#"{"frames":90,"path":"fly-in","actions":[{"frame":30,"wireframe":true},{"frame":45,"tau":4.0},{"frame":50,"color_by":"error"},{"frame":60,"compare":true},{"frame":70,"record":null},{"frame":89,"screenshot":"out/view.png"}],"stats":"out/view-stats.json"}"#);
    if let Some(dir) = models {
        for entry in std::fs::read_dir(&dir).expect("the models folder") {
            let file = entry.expect("an entry").path();
            if file.extension().is_some_and(|e| e == "obj") {
                let bytes = std::fs::read(&file).expect("readable");
                let name = file.file_name().unwrap().to_string_lossy().to_string();
                write(&out, "obj", &name, &bytes[..bytes.len().min(48 << 10)]);
            }
        }
    }
}

fn write(out: &Path, target: &str, name: &str, bytes: &[u8]) {
    let dir = out.join(target);
    std::fs::create_dir_all(&dir).expect("seed folder");
    std::fs::write(dir.join(name), bytes).expect("seed written");
}

fn tetrahedron() -> Mesh {
    let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    Mesh::from_triangles(p.to_vec(), vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
}

/// The first `n` triangles of `m` and the vertices they use.
fn first_triangles(m: &Mesh, n: usize) -> Mesh {
    let tris: Vec<[u32; 3]> = m.triangles.iter().take(n).copied().collect();
    let used = tris
        .iter()
        .flatten()
        .map(|&v| v as usize)
        .max()
        .map_or(0, |x| x + 1);
    Mesh::from_triangles(m.positions[..used].to_vec(), tris)
}

fn obj(m: &Mesh) -> String {
    let mut s = String::new();
    for p in &m.positions {
        s += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for t in &m.triangles {
        s += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

fn off(m: &Mesh) -> String {
    let mut s = format!("OFF\n{} {} 0\n", m.vertex_count(), m.triangle_count());
    for p in &m.positions {
        s += &format!("{} {} {}\n", p.x, p.y, p.z);
    }
    for t in &m.triangles {
        s += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    s
}

fn ply_header(m: &Mesh, format: &str) -> String {
    format!(
        "ply\nformat {format} 1.0\ncomment fuzz seed\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        m.vertex_count(),
        m.triangle_count()
    )
}

fn ply_ascii(m: &Mesh) -> String {
    let mut s = ply_header(m, "ascii");
    for p in &m.positions {
        s += &format!("{} {} {}\n", p.x, p.y, p.z);
    }
    for t in &m.triangles {
        s += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    s
}

fn ply_binary(m: &Mesh) -> Vec<u8> {
    let mut b = ply_header(m, "binary_little_endian").into_bytes();
    for p in &m.positions {
        for x in p.to_array() {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    for t in &m.triangles {
        b.push(3);
        for v in t {
            b.extend_from_slice(&(*v as i32).to_le_bytes());
        }
    }
    b
}

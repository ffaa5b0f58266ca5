//! Writing results: atomic file replacement, and meshes as Wavefront OBJ, binary PLY or OFF (each
//! optionally xz-compressed), or glTF 2.0 (`.glb`, `.gltf` + `.bin`), the formats vunify reads.

pub mod gltf;

use crate::mesh::{Format, Mesh};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

/// Writes `bytes` to `path` through a temporary file in the same directory and a rename, so a crash
/// never leaves a half-written file. Temporary files for `path` that a killed process left behind
/// (`.NAME.tmp-PID` of a process no longer running) are removed first. A `path` that is not a file
/// (`/dev/null`, `/dev/stdout`, a named pipe) is written in place: renaming over it would replace
/// the device with a file, and for root that would break `/dev/null` for every program after.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_atomic_checked(path, |out| out.write_all(bytes), || Ok(()))
}

/// [`write_atomic`] of what `write` writes, with `check` run alongside it (on another thread): the
/// file takes its place only if the check passes, so a slow check (a tree's consistency) costs no
/// time of its own. `write` gets the file itself: large outputs go straight from their arrays to
/// the kernel, without a copy of the whole file in memory first.
pub fn write_atomic_checked(
    path: &Path,
    write: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()> + Send,
    check: impl FnOnce() -> std::io::Result<()> + Send,
) -> std::io::Result<()> {
    if let Ok(meta) = std::fs::metadata(path) {
        if meta.is_dir() {
            return Err(std::io::Error::other("the output path is a folder"));
        }
        if !meta.is_file() {
            check()?;
            let mut f = std::fs::OpenOptions::new().write(true).open(path)?;
            return write(&mut f).and_then(|()| f.flush());
        }
    }
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .ok_or_else(|| std::io::Error::other("the output path has no file name"))?;
    let prefix = format!(".{}.tmp-", name.to_string_lossy());
    remove_stale_temporaries(dir, &prefix);
    let tmp = dir.join(format!("{prefix}{}", std::process::id()));
    let (checked, written) = rayon::join(check, || -> std::io::Result<()> {
        let mut f = Flushing::new(std::fs::File::create(&tmp)?);
        write(&mut f)?;
        f.file.sync_all()
    });
    let result = checked
        .and(written)
        .and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// A file being written that hands each few megabytes to the disk as soon as they are written
/// (Linux `sync_file_range`, which starts the write-back without waiting for it), so that the
/// `fsync` at the end waits for the last few only instead of the whole file.
struct Flushing {
    file: std::fs::File,
    written: u64,
    flushed: u64,
}

/// How much is written before it is handed on.
const FLUSH_EVERY: usize = 8 << 20;

impl Flushing {
    fn new(file: std::fs::File) -> Flushing {
        Flushing {
            file,
            written: 0,
            flushed: 0,
        }
    }
}

impl std::io::Write for Flushing {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(&buf[..buf.len().min(FLUSH_EVERY)])?;
        self.written += n as u64;
        if self.written - self.flushed >= FLUSH_EVERY as u64 {
            #[cfg(target_os = "linux")]
            {
                use std::os::fd::AsRawFd;
                // SAFETY: a valid descriptor and range; the call only starts write-back (an error
                // is harmless: the final `fsync` still flushes everything).
                unsafe {
                    libc::sync_file_range(
                        self.file.as_raw_fd(),
                        self.flushed as libc::off64_t,
                        (self.written - self.flushed) as libc::off64_t,
                        libc::SYNC_FILE_RANGE_WRITE,
                    );
                }
            }
            self.flushed = self.written;
        }
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

/// Removes `dir/PREFIXPID` files whose process has ended. Only where the process table can be read
/// (Linux's `/proc`); elsewhere nothing is removed, since a live writer's file must never go.
fn remove_stale_temporaries(dir: &Path, prefix: &str) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(pid) = file_name
            .to_str()
            .and_then(|n| n.strip_prefix(prefix))
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// OBJ text of a mesh: `v x y z [r g b]`, `vn` when the mesh has normals, one `o` per part.
pub fn obj_string(mesh: &Mesh) -> String {
    obj_with_materials(mesh, None)
}

/// OBJ text; with `library` (the MTL file's name), also `vt` texture coordinates (OBJ's `v` counts
/// from the image's bottom) and a `usemtl` before each run of triangles of one material.
fn obj_with_materials(mesh: &Mesh, library: Option<&str>) -> String {
    let mut s = String::with_capacity(mesh.positions.len() * 40 + mesh.triangles.len() * 24);
    let _ = writeln!(s, "# written by vunify {}", env!("CARGO_PKG_VERSION"));
    let _ = writeln!(
        s,
        "# {} vertices, {} triangles",
        mesh.positions.len(),
        mesh.triangles.len()
    );
    let materials = library.and_then(|_| gltf::materials_of(mesh));
    if let Some(name) = library {
        let _ = writeln!(s, "mtllib {name}");
    }
    for (i, p) in mesh.positions.iter().enumerate() {
        match &mesh.colors {
            Some(c) if materials.is_none() => {
                let c = c[i];
                let _ = writeln!(s, "v {} {} {} {} {} {}", p.x, p.y, p.z, c.x, c.y, c.z);
            }
            _ => {
                let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
            }
        }
    }
    let uvs = mesh.uvs.as_ref().filter(|_| materials.is_some());
    if let Some(uvs) = uvs {
        for t in uvs {
            let _ = writeln!(s, "vt {} {}", t.x, 1.0 - t.y);
        }
    }
    if let Some(normals) = &mesh.normals {
        for n in normals {
            let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
        }
    }
    let mut current = None;
    for part in &mesh.parts {
        let _ = writeln!(s, "o {}", part.name);
        for t in &mesh.triangles[part.triangles.start as usize..part.triangles.end as usize] {
            if let Some((list, of)) = &materials {
                let m = of[t[0] as usize];
                if current != Some(m) {
                    current = Some(m);
                    let _ = writeln!(s, "usemtl {}", mtl_name(&list[m as usize], m));
                }
            }
            let [a, b, c] = t.map(|v| v + 1);
            match (uvs.is_some(), mesh.normals.is_some()) {
                (true, true) => writeln!(s, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}"),
                (true, false) => writeln!(s, "f {a}/{a} {b}/{b} {c}/{c}"),
                (false, true) => writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}"),
                (false, false) => writeln!(s, "f {a} {b} {c}"),
            }
            .expect("writing to a String");
        }
    }
    s
}

/// A material's name in MTL: one word (spaces would end it), unique by its index.
fn mtl_name(m: &crate::mesh::Material, index: u32) -> String {
    let word: String = m
        .name
        .chars()
        .map(|c| if c.is_whitespace() { '_' } else { c })
        .collect();
    format!("m{index}_{word}")
}

/// The MTL library of `mesh`'s materials (`Kd` and `d` the base colour and alpha, `map_Kd` the
/// base colour texture, `map_Bump` the normal map, `Ke` the emission), and the textures it names
/// with their files' names, `image_name(texture, extension)`.
fn mtl_library(
    mesh: &Mesh,
    image_name: &dyn Fn(usize, &str) -> String,
) -> (String, Vec<(usize, String)>) {
    let mut s = format!("# written by vunify {}\n", env!("CARGO_PKG_VERSION"));
    let mut files: Vec<(usize, String)> = Vec::new();
    let Some((list, _)) = gltf::materials_of(mesh) else {
        return (s, files);
    };
    let mut file = |t: u32| {
        let t = t as usize;
        let name = image_name(t, gltf::mime_type(&mesh.textures[t]).1);
        if !files.iter().any(|(k, _)| *k == t) {
            files.push((t, name.clone()));
        }
        name
    };
    for (i, m) in list.iter().enumerate() {
        let [r, g, b, a] = m.base_color_factor;
        let _ = writeln!(
            s,
            "\nnewmtl {}\nKd {r} {g} {b}\nd {a}",
            mtl_name(m, i as u32)
        );
        let [er, eg, eb] = m.emissive_factor;
        if m.emissive_factor != [0.0; 3] {
            let _ = writeln!(s, "Ke {er} {eg} {eb}");
        }
        if let Some(t) = m.base_color_texture {
            let _ = writeln!(s, "map_Kd {}", file(t));
        }
        if let Some(t) = m.normal_texture {
            let _ = writeln!(s, "map_Bump {}", file(t));
        }
    }
    (s, files)
}

pub fn write_obj(mesh: &Mesh, path: &Path) -> std::io::Result<()> {
    write_atomic(path, obj_string(mesh).as_bytes())
}

/// Binary little-endian PLY: `float x y z`, with `uchar red green blue` (the colours times 255, as
/// most PLY tools expect) when the mesh has colours; `int` vertex indices.
pub fn ply_bytes(mesh: &Mesh) -> Vec<u8> {
    ply_with_texture(mesh, None)
}

/// [`ply_bytes`]; with `texture`, the file its header names (`comment TextureFile`, as MeshLab
/// writes) and `float s t` texture coordinates (`t` counted from the image's bottom).
fn ply_with_texture(mesh: &Mesh, texture: Option<&str>) -> Vec<u8> {
    let mut header = String::new();
    let _ = writeln!(header, "ply\nformat binary_little_endian 1.0");
    let _ = writeln!(
        header,
        "comment written by vunify {}",
        env!("CARGO_PKG_VERSION")
    );
    if mesh.one_sided {
        let _ = writeln!(
            header,
            "comment {}: faces are seen from the side they wind counter-clockwise around",
            crate::mesh::ONE_SIDED_COMMENT
        );
    }
    if let Some(name) = texture {
        let _ = writeln!(header, "comment TextureFile {name}");
    }
    let uvs = mesh.uvs.as_ref().filter(|_| texture.is_some());
    let _ = writeln!(header, "element vertex {}", mesh.positions.len());
    header.push_str("property float x\nproperty float y\nproperty float z\n");
    if uvs.is_some() {
        header.push_str("property float s\nproperty float t\n");
    }
    if mesh.colors.is_some() {
        header.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    if mesh.radiosity.is_some() {
        header.push_str(
            "property float radiosity_r\nproperty float radiosity_g\nproperty float radiosity_b\n",
        );
    }
    let _ = writeln!(header, "element face {}", mesh.triangles.len());
    header.push_str("property list uchar int vertex_indices\nend_header\n");
    let mut out = header.into_bytes();
    out.reserve(mesh.positions.len() * 15 + mesh.triangles.len() * 13);
    for (i, p) in mesh.positions.iter().enumerate() {
        for x in p.to_array() {
            out.extend_from_slice(&x.to_le_bytes());
        }
        if let Some(uvs) = uvs {
            out.extend_from_slice(&uvs[i].x.to_le_bytes());
            out.extend_from_slice(&(1.0 - uvs[i].y).to_le_bytes());
        }
        if let Some(colors) = &mesh.colors {
            out.extend(
                colors[i]
                    .to_array()
                    .map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8),
            );
        }
        if let Some(radiosity) = &mesh.radiosity {
            for x in radiosity[i].to_array() {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    for t in &mesh.triangles {
        out.push(3);
        for v in t {
            out.extend_from_slice(&(*v as i32).to_le_bytes());
        }
    }
    out
}

/// OFF text (`COFF` with 8-bit colours when the mesh has them).
pub fn off_string(mesh: &Mesh) -> String {
    let mut s = String::with_capacity(mesh.positions.len() * 40 + mesh.triangles.len() * 24);
    let _ = writeln!(s, "{}", if mesh.colors.is_some() { "COFF" } else { "OFF" });
    let _ = writeln!(s, "# written by vunify {}", env!("CARGO_PKG_VERSION"));
    let _ = writeln!(s, "{} {} 0", mesh.positions.len(), mesh.triangles.len());
    for (i, p) in mesh.positions.iter().enumerate() {
        let _ = write!(s, "{} {} {}", p.x, p.y, p.z);
        if let Some(colors) = &mesh.colors {
            let [r, g, b] = colors[i]
                .to_array()
                .map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
            let _ = write!(s, " {r} {g} {b} 255");
        }
        s.push('\n');
    }
    for [a, b, c] in &mesh.triangles {
        let _ = writeln!(s, "3 {a} {b} {c}");
    }
    s
}

/// Writes a chain of levels of detail of one model as one glTF file (`.glb`, or `.gltf` with its
/// `.bin` and images beside it): a mesh and a scene per level, each with `extras` saying what it is.
pub fn write_chain(levels: &[(&Mesh, serde_json::Value)], path: &Path) -> std::io::Result<()> {
    if Format::from_path(path) != Some(Format::Gltf) || levels.is_empty() {
        return Err(std::io::Error::other(
            "a chain of levels is written as .glb or .gltf",
        ));
    }
    if is_glb(path) {
        let (doc, bin) = gltf::chain_document(levels, None);
        return write_atomic(path, &gltf::glb(&doc, bin));
    }
    let stem = path
        .file_stem()
        .map_or_else(|| "mesh".into(), |n| n.to_string_lossy().into_owned());
    let bin_name = format!("{stem}.bin");
    let image_name = |k: usize, ext: &str| format!("{stem}_image{k}.{ext}");
    let (doc, bin) = gltf::chain_document(levels, Some((&bin_name, &image_name)));
    write_atomic(&path.with_extension("bin"), &bin)?;
    for (k, image) in gltf::images(levels[0].0).iter().enumerate() {
        write_atomic(
            &path.with_file_name(image_name(k, image.extension)),
            image.bytes,
        )?;
    }
    write_atomic(
        path,
        &serde_json::to_vec_pretty(&doc).map_err(std::io::Error::other)?,
    )
}

/// The one base colour texture every textured vertex of `mesh` uses, if there is exactly one (PLY
/// names one image).
fn single_texture(mesh: &Mesh) -> Option<usize> {
    let mut used = mesh
        .texture_of
        .as_ref()?
        .iter()
        .filter(|&&t| t != crate::mesh::NO_TEXTURE);
    let first = *used.next()?;
    used.all(|&t| t == first).then_some(first as usize)
}

fn is_glb(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"))
}

/// Writes `mesh` atomically in the format its name asks for (`.obj`, `.ply`, `.off`, each
/// optionally followed by `.xz`; `.glb`, or `.gltf` with a `.bin` beside it).
pub fn write_mesh(mesh: &Mesh, path: &Path) -> std::io::Result<()> {
    use crate::mesh::Format;
    let format = Format::from_path(path).ok_or_else(|| {
        std::io::Error::other(
            "the output name must end in .obj, .ply, .off (optionally .xz), .glb or .gltf",
        )
    })?;
    let compressed = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xz"));
    if compressed && format == Format::Gltf {
        return Err(std::io::Error::other(
            "glTF output is not written .xz-compressed",
        ));
    }
    let stem = path
        .file_stem()
        .map_or_else(|| "mesh".into(), |n| n.to_string_lossy().into_owned());
    let stem = [".obj", ".ply", ".off"]
        .iter()
        .find_map(|e| stem.strip_suffix(e))
        .unwrap_or(&stem)
        .to_owned();
    let image_name = |k: usize, ext: &str| format!("{stem}_image{k}.{ext}");
    let bytes = match format {
        // A mesh with textures or materials: its MTL library and images beside it.
        Format::Obj if mesh.material_of.is_some() || mesh.texture_of.is_some() => {
            let library = format!("{stem}.mtl");
            let texture_name = |t: usize, ext: &str| format!("{stem}_texture{t}.{ext}");
            let (mtl, files) = mtl_library(mesh, &texture_name);
            for (t, name) in files {
                write_atomic(&path.with_file_name(name), &mesh.textures[t])?;
            }
            write_atomic(&path.with_file_name(&library), mtl.as_bytes())?;
            obj_with_materials(mesh, Some(&library)).into_bytes()
        }
        Format::Obj => obj_string(mesh).into_bytes(),
        // A mesh with one base colour texture: the image beside it, named in its header.
        Format::Ply if single_texture(mesh).is_some() => {
            let t = single_texture(mesh).expect("checked");
            let name = format!("{stem}_texture{t}.{}", gltf::mime_type(&mesh.textures[t]).1);
            write_atomic(&path.with_file_name(&name), &mesh.textures[t])?;
            ply_with_texture(mesh, Some(&name))
        }
        Format::Ply => ply_bytes(mesh),
        Format::Off => off_string(mesh).into_bytes(),
        Format::Gltf if is_glb(path) => gltf::glb_bytes(mesh),
        Format::Gltf => {
            // The JSON names its buffer and images, written first beside it: the same stem,
            // `.bin`, and `_image<k>.png` / `.jpg`.
            let bin_path = path.with_extension("bin");
            let bin_name = format!("{stem}.bin");
            let (doc, bin) = gltf::document(mesh, Some((&bin_name, &image_name)));
            write_atomic(&bin_path, &bin)?;
            for (k, image) in gltf::images(mesh).iter().enumerate() {
                write_atomic(
                    &path.with_file_name(image_name(k, image.extension)),
                    image.bytes,
                )?;
            }
            serde_json::to_vec_pretty(&doc).map_err(std::io::Error::other)?
        }
    };
    if compressed {
        let mut encoder = xz2::write::XzEncoder::new(Vec::new(), 6);
        encoder.write_all(&bytes)?;
        return write_atomic(path, &encoder.finish()?);
    }
    write_atomic(path, &bytes)
}

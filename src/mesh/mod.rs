//! Triangle meshes and scenes: the input of everything else.
//!
//! Pipeline position: **mesh** → simplify → vtree → measure. A [`Mesh`] is a welded, cleaned triangle soup
//! with optional per-vertex colours and normals, split into named [`Part`]s (OBJ `o`/`g` groups) so that a
//! whole scene is one mesh.

mod clean;
mod error;
pub mod gltf;
mod obj;
mod obj_textured;
mod off;
mod ply;
mod ply_binary;

pub use clean::{CleanOptions, CleanReport, clean};
pub use error::{InputError, Location};

use glam::{Vec2, Vec3};
use std::ops::Range;
use std::path::Path;

/// A named group of triangles inside a scene (an OBJ `o` or `g`, or the whole file).
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    pub name: String,
    /// Range into [`Mesh::triangles`].
    pub triangles: Range<u32>,
}

/// An indexed triangle mesh. Attribute vectors, when present, have one entry per position.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Linear RGB in `[0, 1]`, e.g. from OBJ `v x y z r g b` or PLY `red green blue`.
    pub colors: Option<Vec<Vec3>>,
    pub normals: Option<Vec<Vec3>>,
    /// Linear radiosity (RGB, unbounded) of a lit mesh, from PLY `radiosity_r/g/b` (what `vunify
    /// radiosity` writes beside the display colours); carried through to the PLY files vunify writes.
    pub radiosity: Option<Vec<Vec3>>,
    pub triangles: Vec<[u32; 3]>,
    pub parts: Vec<Part>,
    /// Vertices of the file that no face uses and that the reader left out before `positions` (the
    /// OBJ reader keeps only referenced vertices); [`clean`] counts them with the unused ones it
    /// drops itself.
    pub unreferenced_vertices: usize,
    /// The faces are seen only from the side they wind counter-clockwise around, and the winding is
    /// meant (lit meshes from `vunify radiosity`, seen from inside a room): the runtime's back-face
    /// test takes it as it is instead of guessing from the sign of the volume. PLY files say so with
    /// a header comment starting with [`ONE_SIDED_COMMENT`].
    pub one_sided: bool,
    /// Texture coordinates into each vertex's base colour texture (glTF `TEXCOORD_0`, with
    /// `KHR_texture_transform` applied), one per position.
    pub uvs: Option<Vec<Vec2>>,
    /// Each vertex's base colour texture: an index into [`Mesh::textures`], or [`NO_TEXTURE`].
    /// Vertices on a border between textures are split (the clean-up welds only vertices with the
    /// same texture and coordinates), so a vertex has one.
    pub texture_of: Option<Vec<u32>>,
    /// Images, as their files' bytes (PNG or JPEG): the base colour textures [`Mesh::texture_of`]
    /// names (sRGB), and the other maps of [`Mesh::materials`] (carried through to the output).
    pub textures: Vec<std::sync::Arc<Vec<u8>>>,
    /// The file's materials (glTF materials, OBJ `usemtl` of an MTL library); empty when it has none.
    pub materials: Vec<Material>,
    /// Each vertex's material, an index into [`Mesh::materials`]; `None` when there are none. A
    /// vertex on a border between materials is split like a texture seam, so a triangle's corners
    /// share one.
    pub material_of: Option<Vec<u32>>,
    /// Each vertex's tint of its base colour texture (glTF `COLOR_0` on a textured primitive:
    /// the texture's colour is multiplied by it), linear RGB; white on untextured vertices, whose
    /// [`Mesh::colors`] hold theirs already. `None` when no textured vertex is tinted.
    pub tints: Option<Vec<Vec3>>,
}

/// A surface's material, glTF's metallic-roughness model (an OBJ material maps onto it: `Kd` and
/// `map_Kd` are its base colour, `d` its alpha). Texture fields index [`Mesh::textures`]; every
/// map reads [`Mesh::uvs`]. Only the base colour is drawn and weighed by the builder; the others
/// are carried through to the files vunify writes.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Material {
    pub name: String,
    /// Linear RGBA.
    pub base_color_factor: [f32; 4],
    pub base_color_texture: Option<u32>,
    pub metallic_factor: f32,
    pub roughness_factor: f32,
    pub metallic_roughness_texture: Option<u32>,
    pub normal_texture: Option<u32>,
    pub occlusion_texture: Option<u32>,
    pub emissive_texture: Option<u32>,
    pub emissive_factor: [f32; 3],
    pub alpha_mode: AlphaMode,
    /// The alpha below which a [`AlphaMode::Mask`] surface is not drawn.
    pub alpha_cutoff: f32,
    pub double_sided: bool,
    /// Some of its vertices had colours of their own (glTF `COLOR_0`), which multiply the base colour.
    pub vertex_colors: bool,
}

impl Default for Material {
    /// glTF's default material: white, fully metallic and rough, opaque, single-sided.
    fn default() -> Material {
        Material {
            name: String::new(),
            base_color_factor: [1.0; 4],
            base_color_texture: None,
            metallic_factor: 1.0,
            roughness_factor: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            occlusion_texture: None,
            emissive_texture: None,
            emissive_factor: [0.0; 3],
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
            double_sided: false,
            vertex_colors: false,
        }
    }
}

impl Material {
    /// Every image the material uses.
    pub fn textures(&self) -> impl Iterator<Item = u32> {
        [
            self.base_color_texture,
            self.metallic_roughness_texture,
            self.normal_texture,
            self.occlusion_texture,
            self.emissive_texture,
        ]
        .into_iter()
        .flatten()
    }
}

/// How a material's alpha is used (glTF `alphaMode`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum AlphaMode {
    #[default]
    Opaque,
    Mask,
    Blend,
}

/// [`Mesh::texture_of`] of a vertex with no texture.
pub const NO_TEXTURE: u32 = u32::MAX;

/// The PLY header comment that marks a [`Mesh::one_sided`] mesh.
pub const ONE_SIDED_COMMENT: &str = "one-sided";

impl Mesh {
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Axis-aligned bounds `(min, max)`; `(0, 0)` for an empty mesh.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        if self.positions.is_empty() {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in &self.positions {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        (lo, hi)
    }

    /// Length of the bounding-box diagonal: the unit of every relative distance in vunify.
    pub fn diagonal(&self) -> f32 {
        let (lo, hi) = self.bounds();
        diagonal_of(hi - lo)
    }

    /// A mesh with one part covering all triangles.
    pub fn from_triangles(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
        let parts = vec![Part {
            name: "mesh".into(),
            triangles: 0..triangles.len() as u32,
        }];
        Mesh {
            positions,
            colors: None,
            normals: None,
            radiosity: None,
            triangles,
            parts,
            unreferenced_vertices: 0,
            one_sided: false,
            uvs: None,
            texture_of: None,
            textures: Vec::new(),
            materials: Vec::new(),
            material_of: None,
            tints: None,
        }
    }

    /// Gives each vertex the attributes of `source`'s vertex `ids[v]` (colours, normals, radiosity,
    /// texture coordinates and texture, material), with `source`'s textures, materials and sidedness.
    pub fn carry_attributes(&mut self, source: &Mesh, ids: &[u32]) {
        fn pick<T: Copy>(a: &Option<Vec<T>>, ids: &[u32]) -> Option<Vec<T>> {
            a.as_ref()
                .map(|a| ids.iter().map(|&v| a[v as usize]).collect())
        }
        self.colors = pick(&source.colors, ids);
        self.normals = pick(&source.normals, ids);
        self.radiosity = pick(&source.radiosity, ids);
        self.uvs = pick(&source.uvs, ids);
        self.texture_of = pick(&source.texture_of, ids);
        self.material_of = pick(&source.material_of, ids);
        self.tints = pick(&source.tints, ids);
        self.textures = source.textures.clone();
        self.materials = source.materials.clone();
        self.one_sided = source.one_sided;
    }

    /// Checks the structural invariants every loader and [`clean`] guarantee.
    pub fn check(&self) -> Result<(), MeshProblem> {
        let n = self.positions.len();
        if let Some(c) = &self.colors
            && c.len() != n
        {
            return Err(MeshProblem::ColorCount {
                colors: c.len(),
                positions: n,
            });
        }
        if let Some(c) = &self.tints
            && c.len() != n
        {
            return Err(MeshProblem::ColorCount {
                colors: c.len(),
                positions: n,
            });
        }
        if let Some(c) = &self.radiosity
            && c.len() != n
        {
            return Err(MeshProblem::RadiosityCount {
                radiosity: c.len(),
                positions: n,
            });
        }
        if let Some(c) = &self.normals
            && c.len() != n
        {
            return Err(MeshProblem::NormalCount {
                normals: c.len(),
                positions: n,
            });
        }
        for (i, p) in self.positions.iter().enumerate() {
            if !p.is_finite() {
                return Err(MeshProblem::NotFinite {
                    index: i,
                    position: *p,
                });
            }
        }
        for (i, t) in self.triangles.iter().enumerate() {
            if t.iter().any(|&v| v as usize >= n) {
                return Err(MeshProblem::IndexPastEnd {
                    index: i,
                    corners: *t,
                    positions: n,
                });
            }
        }
        let mut next = 0;
        for p in &self.parts {
            if p.triangles.start != next || p.triangles.end < p.triangles.start {
                return Err(MeshProblem::PartsOverlap(p.name.clone()));
            }
            next = p.triangles.end;
        }
        if next as usize != self.triangles.len() {
            return Err(MeshProblem::PartsShort);
        }
        if let Some(m) = &self.material_of
            && (m.len() != n || m.iter().any(|&i| i as usize >= self.materials.len()))
        {
            return Err(MeshProblem::Materials);
        }
        let images = self.textures.len() as u32;
        if self
            .materials
            .iter()
            .flat_map(Material::textures)
            .any(|t| t >= images)
        {
            return Err(MeshProblem::Materials);
        }
        Ok(())
    }
}

/// A broken structural invariant of a [`Mesh`] (see [`Mesh::check`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshProblem {
    #[error("{colors} colours for {positions} positions")]
    ColorCount { colors: usize, positions: usize },
    #[error("{radiosity} radiosity values for {positions} positions")]
    RadiosityCount { radiosity: usize, positions: usize },
    #[error("{normals} normals for {positions} positions")]
    NormalCount { normals: usize, positions: usize },
    #[error("position {index} is not finite: {position}")]
    NotFinite { index: usize, position: Vec3 },
    #[error("triangle {index} {corners:?} indexes past {positions} positions")]
    IndexPastEnd {
        index: usize,
        corners: [u32; 3],
        positions: usize,
    },
    #[error("part {0:?} does not tile the triangle list")]
    PartsOverlap(String),
    #[error("parts do not cover every triangle")]
    PartsShort,
    #[error("a vertex's material or a material's texture is out of range")]
    Materials,
}

/// The length of a box's diagonal `extent`, without the underflow or overflow of squaring its sides
/// in `f32` (sides below ~1e-19 square to nothing, above ~1e19 to infinity): a model at any scale a
/// float holds has a diagonal (infinite only past `f32::MAX`).
pub fn diagonal_of(extent: Vec3) -> f32 {
    let d = extent.length();
    if d.is_finite() && d >= 1e-18 {
        return d;
    }
    let e = extent.abs().as_dvec3();
    let m = e.max_element();
    if m == 0.0 {
        0.0
    } else {
        (m * (e / m).length()) as f32
    }
}

/// The file formats vunify reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Obj,
    Ply,
    Off,
    /// glTF 2.0, `.gltf` (JSON, with its buffers and images beside it or in data URIs) or `.glb`.
    Gltf,
}

impl Format {
    /// From the file name: `.obj`, `.ply`, `.off`, `.gltf`, `.glb`, each optionally followed by
    /// `.xz`.
    pub fn from_path(path: &Path) -> Option<Format> {
        let name = path.file_name()?.to_str()?.to_ascii_lowercase();
        let name = name.strip_suffix(".xz").unwrap_or(&name);
        match name.rsplit('.').next()? {
            "obj" => Some(Format::Obj),
            "ply" => Some(Format::Ply),
            "off" => Some(Format::Off),
            "gltf" | "glb" => Some(Format::Gltf),
            _ => None,
        }
    }
}

/// Parses mesh bytes in a known format. `path` is used only to name the file in errors.
/// The result is raw: not welded or cleaned (see [`clean`]).
pub fn parse(bytes: &[u8], format: Format, path: &Path) -> Result<Mesh, InputError> {
    // The parsers are written not to panic; this is a last line of defence for the third-party
    // crate (ply-rs-bw) under the PLY reader, so that no input can take the program down.
    let result = std::panic::catch_unwind(|| match format {
        Format::Obj => obj::parse(bytes, path),
        Format::Ply => ply::parse(bytes, path),
        Format::Off => off::parse(bytes, path),
        Format::Gltf => gltf::parse(bytes, path).map(|r| r.mesh),
    });
    let mesh = match result {
        Ok(r) => r?,
        Err(_) => {
            return Err(InputError::whole(
                path,
                "the parser failed on this input (internal error)",
            ));
        }
    };
    if mesh.triangles.is_empty() {
        return Err(InputError::whole(path, "the mesh has no faces"));
    }
    debug_assert!(mesh.check().is_ok(), "{:?}", mesh.check());
    Ok(mesh)
}

/// Reads, parses and cleans a mesh file (`.obj`, `.ply`, `.off`, `.gltf`, `.glb`, optionally
/// `.xz`-compressed). What the reader left out or replaced (a glTF file's line primitives, a missing
/// texture) is in the report's `notes`.
pub fn load(path: &Path, options: &CleanOptions) -> Result<(Mesh, CleanReport), InputError> {
    let format = Format::from_path(path).ok_or_else(|| {
        InputError::whole(
            path,
            "unknown mesh format: expected a .obj, .ply, .off, .gltf or .glb file (optionally .xz)",
        )
    })?;
    let bytes = read_maybe_xz(path)?;
    let mut notes = Vec::new();
    let raw = if format == Format::Gltf {
        let read = std::panic::catch_unwind(|| gltf::parse(&bytes, path)).map_err(|_| {
            InputError::whole(path, "the parser failed on this input (internal error)")
        })??;
        notes = read.notes;
        read.mesh
    } else if format == Format::Obj && std::str::from_utf8(&bytes).is_ok_and(obj_textured::wants) {
        // Read by the geometry reader first, for its errors with line numbers.
        parse(&bytes, format, path)?;
        let text = std::str::from_utf8(&bytes).expect("checked above");
        std::panic::catch_unwind(|| {
            let mut notes = Vec::new();
            obj_textured::parse(text, path, &mut notes).map(|m| (m, notes))
        })
        .map_err(|_| InputError::whole(path, "the parser failed on this input (internal error)"))?
        .map(|(m, n)| {
            notes = n;
            m
        })?
    } else if format == Format::Ply {
        let mut mesh = parse(&bytes, format, path)?;
        if let Some(name) = ply::texture_file(&bytes) {
            ply::attach_texture(&mut mesh, &name, path, &mut notes);
        }
        mesh
    } else {
        parse(&bytes, format, path)?
    };
    let (mesh, mut report) = clean(raw, options);
    report.notes = notes;
    if mesh.triangles.is_empty() {
        return Err(InputError::whole(
            path,
            "every face is degenerate: nothing is left to build",
        ));
    }
    Ok((mesh, report))
}

fn read_maybe_xz(path: &Path) -> Result<Vec<u8>, InputError> {
    let bytes =
        std::fs::read(path).map_err(|e| InputError::whole(path, format!("cannot read: {e}")))?;
    let is_xz = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xz"));
    if !is_xz {
        return Ok(bytes);
    }
    use std::io::Read;
    let mut out = Vec::with_capacity(bytes.len() * 6);
    xz2::read::XzDecoder::new(&bytes[..])
        .read_to_end(&mut out)
        .map_err(|e| InputError::whole(path, format!("cannot decompress xz data: {e}")))?;
    Ok(out)
}

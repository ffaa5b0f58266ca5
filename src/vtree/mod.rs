//! The binary vertex tree of Tao et al. (§3.1): leaves are the input vertices, each internal node the
//! `vunify` of its two children, the root the whole scene merged to one vertex.
//!
//! Nodes are numbered leaves first (`0..leaf_count`: a built tree's in the input's vertex order, a
//! tree read from a paged file depth-first, see [`paged`]), then internal nodes in
//! build order, so children always precede their parent and the root is the last node. Triangles are
//! stored once, as leaf indices, grouped by the node whose merge makes them vanish ("the triangle set
//! enumerated by u"); a front maps their corners to its vertices.
//!
//! The method: Tao Zhi-Liang, Cheng Chi-Yi, Pan Zhi-Geng, Shi Jiao-Ying (State Key Laboratory of
//! CAD&CG, Zhejiang University), *Dynamic level of detail framework with topological structure
//! modification* (拓扑结构可变的动态多细节层次模型). `docs/VERTEX_TREE.md` explains the builder.

mod build;
mod check;
mod extract;
mod format;
mod paged;
mod section;
mod table;

pub use build::{
    BudgetTooSmall, BuildError, BuildOptions, BuildStats, CELLS_FLOOR_BYTES_PER_TRIANGLE,
    DEFAULT_CELL_TRIANGLES, Schedule, WHOLE_BUILD_BYTES_PER_TRIANGLE, build, build_partitioned,
    cells, cells_build_bytes, cells_within, default_cells, whole_build_bytes,
};
pub use check::{TreeProblem, check, check_cut};
pub use extract::{Cut, cut_at_bound, cut_at_error, cut_at_merges, cut_at_triangles};
pub use format::{
    Encoding, FORMAT_VERSION, FormatError, FormatErrorKind, MAGIC, OLDEST_FORMAT_VERSION, read,
    read_bytes, read_pages, to_bytes, to_bytes_with, write, write_with,
};
pub use paged::{DecodedPage, PAGE_NODES, PageEntry, PagedFile, Survey};

use crate::simplify::Metric;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// No parent or child.
pub const NONE: u32 = u32::MAX;

/// One tree node, exactly as stored in a `.vtree` file (84 bytes, little-endian).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Node {
    pub position: [f32; 3],
    /// Object-space error where this node stands in for its subtree, 0 for leaves, never less than a
    /// child's: the largest of the RMS plane distance, the measured distance of a few input vertices
    /// to the merged surface, and each child's error plus its vertex's distance to that surface. Not a
    /// strict bound: the Hausdorff max of a cut at error E is 1.0–2.8 E on the models measured.
    pub error: f32,
    /// Linear RGB, carried down from the input (white when it has none).
    pub color: [f32; 3],
    pub parent: u32,
    /// Unit normal (zero when unknown).
    pub normal: [f32; 3],
    /// `[NONE, NONE]` for a leaf.
    pub children: [u32; 2],
    /// Bounding sphere `(center, radius)` of every vertex of the subtree and the triangles around leaves.
    pub sphere: [f32; 4],
    /// Normal cone `(axis, cos half-angle)` of the subtree's faces; `cos = -1` means every direction.
    pub cone: [f32; 4],
}

const _: () = assert!(std::mem::size_of::<Node>() == 84);

impl Node {
    pub fn is_leaf(&self) -> bool {
        self.children[0] == NONE
    }
    pub fn position(&self) -> Vec3 {
        Vec3::from_array(self.position)
    }
}

/// One page of a paged file (see [`Encoding::Paged`]): its root and its nodes, in increasing id.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PageNodes {
    pub root: u32,
    pub nodes: Vec<u32>,
}

/// A named part of the input scene (OBJ object or group), with its triangle count.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct PartInfo {
    pub name: String,
    pub triangles: u32,
}

#[derive(Clone, Debug, PartialEq)]
pub struct VertexTree {
    pub leaf_count: u32,
    pub nodes: Vec<Node>,
    /// Every input triangle as leaf indices, grouped by vanishing node (see [`VertexTree::vanishing`]).
    pub triangles: Vec<[u32; 3]>,
    /// `vanish_offsets[k]..vanish_offsets[k + 1]` are the triangles of internal node `leaf_count + k`.
    pub vanish_offsets: Vec<u32>,
    pub metric: Metric,
    pub has_colors: bool,
    pub has_normals: bool,
    /// From [`crate::mesh::Mesh::one_sided`]: the winding is meant, never flipped.
    pub one_sided: bool,
    pub parts: Vec<PartInfo>,
    /// Texture coordinates and base colour textures, when the input had them.
    pub appearance: Option<Appearance>,
    /// The input's materials and each node's, when it had them.
    pub materials: Option<Materials>,
    /// Per-corner appearance, when the input had texture coordinates or materials (see [`Wedges`]);
    /// `appearance` and `materials` then hold each node's first wedge's.
    pub wedges: Option<Wedges>,
    /// How far any stored position may lie from where the builder put it: 0 for a tree as built
    /// or read from an exact file, the quantisation's bound for one read from a paged file
    /// (versions 4 and 5). Every error and sphere already holds it; [`VertexTree::deviation_bounds`]
    /// adds it.
    pub position_error: f32,
    /// Whether the input's faces wind clockwise seen from outside, as a file records it (see
    /// [`VertexTree::winds_inward`]); `None` for a tree as built, or a file from before it was
    /// recorded.
    pub inward: Option<bool>,
}

/// Hugues Hoppe's wedges (*Efficient implementation of progressive meshes*, Computers & Graphics
/// 1998): the appearance of a vertex as its triangle corners see it. A vertex on a UV seam or a
/// material border is one node with several wedges, one per side, so that the seam is one line of
/// vertices at every cut and each side keeps its own texture coordinates.
///
/// Wedges form a forest parallel to the node tree: every wedge belongs to one node, and the wedges
/// of a merge's two children become the parent's, two joined into one where a triangle that
/// vanishes in the merge has one at each of its merging corners (they were one side of the seam).
/// A corner of a triangle drawn at node `u` shows the ancestor at `u` of the corner's leaf wedge.
///
/// Numbering: the input's vertices are the leaf wedges (`0..leaf_wedges`), then the internal
/// nodes' wedges in node order.
#[derive(Clone, Debug, PartialEq)]
pub struct Wedges {
    /// Each wedge's node.
    pub node: Vec<u32>,
    /// The wedge each becomes at its node's parent; [`NONE`] at the root.
    pub parent: Vec<u32>,
    pub uv: Vec<[f32; 2]>,
    /// An index into [`Appearance::textures`], or [`crate::mesh::NO_TEXTURE`].
    pub texture: Vec<u32>,
    /// An index into [`Materials::list`] (0 when the tree has no materials).
    pub material: Vec<u32>,
    /// Linear RGB: the material's factor, vertex colour and texture's mean around the wedge, as
    /// the builder weighs it and an untextured renderer draws it.
    pub color: Vec<[f32; 3]>,
    /// Unit normal, zero where the input had none (its node's normal stands in): the sides of a
    /// crease are wedges too, so a hard edge stays hard.
    pub normal: Vec<[f32; 3]>,
    /// Per triangle of [`VertexTree::triangles`], its corners' leaf wedges.
    pub corners: Vec<[u32; 3]>,
    /// Linear RGB the wedge's texture is multiplied by (the input's `COLOR_0` on a textured
    /// vertex; white on untextured ones, whose `color` has it); empty when nothing is tinted.
    pub tint: Vec<[f32; 3]>,
}

impl Wedges {
    pub fn len(&self) -> usize {
        self.node.len()
    }

    pub fn is_empty(&self) -> bool {
        self.node.is_empty()
    }

    /// The ancestor of leaf wedge `w` that belongs to node `u` (an ancestor of `w`'s leaf), by
    /// walking up; `None` if `u` is not on the way.
    pub fn at(&self, mut w: u32, u: u32) -> Option<u32> {
        while self.node[w as usize] != u {
            w = self.parent[w as usize];
            if w == NONE {
                return None;
            }
        }
        Some(w)
    }
}

/// A tree's materials (their textures index [`Appearance::textures`]) and each node's material:
/// its first wedge's (see [`Wedges`], which give each corner its own).
#[derive(Clone, Debug, PartialEq)]
pub struct Materials {
    pub list: Vec<crate::mesh::Material>,
    /// Per node, an index into `list`.
    pub of: Vec<u32>,
}

/// What a textured tree carries besides its nodes: per node, texture coordinates and a texture
/// (its first wedge's, see [`Wedges`]); and the textures' image files.
#[derive(Clone, Debug, PartialEq)]
pub struct Appearance {
    pub uvs: Vec<[f32; 2]>,
    /// An index into `textures`, or [`crate::mesh::NO_TEXTURE`].
    pub texture_of: Vec<u32>,
    /// Base colour textures, as their image files' bytes (PNG or JPEG, sRGB).
    pub textures: Vec<std::sync::Arc<Vec<u8>>>,
}

/// Relative widening of computed bounds, so that float rounding in the distances never lets a point
/// poke out.
const BOUND_SLACK: f32 = 1e-5;

impl VertexTree {
    pub fn root(&self) -> u32 {
        self.nodes.len() as u32 - 1
    }

    pub fn internal_count(&self) -> u32 {
        self.nodes.len() as u32 - self.leaf_count
    }

    /// The triangles that vanish when node `u`'s children merge (empty for a leaf).
    pub fn vanishing(&self, u: u32) -> &[[u32; 3]] {
        if u < self.leaf_count {
            return &[];
        }
        let k = (u - self.leaf_count) as usize;
        &self.triangles[self.vanish_offsets[k] as usize..self.vanish_offsets[k + 1] as usize]
    }

    /// A strict bound on how far each node's front strays from the input: for every node `u`, at
    /// least the distance from `u`'s position to every input vertex of its subtree, and at least its
    /// children's bounds (so it never decreases towards the root).
    ///
    /// Why it bounds the surface: on any front, a point `p = Σ βᵢ vᵢ` of an input triangle is drawn
    /// at `p' = Σ βᵢ g(vᵢ)` (Tao et al.'s vertex map, applied to the corners), and
    /// `|p − p'| ≤ Σ βᵢ |vᵢ − g(vᵢ)| ≤ maxᵢ bound(g(vᵢ))`. Every drawn triangle is the image of input
    /// triangles, so both one-sided distances, and with them the Hausdorff distance between the input
    /// and any front (its triangles, and the edges and points that input triangles collapse to), are
    /// at most the largest bound on the front. Unlike [`Node::error`], which *measures* deviation
    /// against the triangles around each merge (tighter, 1–3× below the Hausdorff distance it
    /// predicts), this one holds for every front, in any order; it is looser because it counts
    /// sliding along the surface as deviation.
    ///
    /// Computed, not stored: every leaf against each of its ancestors (leaves × depth distances,
    /// in parallel), about 90 ms for the dragon's 435,545 leaves on 2 cores.
    pub fn deviation_bounds(&self) -> Vec<f32> {
        use rayon::prelude::*;
        use std::sync::atomic::{AtomicU32, Ordering};
        // Non-negative floats order like their bit patterns, so an atomic integer max is a float max.
        let bits: Vec<AtomicU32> = (0..self.nodes.len()).map(|_| AtomicU32::new(0)).collect();
        (0..self.leaf_count).into_par_iter().for_each(|v| {
            let p = self.nodes[v as usize].position();
            let mut u = self.nodes[v as usize].parent;
            while u != NONE {
                let node = &self.nodes[u as usize];
                let d =
                    (p.distance(node.position()) + 2.0 * self.position_error) * (1.0 + BOUND_SLACK);
                bits[u as usize].fetch_max(d.to_bits(), Ordering::Relaxed);
                u = node.parent;
            }
        });
        let mut bound: Vec<f32> = bits
            .into_iter()
            .map(|b| f32::from_bits(b.into_inner()).max(self.position_error))
            .collect();
        // Children come before their parent in build order.
        for u in self.leaf_count as usize..self.nodes.len() {
            let [a, b] = self.nodes[u].children;
            bound[u] = bound[u].max(bound[a as usize]).max(bound[b as usize]);
        }
        bound
    }

    /// Depth of the tree: edges on the longest root-to-leaf path.
    pub fn depth(&self) -> u32 {
        let mut depth = vec![0u32; self.nodes.len()];
        let mut max = 0;
        for u in (0..self.nodes.len()).rev() {
            let p = self.nodes[u].parent;
            if p != NONE {
                depth[u] = depth[p as usize] + 1;
                max = max.max(depth[u]);
            }
        }
        max
    }

    /// Bounding-box diagonal of the leaves.
    pub fn diagonal(&self) -> f32 {
        if self.leaf_count == 0 {
            0.0
        } else {
            let (lo, hi) = self.leaf_box();
            crate::mesh::diagonal_of(hi - lo)
        }
    }

    /// The box of the leaves' positions (empty, lower corner at +∞, without leaves).
    pub fn leaf_box(&self) -> (Vec3, Vec3) {
        self.nodes[..self.leaf_count as usize]
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), n| {
                (lo.min(n.position()), hi.max(n.position()))
            })
    }
}

/// Centre and radius of a box (a radius of at least the smallest positive float, so that a
/// camera can always stand back from it).
pub fn sphere_of_box((lo, hi): (Vec3, Vec3)) -> (Vec3, f32) {
    (
        lo * 0.5 + hi * 0.5,
        (crate::mesh::diagonal_of(hi - lo) * 0.5).max(f32::MIN_POSITIVE),
    )
}

/// Whether the renderer and camera paths can work with a model of this diagonal: between
/// [`VIEWABLE_SCALE`]'s bounds. Outside them, a camera's projection underflows or overflows in
/// `f32` (a model 1e-30 across renders blank); the builder itself works at any scale.
pub fn check_viewable_diagonal(diagonal: f32) -> Result<(), ScaleError> {
    if (VIEWABLE_SCALE.0..=VIEWABLE_SCALE.1).contains(&diagonal) {
        Ok(())
    } else {
        Err(ScaleError { diagonal })
    }
}

impl VertexTree {
    /// Whether the input's faces wind clockwise seen from outside (negative signed volume, like
    /// the horse model), which the runtime's back-face test turns its cones for: as recorded in
    /// the file, else from the triangles. A one-sided mesh (a lit room, seen from inside) means
    /// its winding even when its volume is negative. Open meshes give a rough answer, decided
    /// once, when the tree is written, so that a reader of part of the tree (a streamed front)
    /// turns its cones as a reader of all of it does.
    pub fn winds_inward(&self) -> bool {
        self.inward
            .unwrap_or_else(|| !self.one_sided && signed_volume(&self.nodes, &self.triangles) < 0.0)
    }

    /// Centre and radius of the box around the leaves (see [`sphere_of_box`]).
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        sphere_of_box(self.leaf_box())
    }

    /// Whether the renderer and camera paths can work with this tree (see
    /// [`check_viewable_diagonal`]).
    pub fn check_viewable(&self) -> Result<(), ScaleError> {
        check_viewable_diagonal(self.diagonal())
    }

    /// Multiplies every length in the tree by `factor` (positions, spheres, errors), exactly when it is
    /// a power of two.
    pub(crate) fn scale_lengths(&mut self, factor: f32) {
        for n in &mut self.nodes {
            n.position = n.position.map(|x| x * factor);
            n.error *= factor;
            n.sphere = n.sphere.map(|x| x * factor);
        }
    }
}

/// The model sizes (bounding-box diagonal, in its own units) that can be viewed and rendered.
pub const VIEWABLE_SCALE: (f32, f32) = (1e-15, 1e15);

/// A model too small or too large to view (see [`VertexTree::check_viewable`]).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error(
    "the model is {diagonal:e} units across; vunify views and renders models from {:e} to {:e} units across: scale it into that range first",
    VIEWABLE_SCALE.0,
    VIEWABLE_SCALE.1
)]
pub struct ScaleError {
    pub diagonal: f32,
}

/// Why a model could not be opened as a tree.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error(transparent)]
    Tree(#[from] FormatError),
    #[error(transparent)]
    Mesh(#[from] crate::mesh::InputError),
    #[error("{path}: {source}")]
    Build {
        path: std::path::PathBuf,
        source: BuildError,
    },
}

/// Whether `path` names a `.vtree` file (by its extension).
pub fn is_tree_file(path: &std::path::Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("vtree"))
}

/// A model's tree: read from a `.vtree` file, or built with `options` from a mesh (.obj, .ply, .off,
/// optionally .xz; cleaned with the default options), reporting `(merges done, merges in all)`.
/// The command line and the viewer open models through this.
pub fn load_or_build(
    path: &std::path::Path,
    options: &BuildOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<VertexTree, LoadError> {
    if is_tree_file(path) {
        return Ok(read(path)?);
    }
    let (mesh, _) = crate::mesh::load(path, &crate::mesh::CleanOptions::default())?;
    let (tree, _) = build(&mesh, options, progress).map_err(|source| LoadError::Build {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(tree)
}

/// Six times the signed volume enclosed by the triangles (positive when they wind counter-clockwise
/// seen from outside).
fn signed_volume(nodes: &[Node], triangles: &[[u32; 3]]) -> f64 {
    use rayon::prelude::*;
    // Sums of fixed blocks, added in order: the same bits on any number of threads.
    let blocks: Vec<f64> = triangles
        .par_chunks(1 << 14)
        .map(|block| {
            block
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|v| nodes[v as usize].position().as_dvec3());
                    a.dot(b.cross(c))
                })
                .sum()
        })
        .collect();
    blocks.iter().sum()
}

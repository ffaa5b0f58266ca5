//! Opening models without stalling the frame: a `.vtree` is read, a mesh is built, on a background
//! thread that reports progress; built trees are cached in the user's cache directory, keyed by the
//! file's content and the build options.

use crate::refine::Hierarchy;
use crate::simplify::Metric;
use crate::vtree::{self, BuildOptions, VertexTree};
use glam::Vec3;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, channel};

/// A model ready to view.
pub struct Loaded {
    pub path: PathBuf,
    pub metric: Metric,
    /// What the panel and the comparison view read of the tree; the tree itself is dropped once
    /// the hierarchy is built (1.4 GB at 14 M triangles that nothing else reads).
    pub tree: TreeFacts,
    pub hierarchy: Arc<Hierarchy>,
    pub center: Vec3,
    pub radius: f32,
    /// Read from the cache rather than built.
    pub cached: bool,
    /// A tree flown from its file, not read whole (see [`stream_trees_within`]): its hierarchy
    /// is the part read so far, and changes as pages arrive.
    pub streamed: Option<Box<crate::refine::Streamed>>,
}

/// The memory (bytes) within which the viewer streams paged trees it opens from now on, instead
/// of reading them whole (`vunify view --cache SIZE`); `None`: read whole.
static STREAM_WITHIN: std::sync::Mutex<Option<u64>> = std::sync::Mutex::new(None);

/// Streams the paged trees opened from now on within `budget` bytes (see `vunify view --cache`),
/// or reads them whole (`None`).
pub fn stream_trees_within(budget: Option<u64>) {
    *STREAM_WITHIN.lock().unwrap_or_else(|e| e.into_inner()) = budget;
}

/// A paged tree opened for streaming within `budget` bytes: its pages take a third, the
/// runtime's hierarchy over them the rest.
fn load_streamed(path: &Path, metric: Metric, budget: u64) -> Result<Loaded, String> {
    let streamed = crate::refine::Streamed::open(path, budget / 3, Default::default())
        .map_err(|e| e.to_string())?;
    crate::vtree::check_viewable_diagonal(streamed.hierarchy().diagonal)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let file = crate::vtree::PagedFile::open(path).map_err(|e| e.to_string())?;
    let (center, radius) = streamed.sphere();
    Ok(Loaded {
        path: path.to_path_buf(),
        metric,
        tree: TreeFacts {
            triangles: file.triangles as usize,
            leaf_count: file.leaf_count,
            parts: file.parts.len(),
            build_order: Vec::new(),
            vanish_offsets: Vec::new(),
        },
        hierarchy: streamed.hierarchy_arc(),
        center,
        radius: radius.max(f32::MIN_POSITIVE),
        cached: false,
        streamed: Some(Box::new(streamed)),
    })
}

pub enum LoadMessage {
    /// Share done (0..1) and what is happening.
    Progress(f32, String),
    Done(Result<Loaded, String>),
}

/// Starts loading `path` (building its tree with `metric` if it is a mesh) on a new thread.
pub fn spawn_load(path: PathBuf, metric: Metric) -> Receiver<LoadMessage> {
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        let progress = tx.clone();
        let result = load(&path, metric, &mut |share, what| {
            let _ = progress.send(LoadMessage::Progress(share, what.to_string()));
        });
        let _ = tx.send(LoadMessage::Done(result));
    });
    rx
}

/// Starts simplifying the mesh at `path` within `epsilon` by `method` (a `simplify --method` name)
/// on a new thread; the result comes as a tree of its own, shown whole.
pub fn spawn_within(path: PathBuf, method: &'static str, epsilon: f64) -> Receiver<LoadMessage> {
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        let progress = tx.clone();
        let result = load_within(&path, method, epsilon, &mut |share, what| {
            let _ = progress.send(LoadMessage::Progress(share, what.to_string()));
        });
        let _ = tx.send(LoadMessage::Done(result));
    });
    rx
}

fn load_within(
    path: &Path,
    method: &str,
    epsilon: f64,
    progress: &mut dyn FnMut(f32, &str),
) -> Result<Loaded, String> {
    use crate::simplify::bounded::{BoundedOptions, simplify_bounded};
    use crate::simplify::envelope::{EnvelopeOptions, Method, simplify_envelope};
    let (mesh, _) = crate::mesh::load(path, &crate::mesh::CleanOptions::default())
        .map_err(|e| e.to_string())?;
    let total = mesh.triangle_count().max(1) as f32;
    let mut simplifying = |now: usize| progress(0.9 * (1.0 - now as f32 / total), "simplifying");
    let envelope = match method {
        "offset-patch" => Some(Method::OffsetPatch),
        "single-envelope" => Some(Method::SingleEnvelope),
        "cohen" => Some(Method::Cohen),
        _ => None,
    };
    let simplified = match envelope {
        Some(method) => {
            let options = EnvelopeOptions {
                method,
                epsilon,
                target_triangles: 0,
            };
            simplify_envelope(&mesh, &options, &mut simplifying).map(|r| r.0)
        }
        None => {
            let options = BoundedOptions {
                epsilon,
                target_triangles: 0,
            };
            simplify_bounded(&mesh, &options, &mut simplifying).map(|r| r.0)
        }
    }
    .map_err(|e| format!("{}: {e}", path.display()))?;
    let options = BuildOptions::default();
    let (tree, _) = vtree::build(&simplified, &options, &mut |_, _| {})
        .map_err(|e| format!("{}: {e}", path.display()))?;
    progress(1.0, "preparing the runtime");
    Ok(ready(path, options.metric, tree, false))
}

/// Loads synchronously (the background thread's body; scripts and tests call it directly).
pub fn load(
    path: &Path,
    metric: Metric,
    progress: &mut dyn FnMut(f32, &str),
) -> Result<Loaded, String> {
    let options = BuildOptions {
        metric,
        ..Default::default()
    };
    // A scene (OBJ whose materials emit) is lit first, once: the lit mesh is cached like a tree.
    let lit = if crate::radiosity::is_scene(path) {
        // Keyed by the scene and its materials.
        let mut bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            if entry.path().extension().is_some_and(|e| e == "mtl") {
                bytes.extend(std::fs::read(entry.path()).unwrap_or_default());
            }
        }
        let cached = cache_file(&bytes, metric).map(|c| c.with_extension("lit.ply"));
        let out = cached.unwrap_or_else(|| std::env::temp_dir().join("vunify-lit.ply"));
        if !out.exists() {
            if let Some(dir) = out.parent() {
                let _ = std::fs::create_dir_all(dir);
            }
            crate::radiosity::light(path, &out, &mut |share, what| {
                progress(share as f32, &format!("lighting the scene: {what}"))
            })?;
        }
        Some(out)
    } else {
        None
    };
    let shown = path;
    let path = lit.as_deref().unwrap_or(path);
    let mut build_progress = |done: usize, total: usize| {
        progress(
            done as f32 / total.max(1) as f32,
            "building the vertex tree",
        )
    };
    let within = *STREAM_WITHIN.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(budget) = within.filter(|_| path.extension().is_some_and(|e| e == "vtree")) {
        progress(0.5, "opening the tree's pages");
        return load_streamed(path, metric, budget);
    }
    let (tree, cached) = if vtree::is_tree_file(path) {
        (
            vtree::load_or_build(path, &options, &mut build_progress).map_err(|e| e.to_string())?,
            false,
        )
    } else {
        let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let cache = cache_file(&bytes, metric);
        match cache.as_deref().and_then(|c| vtree::read(c).ok()) {
            Some(tree) => (tree, true),
            None => {
                let tree = vtree::load_or_build(path, &options, &mut build_progress)
                    .map_err(|e| e.to_string())?;
                if let Some(c) = &cache {
                    if let Some(dir) = c.parent() {
                        let _ = std::fs::create_dir_all(dir);
                    }
                    let _ = vtree::write(&tree, c);
                }
                (tree, false)
            }
        }
    };
    tree.check_viewable()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    progress(1.0, "preparing the runtime");
    Ok(ready(shown, metric, tree, cached))
}

/// The tree's counts, and its build order for the comparison view's static cuts.
pub struct TreeFacts {
    pub triangles: usize,
    pub leaf_count: u32,
    pub parts: usize,
    /// The internal nodes in the order the build made them, in the hierarchy's numbering.
    pub build_order: Vec<u32>,
    /// How many triangles had vanished after each merge ([`VertexTree::vanish_offsets`]).
    pub vanish_offsets: Vec<u32>,
}

impl TreeFacts {
    /// What the viewer keeps of `tree` (its vanish offsets taken).
    fn of(tree: &mut VertexTree) -> TreeFacts {
        let renumber = Hierarchy::renumbering(tree);
        TreeFacts {
            triangles: tree.triangles.len(),
            leaf_count: tree.leaf_count,
            parts: tree.parts.len(),
            build_order: (tree.leaf_count..tree.nodes.len() as u32)
                .map(|u| renumber[u as usize])
                .collect(),
            vanish_offsets: std::mem::take(&mut tree.vanish_offsets),
        }
    }
}

fn ready(path: &Path, metric: Metric, mut tree: VertexTree, cached: bool) -> Loaded {
    let facts = TreeFacts::of(&mut tree);
    let hierarchy = Hierarchy::from_tree(tree);
    let leaves = &hierarchy.position[..hierarchy.leaf_count as usize];
    let lo = leaves.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
    let hi = leaves.iter().fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
    Loaded {
        path: path.to_path_buf(),
        metric,
        tree: facts,
        hierarchy: Arc::new(hierarchy),
        center: (lo + hi) * 0.5,
        radius: ((hi - lo).length() * 0.5).max(f32::MIN_POSITIVE),
        cached,
        streamed: None,
    }
}

/// Where the tree of a mesh with these bytes, built with `metric` and default options by this
/// version of vunify, is cached.
fn cache_file(bytes: &[u8], metric: Metric) -> Option<PathBuf> {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    bytes.hash(&mut h);
    format!(
        "{:?}",
        BuildOptions {
            metric,
            ..Default::default()
        }
    )
    .hash(&mut h);
    env!("CARGO_PKG_VERSION").hash(&mut h);
    vtree::FORMAT_VERSION.hash(&mut h);
    Some(dirs::cache_dir()?.join("vunify").join(format!(
        "{:016x}-{}.vtree",
        h.finish(),
        metric.name()
    )))
}

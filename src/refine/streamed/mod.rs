//! A tree flown without reading all of it (docs/RUNTIME.md, "A streamed tree"): the runtime
//! refines over the pages read so far, asks for the pages the view wants, and takes them in
//! when they have arrived, so that a frame never waits for the disk.
//!
//! # The part that is read
//! The runtime's hierarchy is built over a *part* of the tree ([`part`]): the nodes on and above
//! the front, and below them what the view may split soon; its leaves are the tree's leaves it
//! reached and *stand-ins*, nodes whose children are left out or not read yet, which draw as one
//! vertex and cannot split.
//!
//! # Taking pages in
//! Pages arrive on the cache's reader threads. When some have arrived, the next part is built on
//! another thread, from the resident pages and the front as it is then (each front node's
//! leaves, which name it in any part that holds it, or its nearest ancestor there). The frames go
//! on over the old part meanwhile; once the new one is ready it replaces the old, and the front
//! goes on from the cut it was built at, which the next frames adapt as they always do.
//!
//! # Asking for pages
//! Each frame every stand-in on the front is weighed by the same tests as a node of the
//! hierarchy (its turn as the page records it, version 6, or bounded from its normal cone): one
//! in view whose projected error is above τ asks for the pages of its children, its projected
//! error the priority (as Nexus orders its requests), so that what the user looks at sharpens
//! first. The cache never lets go a page the front stands in or above, keeps of each page what
//! parts use, and reads a page whole again when the view wants more of it.

mod part;

use super::adapt::{FrameStats, Refiner, Settings};
use super::cache::{CacheStats, PageCache, PageSource};
use super::criteria::{Camera, View};
use super::front::Front;
use super::hierarchy::{Hierarchy, stand_in_bounds};
use crate::vtree::{DecodedPage, FormatError, NONE, PagedFile, VertexTree};
use glam::Vec3;
pub use part::Part;
use part::{Kept, Meta, TRIM_MARGIN, Trim, build_part, turn_at};
use rustc_hash::FxHashMap;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, TryRecvError, channel};

/// Why a tree cannot be streamed.
#[derive(Debug, thiserror::Error)]
pub enum StreamError {
    #[error(transparent)]
    Format(#[from] FormatError),
    #[error(
        "{0}: format version 4 keeps the input's order of leaves; rebuild it with `vunify build` to stream it"
    )]
    OldVersion(String),
    #[error(
        "{0}: textures, materials and per-corner appearance are not streamed yet; view it without --cache"
    )]
    Appearance(String),
    #[error("{0}: its root's page is not readable: {1}")]
    Root(String, String),
}

/// How many nodes the first part holds at least (when the tree has them): the pages nearest
/// the root, read before the first frame, so that it draws the model coarsely rather than a
/// root page's few nodes.
const FIRST_NODES: usize = 1 << 15;

/// The pages nearest the root (level by level, each level read on every core) until they hold
/// [`FIRST_NODES`]. One that cannot be read is left out here: the cache reports it when the view
/// asks for it.
fn first_pages(
    file: &PagedFile,
    page_of_root: &FxHashMap<u32, u32>,
    root_page: u32,
    root: DecodedPage,
) -> Vec<(u32, Arc<DecodedPage>)> {
    use rayon::prelude::*;
    let mut pages = vec![(root_page, Arc::new(root))];
    let mut level = vec![0usize];
    let mut nodes = pages[0].1.ids.len();
    while nodes < FIRST_NODES && !level.is_empty() {
        let below: Vec<u32> = (level.iter())
            .flat_map(|&k| {
                let page = &pages[k].1;
                (page.nodes.iter())
                    .flat_map(|n| n.children)
                    .filter(|c| *c != NONE && page.ids.binary_search(c).is_err())
                    .filter_map(|c| page_of_root.get(&c).copied())
                    .collect::<Vec<_>>()
            })
            .collect();
        let read: Vec<(u32, DecodedPage)> = (below.par_iter())
            .filter_map(|&p| Some((p, file.read_page(p as usize).ok()?)))
            .collect();
        level = (pages.len()..pages.len() + read.len()).collect();
        for (p, page) in read {
            nodes += page.ids.len();
            pages.push((p, Arc::new(page)));
        }
    }
    pages
}

/// A part being built on another thread, with the front it will start from.
type Building = Receiver<Option<(Part, Refiner, Vec<Kept>)>>;

/// A tree flown from its file: the part read so far, the runtime over it, and the cache that
/// reads the rest (see the module's text).
pub struct Streamed {
    meta: Meta,
    cache: PageCache,
    part: Part,
    refiner: Refiner,
    settings: Settings,
    building: Option<Building>,
    /// The cache's count of arrived pages when the part being built (or the current one) was
    /// begun: a part is built again once more have arrived.
    loaded_then: u64,
    /// Pages resident when the part being built began that the current part lacks, or that the
    /// front stood in: kept resident until it is taken in, so that the front can step into them
    /// (and start from where it was).
    arriving: Vec<u32>,
    /// The same for the part taken in last, until the front has had a frame to step into them
    /// and be pinned there.
    arrived: Vec<u32>,
    /// A part was taken in since the front was last pinned.
    taken: bool,
    /// The last frame's camera and τ: what the next part is trimmed for.
    seen: Option<(Camera, f32)>,
    /// A page the view wants is resident but not in the part: the next part should have it.
    stale: bool,
    failures: Vec<(u32, FormatError)>,
    /// Parts taken in since the tree opened (the first included).
    pub parts: u64,
}

/// What [`Streamed::update`] did besides adapting the front.
#[derive(Clone, Copy, Debug, Default)]
pub struct StreamFrame {
    pub stats: FrameStats,
    /// The part, and so the hierarchy, is new: a renderer uploads it again.
    pub new_part: bool,
    pub cache: CacheStats,
}

impl Streamed {
    /// Opens a paged file for streaming within `budget` bytes of pages (see
    /// [`Streamed::new`]).
    pub fn open(
        path: &std::path::Path,
        budget: u64,
        settings: Settings,
    ) -> Result<Streamed, StreamError> {
        let file = PagedFile::open(path)?;
        Streamed::new(Arc::new(file), budget, settings)
    }

    /// A runtime over `file`'s root page alone, read now (the first frame draws it); the
    /// rest is read as the view asks for it, within `budget` bytes of decoded pages (pinned
    /// pages may hold more). The runtime's hierarchy over the pages is about as large again.
    pub fn new(
        file: Arc<PagedFile>,
        budget: u64,
        settings: Settings,
    ) -> Result<Streamed, StreamError> {
        let source: Arc<dyn PageSource> = file.clone();
        Streamed::with_source(file, source, budget, settings)
    }

    /// [`Streamed::new`] with the pages after the root's read from `source` (in tests, a disk
    /// that is slow or delivers in any order).
    pub fn with_source(
        file: Arc<PagedFile>,
        source: Arc<dyn PageSource>,
        budget: u64,
        settings: Settings,
    ) -> Result<Streamed, StreamError> {
        let name = file.path().display().to_string();
        if !file.leaves_depth_first() {
            return Err(StreamError::OldVersion(name));
        }
        if file.appearance {
            return Err(StreamError::Appearance(name));
        }
        let page_of_root = Arc::new(file.page_of_root());
        let root_page = file.entries.len() as u32 - 1;
        let root = file
            .read_page(root_page as usize)
            .map_err(|e| StreamError::Root(name.clone(), e.to_string()))?;
        let mut meta = Meta {
            leaf_count: file.leaf_count,
            node_count: file.node_count,
            page_of_root,
            tree: VertexTree {
                leaf_count: 0,
                nodes: Vec::new(),
                triangles: Vec::new(),
                vanish_offsets: Vec::new(),
                metric: file.metric,
                has_colors: file.has_colors,
                has_normals: file.has_normals,
                one_sided: file.one_sided,
                parts: file.parts.clone(),
                appearance: None,
                materials: None,
                wedges: None,
                position_error: file.position_error,
                inward: file.inward,
            },
            inward: None,
            // The root's sphere holds every leaf: its diameter stands for the leaves' box's
            // diagonal, which only reading every page would give.
            diagonal: root.nodes.last().map_or(1.0, |n| 2.0 * n.sphere[3]),
            sphere: root.nodes.last().map_or((Vec3::ZERO, 1.0), |n| {
                (Vec3::from_slice(&n.sphere), n.sphere[3])
            }),
        };
        let pages = first_pages(&file, &meta.page_of_root, root_page, root);
        let (part, inward, _) = build_part(&meta, &pages, None).ok_or_else(|| {
            StreamError::Root(name, "the root's page does not hold the root".into())
        })?;
        meta.inward = Some(inward);
        let refiner = Refiner::new(&part.h, settings);
        let readers = std::thread::available_parallelism().map_or(1, |n| n.get());
        let mut cache = PageCache::with_readers(source, budget, readers);
        for (p, page) in pages {
            cache.adopt(p, page);
        }
        let mut streamed = Streamed {
            meta,
            cache,
            part,
            refiner,
            settings,
            building: None,
            loaded_then: 0,
            arriving: Vec::new(),
            arrived: Vec::new(),
            taken: false,
            seen: None,
            stale: false,
            failures: Vec::new(),
            parts: 1,
        };
        streamed.loaded_then = streamed.cache.stats().loaded + streamed.cache.stats().rereads;
        Ok(streamed)
    }

    /// The whole tree's bounding sphere (its root's).
    pub fn sphere(&self) -> (Vec3, f32) {
        self.meta.sphere
    }

    /// The hierarchy the front is a cut of now.
    pub fn hierarchy(&self) -> &Hierarchy {
        &self.part.h
    }

    /// [`Streamed::hierarchy`], shared.
    pub fn hierarchy_arc(&self) -> Arc<Hierarchy> {
        self.part.h.clone()
    }

    /// The runtime's settings from now on.
    pub fn set_settings(&mut self, settings: Settings) {
        self.settings = settings;
        self.refiner.settings = settings;
    }

    pub fn part(&self) -> &Part {
        &self.part
    }

    pub fn front(&self) -> &Front {
        &self.refiner.front
    }

    /// The refiner over [`Streamed::hierarchy`].
    pub fn refiner(&self) -> &Refiner {
        &self.refiner
    }

    /// The hierarchy, the front and this frame's vertex updates: what a renderer uploads.
    pub fn output(&mut self) -> (&Hierarchy, &mut Front, &[(u32, Vec3)]) {
        let (front, moved) = self.refiner.output();
        (&self.part.h, front, moved)
    }

    /// Whether page `p` is in the cache now.
    pub fn is_resident(&self, p: u32) -> bool {
        self.cache.is_resident(p)
    }

    pub fn cache_stats(&self) -> CacheStats {
        self.cache.stats()
    }

    /// Pages that could not be read since the last call (each once), with why.
    pub fn take_failures(&mut self) -> Vec<(u32, FormatError)> {
        std::mem::take(&mut self.failures)
    }

    /// Adapts the front to one frame seen from `camera`: takes in a part that is ready, adapts,
    /// asks for the pages the view wants, and begins the next part when pages have arrived.
    /// Never waits for the disk or for a part.
    pub fn update(&mut self, camera: &Camera) -> StreamFrame {
        let new_part = self.take_part(false);
        let stats = self.refiner.update(&self.part.h, camera);
        self.seen = Some((*camera, stats.tolerance_px));
        if std::mem::take(&mut self.taken) {
            // The front has stepped into the new part's pages it wants: the others may go.
            for p in self.arrived.drain(..) {
                self.cache.unpin(p);
            }
        }
        let (part, front) = (&self.part, &self.refiner.front);
        let failures = self.cache.receive_keeping(&|p| part.in_use(p, front));
        self.failures.extend(failures);
        self.ask(camera, stats.tolerance_px);
        self.begin_part();
        StreamFrame {
            stats,
            new_part,
            cache: self.cache.stats(),
        }
    }

    /// Before a first frame seen from `camera`: adapts and waits for what it asks for, part
    /// after part, until nothing more is asked for or `limit` has passed (then the frames go on
    /// from there, and sharpen as the rest arrives).
    pub fn prepare(&mut self, camera: &Camera, limit: std::time::Duration) {
        let start = std::time::Instant::now();
        while start.elapsed() < limit {
            self.update(camera);
            if !self.settle() {
                break;
            }
        }
    }

    /// Waits until what has been asked for has arrived and a part holding it is taken in (for
    /// tests and tools, not for a frame): returns whether anything changed.
    pub fn settle(&mut self) -> bool {
        let (part, front) = (&self.part, &self.refiner.front);
        let failures = self
            .cache
            .receive_waiting_keeping(&|p| part.in_use(p, front));
        self.failures.extend(failures);
        let mut changed = self.take_part(true);
        self.begin_part();
        changed |= self.take_part(true);
        changed
    }

    /// Takes in the part being built when it is ready (`wait`: waits for it).
    fn take_part(&mut self, wait: bool) -> bool {
        let Some(building) = &self.building else {
            return false;
        };
        let ready = if wait {
            building.recv().map_err(|_| TryRecvError::Disconnected)
        } else {
            building.try_recv()
        };
        match ready {
            Err(TryRecvError::Empty) => false,
            Err(TryRecvError::Disconnected) | Ok(None) => {
                self.building = None;
                false
            }
            Ok(Some((part, refiner, kept))) => {
                self.building = None;
                // The cache keeps of each page what the part uses; the rest is read again
                // when the view wants it.
                for (p, was, kept) in kept {
                    self.cache.keep_only(p, &was, kept);
                }
                self.arrived.append(&mut self.arriving);
                self.taken = true;
                self.part = part;
                self.refiner = refiner;
                self.parts += 1;
                true
            }
        }
    }

    /// Begins building a new part when pages have arrived since the last one began.
    fn begin_part(&mut self) {
        let loaded = self.cache.stats().loaded + self.cache.stats().rereads;
        if self.building.is_some() || (loaded == self.loaded_then && !self.stale) {
            return;
        }
        self.loaded_then = loaded;
        self.stale = false;
        let pages = self.cache.resident();
        // Until the new part is taken in and the front has had a frame in it, its pages that
        // are new, and those the front stands in now (it starts again from this cut), stay.
        let front = &self.refiner.front;
        for &(p, _) in &pages {
            if (!self.part.has_page(p) || self.part.in_use(p, front)) && self.cache.pin(p) {
                self.arriving.push(p);
            }
        }
        let mut cut: Vec<[u32; 2]> = self
            .refiner
            .front
            .active()
            .into_iter()
            .map(|u| self.part.whole_range(u))
            .collect();
        cut.sort_unstable();
        let trim = self.seen.map(|(camera, tau)| Trim {
            view: View::new(&camera),
            tests: self.settings.tests,
            tau: tau / TRIM_MARGIN,
            cut: cut.clone(),
            inward: self.meta.inward.unwrap_or(false),
        });
        let (meta, settings) = (self.meta.clone(), self.settings);
        let (send, receive) = channel();
        self.building = Some(receive);
        std::thread::Builder::new()
            .name("vunify-part".into())
            .spawn(move || {
                let built = build_part(&meta, &pages, trim.as_ref()).map(|(part, _, kept)| {
                    let at = part.cut_at(&cut);
                    let front = Front::at_cut(&part.h, &at).expect("a cut of the part");
                    let refiner = Refiner::starting_from(&part.h, front, settings);
                    (part, refiner, kept)
                });
                let _ = send.send(built);
            })
            .expect("a thread starts");
    }

    /// Asks for the pages that the stand-ins on the front want to split into.
    fn ask(&mut self, camera: &Camera, tau: f32) {
        let view = View::new(camera);
        let tests = self.settings.tests;
        let mut wanted: Vec<(u32, f32)> = Vec::new();
        for s in &self.part.stand_ins {
            if !self.refiner.front.is_active(s.leaf) {
                continue;
            }
            let n = tests.view_of(&s.bounds, s.center);
            if tests.sees(&view, &n) {
                let px = tests.projected(&view, &n);
                if px > tau {
                    let wants = s.wants.into_iter().filter(|&p| p != NONE);
                    // All there: the next part splits it (a page that cannot be read never is).
                    self.stale |= wants.clone().all(|p| self.cache.is_whole(p));
                    for p in wants {
                        if self.cache.is_resident(p) && !self.cache.is_whole(p) {
                            self.cache.reread(p, px);
                        } else {
                            wanted.push((p, px));
                        }
                    }
                }
            }
        }
        // A wanted page that has arrived but is not in the part yet is looked into at once:
        // the pages below it that the view wants are asked for now, not a part later.
        let inward = self.meta.inward.unwrap_or(false);
        let mut looked: rustc_hash::FxHashSet<u32> = Default::default();
        while let Some((p, px)) = wanted.pop() {
            self.cache.request(p, px);
            if self.part.has_page(p) || !looked.insert(p) {
                continue;
            }
            let Some(page) = self.cache.get(p) else {
                continue;
            };
            for (i, (&id, node)) in page.ids.iter().zip(&page.nodes).enumerate() {
                if id < self.meta.leaf_count {
                    continue;
                }
                let outside = node
                    .children
                    .map(|c| page.ids.binary_search(&c).is_err().then_some(c));
                if outside == [None, None] {
                    continue;
                }
                let bounds = stand_in_bounds(node, turn_at(&page, i), inward);
                let n = tests.view_of(&bounds, node.position());
                let px = tests.projected(&view, &n);
                if px > tau && tests.sees(&view, &n) {
                    for c in outside.into_iter().flatten() {
                        if let Some(&q) = self.meta.page_of_root.get(&c) {
                            wanted.push((q, px));
                        }
                    }
                }
            }
        }
    }
}

//! Pages of a paged tree fetched on demand into a cache with a budget (see docs/RUNTIME.md, "A
//! streamed tree"): the part of the streamed runtime (`refine::streamed`) that reads, checks and
//! keeps pages.
//!
//! The frame's thread asks for pages ([`PageCache::request`], with a priority: the projected
//! error of the front entries that need the page, as Nexus orders its requests) and takes what has
//! arrived ([`PageCache::receive`]); neither waits for the disk. One reader thread fetches the
//! most wanted page first (priorities may change while a page waits), decodes and checks it, and
//! hands it over. Resident pages count their bytes against the budget; once over it, the least
//! recently used pages that nothing pins (a front entry in the page, or a resident page below it)
//! are let go. A page that cannot be read or is corrupt is reported once and never asked for again:
//! the front stays coarse there.

use crate::vtree::{DecodedPage, FormatError, PagedFile};
use std::collections::{BinaryHeap, HashMap};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Condvar, Mutex};

/// Where pages come from: a [`PagedFile`], or in tests a file read slowly or out of order.
pub trait PageSource: Send + Sync {
    fn pages(&self) -> usize;
    fn fetch(&self, page: usize) -> Result<DecodedPage, FormatError>;
}

impl PageSource for PagedFile {
    fn pages(&self) -> usize {
        self.entries.len()
    }
    fn fetch(&self, page: usize) -> Result<DecodedPage, FormatError> {
        self.read_page(page)
    }
}

/// What the cache holds and has done, for the panel and `render`'s statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct CacheStats {
    pub resident_bytes: u64,
    pub budget: u64,
    pub resident_pages: usize,
    /// Pages asked for and not arrived yet.
    pub pending: usize,
    /// Pages that arrived, evicted, and could not be read, since the cache opened.
    pub loaded: u64,
    /// The bytes of the pages that arrived, decoded, since the cache opened.
    pub loaded_bytes: u64,
    /// Pages of which only some nodes were kept read whole again (not counted in `loaded`).
    pub rereads: u64,
    pub evicted: u64,
    pub failed: u64,
}

enum Slot {
    Absent,
    Pending,
    Resident {
        page: Arc<DecodedPage>,
        bytes: u64,
        /// The [`PageCache::clock`] when it was last asked for or read.
        used: u64,
        pins: u32,
        /// Only some of its nodes are kept (see [`PageCache::keep_only`]), and whether it is
        /// being read again whole (or could not be).
        part: Option<Rereading>,
    },
    Failed,
}

/// The requests the reader takes from: each waiting page's current priority (its bits), and a
/// heap that may hold stale entries (a page asked for again with another priority), skipped when
/// popped. A page the reader has taken is no longer `wanted`.
#[derive(Default)]
struct Queue {
    wanted: HashMap<u32, u32>,
    heap: BinaryHeap<Request>,
    stop: bool,
}

/// A page asked for with a priority: the heap's greatest is the highest priority (NaN lowest),
/// the lower page among equals.
#[derive(Clone, Copy, Debug)]
struct Request {
    priority: f32,
    page: u32,
}

impl Ord for Request {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        let key = |p: f32| if p.is_nan() { f32::NEG_INFINITY } else { p };
        key(self.priority)
            .total_cmp(&key(o.priority))
            .then(o.page.cmp(&self.page))
    }
}
impl PartialOrd for Request {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl PartialEq for Request {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o).is_eq()
    }
}
impl Eq for Request {}

/// A page of which only some nodes are kept: whether the whole is being read again.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Rereading {
    No,
    Asked,
    /// Reading it again failed: it stays as it is.
    Failed,
}

struct Shared {
    queue: Mutex<Queue>,
    wake: Condvar,
}

/// A page that arrived, or why it could not.
type Arrival = (u32, Result<DecodedPage, FormatError>);

pub struct PageCache {
    shared: Arc<Shared>,
    arrivals: Receiver<Arrival>,
    slots: Vec<Slot>,
    clock: u64,
    stats: CacheStats,
}

impl PageCache {
    /// A cache of `source`'s pages within `budget` bytes (pinned pages may hold more), with its
    /// reader thread started.
    pub fn new(source: Arc<dyn PageSource>, budget: u64) -> PageCache {
        PageCache::with_readers(source, budget, 1)
    }

    /// [`PageCache::new`] with `readers` threads reading (and decoding, which is most of a read)
    /// at once, each taking the most wanted page left: what a streaming front uses, one a core.
    pub fn with_readers(source: Arc<dyn PageSource>, budget: u64, readers: usize) -> PageCache {
        let shared = Arc::new(Shared {
            queue: Mutex::new(Queue::default()),
            wake: Condvar::new(),
        });
        let (send, arrivals) = channel();
        for _ in 0..readers.max(1) {
            let (shared, source, send) = (shared.clone(), source.clone(), send.clone());
            // Never joined (see `Drop`): it ends when the cache is let go.
            std::thread::Builder::new()
                .name("vunify-pages".into())
                .spawn(move || read_pages(&shared, source.as_ref(), &send))
                .expect("a thread starts");
        }
        PageCache {
            shared,
            arrivals,
            slots: (0..source.pages()).map(|_| Slot::Absent).collect(),
            clock: 0,
            stats: CacheStats {
                budget,
                ..Default::default()
            },
        }
    }

    /// Asks for `page` with `priority` (higher first): a page not resident is queued, or its place
    /// in the queue moves; a resident one counts as used now. Never waits.
    pub fn request(&mut self, page: u32, priority: f32) {
        self.clock += 1;
        let Some(slot) = self.slots.get_mut(page as usize) else {
            return;
        };
        match slot {
            Slot::Resident { used, .. } => *used = self.clock,
            Slot::Failed => {}
            Slot::Absent => {
                *slot = Slot::Pending;
                self.stats.pending += 1;
                self.enqueue(page, priority);
            }
            Slot::Pending => self.requeue(page, priority),
        }
    }

    /// Takes the pages that have arrived (never waiting), lets the least recently used unpinned
    /// ones go while the cache is over its budget (not those that just arrived), and returns the
    /// errors of pages that could not be read (each once).
    pub fn receive(&mut self) -> Vec<(u32, FormatError)> {
        self.receive_keeping(&|_| false)
    }

    /// [`PageCache::receive`], never letting go a page for which `keep` holds (one a front
    /// stands in, asked when the cache would let it go).
    pub fn receive_keeping(&mut self, keep: &dyn Fn(u32) -> bool) -> Vec<(u32, FormatError)> {
        let before = self.clock;
        let mut failures = Vec::new();
        while let Ok((page, result)) = self.arrivals.try_recv() {
            self.arrive(page, result, &mut failures);
        }
        self.evict(before, keep);
        failures
    }

    /// Like [`PageCache::receive`], first waiting for one arrival while any page is pending (for
    /// tools and tests that read a tree through the cache, not for a frame).
    pub fn receive_waiting(&mut self) -> Vec<(u32, FormatError)> {
        self.receive_waiting_keeping(&|_| false)
    }

    /// [`PageCache::receive_waiting`] with [`PageCache::receive_keeping`]'s `keep`.
    pub fn receive_waiting_keeping(
        &mut self,
        keep: &dyn Fn(u32) -> bool,
    ) -> Vec<(u32, FormatError)> {
        let before = self.clock;
        let mut failures = Vec::new();
        if self.stats.pending > 0
            && let Ok((page, result)) = self.arrivals.recv()
        {
            self.arrive(page, result, &mut failures);
        }
        while let Ok((page, result)) = self.arrivals.try_recv() {
            self.arrive(page, result, &mut failures);
        }
        self.evict(before, keep);
        failures
    }

    fn arrive(
        &mut self,
        page: u32,
        result: Result<DecodedPage, FormatError>,
        failures: &mut Vec<(u32, FormatError)>,
    ) {
        self.clock += 1;
        let slot = &mut self.slots[page as usize];
        if matches!(slot, Slot::Pending) {
            self.stats.pending -= 1;
        }
        if let Slot::Resident {
            page: kept,
            bytes,
            used,
            part,
            ..
        } = slot
        {
            // A page read again whole replaces the part of it that was kept.
            if *part == Some(Rereading::Asked) {
                self.stats.pending -= 1;
                match result {
                    Ok(p) => {
                        let whole = p.bytes();
                        self.stats.rereads += 1;
                        self.stats.loaded_bytes += whole;
                        self.stats.resident_bytes += whole - *bytes;
                        (*kept, *bytes, *used, *part) = (Arc::new(p), whole, self.clock, None);
                    }
                    Err(e) => {
                        self.stats.failed += 1;
                        failures.push((page, e));
                        *part = Some(Rereading::Failed);
                    }
                }
            }
            return;
        }
        *slot = match result {
            Ok(p) => {
                let bytes = p.bytes();
                self.stats.loaded += 1;
                self.stats.loaded_bytes += bytes;
                self.stats.resident_bytes += bytes;
                self.stats.resident_pages += 1;
                Slot::Resident {
                    page: Arc::new(p),
                    bytes,
                    used: self.clock,
                    pins: 0,
                    part: None,
                }
            }
            Err(e) => {
                self.stats.failed += 1;
                failures.push((page, e));
                Slot::Failed
            }
        };
    }

    /// Lets the least recently used unpinned pages go until the cache is within its budget, never
    /// one used after `clock` (a page that has just arrived stays until the front could pin it).
    fn evict(&mut self, clock: u64, keep: &dyn Fn(u32) -> bool) {
        if self.stats.resident_bytes <= self.stats.budget {
            return;
        }
        let mut idle: Vec<(u64, usize)> = self
            .slots
            .iter()
            .enumerate()
            .filter_map(|(p, s)| match s {
                Slot::Resident { used, pins: 0, .. } if *used <= clock => Some((*used, p)),
                _ => None,
            })
            .collect();
        idle.sort_unstable();
        for (_, p) in idle {
            if self.stats.resident_bytes <= self.stats.budget {
                break;
            }
            if keep(p as u32) {
                continue;
            }
            if let Slot::Resident { bytes, part, .. } =
                std::mem::replace(&mut self.slots[p], Slot::Absent)
            {
                // Its whole, still being read, arrives into an empty slot.
                if part == Some(Rereading::Asked) {
                    self.stats.pending -= 1;
                }
                self.stats.resident_bytes -= bytes;
                self.stats.resident_pages -= 1;
                self.stats.evicted += 1;
            }
        }
    }

    /// Page `page` when it is resident (counted as used now).
    pub fn get(&mut self, page: u32) -> Option<Arc<DecodedPage>> {
        self.clock += 1;
        match self.slots.get_mut(page as usize)? {
            Slot::Resident { page, used, .. } => {
                *used = self.clock;
                Some(page.clone())
            }
            _ => None,
        }
    }

    /// Takes in `page`, read elsewhere (a runtime reads its first page itself, before the first
    /// frame), as if it had arrived.
    pub fn adopt(&mut self, page: u32, decoded: Arc<DecodedPage>) {
        if page as usize >= self.slots.len() || self.is_resident(page) {
            return;
        }
        if matches!(self.slots[page as usize], Slot::Pending) {
            self.stats.pending -= 1;
        }
        self.clock += 1;
        let bytes = decoded.bytes();
        self.stats.loaded += 1;
        self.stats.loaded_bytes += bytes;
        self.stats.resident_bytes += bytes;
        self.stats.resident_pages += 1;
        self.slots[page as usize] = Slot::Resident {
            page: decoded,
            bytes,
            used: self.clock,
            pins: 0,
            part: None,
        };
    }

    /// Keeps only `kept` of a resident page read whole (the nodes a reader uses of it; see
    /// [`DecodedPage::keep`]), counting its bytes instead.
    /// Nothing changes unless the page is still `was` (not let go and read again since).
    pub fn keep_only(&mut self, page: u32, was: &Arc<DecodedPage>, kept: Arc<DecodedPage>) {
        if let Some(Slot::Resident {
            page: held,
            bytes,
            part: part @ None,
            ..
        }) = self.slots.get_mut(page as usize)
            && Arc::ptr_eq(held, was)
        {
            let less = kept.bytes();
            self.stats.resident_bytes -= *bytes - less.min(*bytes);
            (*held, *bytes, *part) = (kept, less.min(*bytes), Some(Rereading::No));
        }
    }

    /// Whether `page` is resident with all its nodes.
    pub fn is_whole(&self, page: u32) -> bool {
        matches!(
            self.slots.get(page as usize),
            Some(Slot::Resident { part: None, .. })
        )
    }

    /// Asks for `page` whole again (it is resident with only some of its nodes kept), with
    /// `priority`, as [`PageCache::request`] asks for a page not resident. Never waits.
    pub fn reread(&mut self, page: u32, priority: f32) {
        self.clock += 1;
        let Some(Slot::Resident { part, used, .. }) = self.slots.get_mut(page as usize) else {
            return;
        };
        *used = self.clock;
        match *part {
            Some(Rereading::No) => {
                *part = Some(Rereading::Asked);
                self.stats.pending += 1;
                self.enqueue(page, priority);
            }
            Some(Rereading::Asked) => self.requeue(page, priority),
            _ => {}
        }
    }

    fn enqueue(&self, page: u32, priority: f32) {
        let mut q = self.lock();
        q.wanted.insert(page, priority.to_bits());
        q.heap.push(Request { priority, page });
        drop(q);
        self.shared.wake.notify_one();
    }

    /// Moves a waiting page in the queue; once the reader has it, nothing to do.
    fn requeue(&self, page: u32, priority: f32) {
        let mut q = self.lock();
        if let Some(bits) = q.wanted.get_mut(&page)
            && *bits != priority.to_bits()
        {
            *bits = priority.to_bits();
            q.heap.push(Request { priority, page });
        }
    }

    /// Every resident page, without counting it as used.
    pub fn resident(&self) -> Vec<(u32, Arc<DecodedPage>)> {
        self.slots
            .iter()
            .enumerate()
            .filter_map(|(p, s)| match s {
                Slot::Resident { page, .. } => Some((p as u32, page.clone())),
                _ => None,
            })
            .collect()
    }

    /// Whether `page` is resident.
    pub fn is_resident(&self, page: u32) -> bool {
        matches!(self.slots.get(page as usize), Some(Slot::Resident { .. }))
    }

    /// Keeps `page` resident until as many [`PageCache::unpin`]s; false when it is not resident.
    pub fn pin(&mut self, page: u32) -> bool {
        match self.slots.get_mut(page as usize) {
            Some(Slot::Resident { pins, .. }) => {
                *pins += 1;
                true
            }
            _ => false,
        }
    }

    pub fn unpin(&mut self, page: u32) {
        if let Some(Slot::Resident { pins, .. }) = self.slots.get_mut(page as usize) {
            *pins = pins.saturating_sub(1);
        }
    }

    pub fn stats(&self) -> CacheStats {
        self.stats
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Queue> {
        self.shared
            .queue
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

impl Drop for PageCache {
    /// Tells the reader to stop, without waiting for it: a page being read from a slow disk
    /// would hold up whoever lets the cache go (the viewer closing); the reader ends once that
    /// read returns.
    fn drop(&mut self) {
        self.lock().stop = true;
        self.shared.wake.notify_all();
    }
}

/// The reader thread: the most wanted page first, until the cache is dropped.
fn read_pages(shared: &Shared, source: &dyn PageSource, send: &Sender<Arrival>) {
    loop {
        let page = {
            let mut q = shared
                .queue
                .lock()
                .unwrap_or_else(|poisoned| poisoned.into_inner());
            loop {
                if q.stop {
                    return;
                }
                match q.heap.pop() {
                    // Current unless the page was asked for again with another priority since.
                    Some(Request { priority, page })
                        if q.wanted.get(&page) == Some(&priority.to_bits()) =>
                    {
                        q.wanted.remove(&page);
                        break page;
                    }
                    Some(_) => {}
                    None => {
                        q = shared
                            .wake
                            .wait(q)
                            .unwrap_or_else(|poisoned| poisoned.into_inner());
                    }
                }
            }
        };
        if send.send((page, source.fetch(page as usize))).is_err() {
            return;
        }
    }
}

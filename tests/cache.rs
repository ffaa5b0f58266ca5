//! Pages fetched on demand (issue 40 §1): a paged file opened without reading its pages, each page
//! read and checked alone, and the cache that keeps them within a budget.

mod common;

use common::grid;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex};
use vunify::refine::{PageCache, PageSource};
use vunify::vtree::{self, BuildOptions, DecodedPage, FormatError, FormatErrorKind, PagedFile};

/// A wavy 100 × 100 grid's tree (about 19,600 nodes, five or more pages), written paged to a
/// fresh file in `dir`.
fn paged_tree(dir: &Path) -> (vtree::VertexTree, PathBuf) {
    let mesh = grid(100, 100, |x, y| 0.1 * (6.0 * x).sin() * (5.0 * y).cos());
    let (tree, _) = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {}).unwrap();
    let path = dir.join("grid.vtree");
    vtree::write_with(&tree, &path, vtree::Encoding::Paged).unwrap();
    (vtree::read(&path).unwrap(), path)
}

fn temp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// Opening reads only the directory; every page read alone gives the nodes the whole file's
/// reader gives, and together they are every node once.
#[test]
fn pages_read_alone_are_the_whole_tree() {
    let dir = temp();
    let (tree, path) = paged_tree(dir.path());
    let file = PagedFile::open(&path).unwrap();
    assert_eq!(file.node_count as usize, tree.nodes.len());
    assert!(file.entries.len() >= 5, "{} pages", file.entries.len());
    let mut seen = HashSet::new();
    for p in 0..file.entries.len() {
        let page = file.read_page(p).unwrap();
        assert_eq!(page.ids.len(), file.entries[p].nodes as usize);
        assert!(page.ids.contains(&file.entries[p].root));
        for (&id, node) in page.ids.iter().zip(&page.nodes) {
            assert!(seen.insert(id), "node {id} twice");
            let whole = &tree.nodes[id as usize];
            assert_eq!((node.position, node.error), (whole.position, whole.error));
            assert_eq!(node.children, whole.children);
        }
    }
    assert_eq!(seen.len(), tree.nodes.len());
}

/// The leaves' box, the depth and the root, read page by page, are the whole reader's, bit for
/// bit; so are the counts, flags and parts read on opening.
#[test]
fn a_survey_page_by_page_is_the_whole_trees() {
    let dir = temp();
    let (tree, path) = paged_tree(dir.path());
    let file = PagedFile::open(&path).unwrap();
    let survey = file.survey().unwrap();
    assert_eq!(survey.leaf_box, tree.leaf_box());
    assert_eq!(survey.depth, tree.depth());
    assert_eq!(survey.root, Some(tree.nodes[tree.root() as usize]));
    assert_eq!(file.triangles as usize, tree.triangles.len());
    assert_eq!(file.metric, tree.metric);
    assert_eq!(
        (file.has_colors, file.has_normals, &file.parts),
        (tree.has_colors, tree.has_normals, &tree.parts)
    );
    assert!(!file.appearance);
}

/// Every byte of a paged file is covered by a checksum that the page-by-page reader checks:
/// whichever byte changes (three thousand of them, spread over the file), opening it and
/// surveying its pages fails with an error, never a panic and never a different answer.
#[test]
fn any_changed_byte_is_found_page_by_page() {
    let dir = temp();
    let mesh = grid(70, 70, |x, y| 0.1 * (6.0 * x).sin() * (5.0 * y).cos());
    let (tree, _) = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {}).unwrap();
    let path = dir.path().join("small.vtree");
    vtree::write_with(&tree, &path, vtree::Encoding::Paged).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert!(PagedFile::open(&path).unwrap().entries.len() >= 2);
    let changed = dir.path().join("changed.vtree");
    let step = (bytes.len() / 3000).max(1);
    for at in (0..bytes.len()).step_by(step) {
        let mut b = bytes.clone();
        b[at] ^= 1 << (at % 8);
        std::fs::write(&changed, &b).unwrap();
        let result = PagedFile::open(&changed).and_then(|f| f.survey());
        assert!(result.is_err(), "byte {at} changed went unnoticed");
    }
}

/// One changed byte inside a page: the file still opens (its pages are not read), that page
/// fails with its number and where it lies, and the others read.
#[test]
fn a_corrupt_page_fails_alone() {
    let dir = temp();
    let (_, path) = paged_tree(dir.path());
    let entries = PagedFile::open(&path).unwrap().entries;
    let data_at = std::fs::metadata(&path).unwrap().len()
        - entries.iter().map(|e| e.length as u64).sum::<u64>()
        - part_section_len(&path);
    let mut bytes = std::fs::read(&path).unwrap();
    let at = (data_at + entries[1].offset + entries[1].length as u64 / 2) as usize;
    bytes[at] ^= 0x10;
    std::fs::write(&path, &bytes).unwrap();
    let file = PagedFile::open(&path).unwrap();
    let e = file.read_page(1).err().expect("page 1 is corrupt");
    assert_eq!(e.kind, FormatErrorKind::Checksum);
    assert!(e.to_string().contains("page 1"), "{e}");
    assert_eq!(e.offset, Some(data_at + entries[1].offset));
    file.read_page(0).unwrap();
    file.read_page(2).unwrap();
    // Through the cache: page 1 reported once, the rest resident.
    let mut cache = PageCache::new(Arc::new(file), u64::MAX);
    for p in 0..3 {
        cache.request(p, 1.0);
    }
    let mut failures = Vec::new();
    while cache.stats().pending > 0 {
        failures.extend(cache.receive_waiting());
    }
    assert_eq!(failures.len(), 1);
    assert_eq!(failures[0].0, 1);
    assert!(cache.is_resident(0) && cache.is_resident(2) && !cache.is_resident(1));
    // Asked for again, a failed page is not fetched again.
    cache.request(1, 5.0);
    assert_eq!(cache.stats().pending, 0);
}

/// The bytes after `PDAT`: the file's last section, `PART` (written after the pages).
fn part_section_len(path: &Path) -> u64 {
    let bytes = std::fs::read(path).unwrap();
    let count = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    (0..count)
        .map(|i| 16 + 32 * i)
        .find(|&at| &bytes[at..at + 4] == b"PART")
        .map(|at| u64::from_le_bytes(bytes[at + 16..at + 24].try_into().unwrap()))
        .unwrap()
}

/// A file cut inside its pages is refused when opened, saying where it ends; an exact (version
/// 3) file is refused with the advice to rebuild it.
#[test]
fn truncated_and_exact_files_are_refused() {
    let dir = temp();
    let (tree, path) = paged_tree(dir.path());
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("cut.vtree");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let e = PagedFile::open(&cut).err().expect("truncated");
    assert_eq!(e.kind, FormatErrorKind::Truncated);
    assert!(e.to_string().contains("runs past the end"), "{e}");
    let exact = dir.path().join("exact.vtree");
    vtree::write_with(&tree, &exact, vtree::Encoding::Exact).unwrap();
    let e = PagedFile::open(&exact).err().expect("exact");
    assert!(
        e.to_string().contains("rebuild it with `vunify build`"),
        "{e}"
    );
}

/// A page source held shut until the test opens it, recording the order pages are fetched in.
struct Gated {
    file: PagedFile,
    open: Mutex<bool>,
    opened: Condvar,
    order: Mutex<Vec<usize>>,
}

impl Gated {
    fn open(&self) {
        *self.open.lock().unwrap() = true;
        self.opened.notify_all();
    }
}

impl PageSource for Gated {
    fn pages(&self) -> usize {
        self.file.entries.len()
    }
    fn fetch(&self, page: usize) -> Result<DecodedPage, FormatError> {
        let mut open = self.open.lock().unwrap();
        while !*open {
            open = self.opened.wait(open).unwrap();
        }
        drop(open);
        self.order.lock().unwrap().push(page);
        self.file.read_page(page)
    }
}

fn gated(path: &Path) -> Arc<Gated> {
    Arc::new(Gated {
        file: PagedFile::open(path).unwrap(),
        open: Mutex::new(false),
        opened: Condvar::new(),
        order: Mutex::new(Vec::new()),
    })
}

/// While the disk keeps every page back, asking and receiving never wait: nothing arrives and
/// every page stays pending. Once it lets them through, the most wanted are read first, with
/// priorities changed while they waited.
#[test]
fn requests_never_wait_and_the_most_wanted_come_first() {
    let dir = temp();
    let (_, path) = paged_tree(dir.path());
    let source = gated(&path);
    let pages = source.pages() as u32;
    let mut cache = PageCache::new(source.clone(), u64::MAX);
    for p in 0..pages {
        cache.request(p, p as f32);
    }
    assert!(cache.receive().is_empty());
    assert_eq!(cache.stats().pending, pages as usize);
    assert_eq!(cache.stats().resident_pages, 0);
    // Page 0 becomes the most wanted (the reader may hold one page already: the first asked).
    cache.request(0, 1000.0);
    source.open();
    while cache.stats().pending > 0 {
        assert!(cache.receive_waiting().is_empty());
    }
    let order = source.order.lock().unwrap().clone();
    let rest = &order[1..];
    let mut want: Vec<usize> = rest.to_vec();
    want.sort_by_key(|&p| if p == 0 { 0 } else { u32::MAX - p as u32 });
    assert_eq!(rest, want.as_slice(), "fetched in {order:?}");
    assert_eq!(cache.stats().loaded, pages as u64);
}

/// Letting the cache go while the disk holds a page back does not wait for the disk.
#[test]
fn dropping_the_cache_does_not_wait_for_the_disk() {
    let dir = temp();
    let (_, path) = paged_tree(dir.path());
    let source = gated(&path);
    let mut cache = PageCache::new(source.clone(), u64::MAX);
    cache.request(0, 1.0);
    cache.request(1, 1.0);
    drop(cache);
    // Reached only because the drop returned; the reader ends once its read does.
    source.open();
}

/// Under a budget of two pages' bytes: the least recently used unpinned pages go as others
/// arrive, a pinned page never does, nor one that has just arrived, and nothing else stays
/// beyond the budget.
#[test]
fn eviction_keeps_the_budget_and_the_pinned() {
    let dir = temp();
    let (_, path) = paged_tree(dir.path());
    let file = Arc::new(PagedFile::open(&path).unwrap());
    let size = |p: usize| file.read_page(p).unwrap().bytes();
    let pages = file.entries.len() as u32;
    let budget = size(0) + size(1);
    let mut cache = PageCache::new(file.clone(), budget);
    let fetch = |cache: &mut PageCache, p: u32| {
        cache.request(p, 1.0);
        while cache.stats().pending > 0 {
            cache.receive_waiting();
        }
    };
    fetch(&mut cache, 0);
    fetch(&mut cache, 1);
    assert!(cache.pin(0));
    // Page 1 is the least recently used unpinned page when page 2 arrives.
    fetch(&mut cache, 2);
    assert!(cache.is_resident(0) && cache.is_resident(2) && !cache.is_resident(1));
    for p in 3..pages {
        fetch(&mut cache, p);
        let s = cache.stats();
        assert!(cache.is_resident(0), "the pinned page stays");
        assert!(
            s.resident_bytes <= s.budget.max(size(0) + size(p as usize)),
            "{s:?}"
        );
    }
    cache.unpin(0);
    fetch(&mut cache, 1);
    assert!(!cache.is_resident(0), "unpinned and least recently used");
    let s = cache.stats();
    assert!(s.resident_bytes <= budget, "{s:?}");
    assert_eq!(s.loaded - s.evicted, s.resident_pages as u64);
}

/// Version 6 records at every internal node how far normals turn below it (the largest angle
/// between a node's normal and a child's in its subtree, which the runtime's shading term
/// weighs), rounded up to a 255th of a right angle: what a page read alone says is what the
/// whole tree's normals give, never less and at most one step more.
#[test]
fn every_page_knows_how_far_normals_turn_below_its_nodes() {
    let dir = temp();
    let (tree, path) = paged_tree(dir.path());
    let n = tree.leaf_count as usize;
    let mut turn = vec![0f32; tree.nodes.len()];
    for u in n..tree.nodes.len() {
        let normal = glam::Vec3::from_array(tree.nodes[u].normal);
        for c in tree.nodes[u].children {
            let cn = glam::Vec3::from_array(tree.nodes[c as usize].normal);
            let angle = normal.dot(cn).clamp(-1.0, 1.0).acos();
            turn[u] = turn[u].max(angle).max(turn[c as usize]);
        }
    }
    let file = PagedFile::open(&path).unwrap();
    assert_eq!(file.version, 6);
    let step = std::f32::consts::FRAC_PI_2 / 255.0;
    let mut turning = 0;
    for p in 0..file.entries.len() {
        let page = file.read_page(p).unwrap();
        assert_eq!(page.turns.len(), page.ids.len());
        for (&id, &stored) in page.ids.iter().zip(&page.turns) {
            let want = turn[id as usize].min(std::f32::consts::FRAC_PI_2);
            assert!(
                stored >= want && stored <= want + step + 1e-4,
                "node {id}: {stored} for {want}"
            );
            turning += usize::from(want > 0.01);
        }
    }
    assert!(turning > 100, "{turning} nodes turn");
}

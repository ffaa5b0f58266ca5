//! A tree flown from its file without reading all of it (issue 40 §1): the front refines over
//! the pages read so far, pages arrive in any order while frames go on, a tiny budget evicts, a
//! corrupt page leaves the front coarse there; and once what the view asks for has arrived, the
//! front is the one the whole tree's runtime reaches.

mod common;

use common::{Rng, grid};
use glam::Vec3;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use vunify::refine::validation::check_refiner;
use vunify::refine::{Camera, Front, Hierarchy, PageSource, Refiner, Settings, Streamed, Tests};
use vunify::vtree::{self, BuildOptions, DecodedPage, FormatError, PagedFile};

/// A wavy 120 × 120 grid's tree (about 28,000 nodes, nine pages, all read before the first frame), written paged to a fresh
/// file in `dir`, with the whole tree's hierarchy as the whole file's reader gives it.
fn paged_tree(dir: &Path) -> (Hierarchy, PathBuf) {
    paged_grid(dir, 120)
}

/// [`paged_tree`] of an `n` × `n` grid.
fn paged_grid(dir: &Path, n: u32) -> (Hierarchy, PathBuf) {
    let mesh = grid(n, n, |x, y| 0.1 * (6.0 * x).sin() * (5.0 * y).cos());
    let (tree, _) = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {}).unwrap();
    let path = dir.join("grid.vtree");
    vtree::write_with(&tree, &path, vtree::Encoding::Paged).unwrap();
    (Hierarchy::from_tree(vtree::read(&path).unwrap()), path)
}

/// Cameras that fly from afar to close over the 120 × 120 grid, looking down at a point that
/// wanders.
fn fly_in(frames: usize, seed: u64) -> Vec<Camera> {
    fly_in_at(frames, seed, [640, 480], 120.0, Vec3::new(0.5, 0.5, 0.0))
}

/// [`fly_in`] into a viewport of `size` pixels over a grid `across` wide, towards `target`
/// (in shares of the grid) first.
fn fly_in_at(
    frames: usize,
    seed: u64,
    size: [u32; 2],
    across: f32,
    mut target: Vec3,
) -> Vec<Camera> {
    let mut rng = Rng(seed);
    (0..frames)
        .map(|i| {
            let t = i as f32 / frames.max(2) as f32;
            target += Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, 0.0) * 0.02;
            let distance = 3.0 * (1.0 - t) + 0.15;
            let eye = target + Vec3::new(0.3, -0.4, 1.0).normalize() * distance;
            Camera::looking_at(
                eye * across,
                target * across,
                Vec3::Z,
                50f32.to_radians(),
                size,
                0.01 * across,
                20.0 * across,
            )
        })
        .collect()
}

fn settings(shading: bool) -> Settings {
    Settings {
        tolerance_px: 1.0,
        tests: Tests {
            shading,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// The drawn triangles of a front as the whole tree's leaf ranges of their corners, each
/// rotated to start at its least.
fn drawn(front: &Front, range: impl Fn(u32) -> [u32; 2]) -> HashSet<[[u32; 2]; 3]> {
    front
        .indices()
        .iter()
        .map(|t| {
            let c = t.map(&range);
            let k = (0..3).min_by_key(|&k| c[k]).unwrap();
            [c[k], c[(k + 1) % 3], c[(k + 2) % 3]]
        })
        .collect()
}

/// Flies `streamed` to `camera` until nothing it asks for is missing: frames, and waiting for
/// pages and parts between them.
fn settle_at(streamed: &mut Streamed, camera: &Camera) {
    for _ in 0..200 {
        streamed.update(camera);
        if !streamed.settle() {
            streamed.update(camera);
            if !streamed.settle() {
                return;
            }
        }
    }
    panic!("the stream did not settle");
}

/// With everything the view asks for read, the streamed front is the whole runtime's: the same
/// cut and the same triangles, camera after camera of a fly-in (shading off, where the two
/// weigh the same numbers); with shading on, the stand-ins' bound only makes it finer.
#[test]
fn a_settled_stream_is_the_whole_trees_front() {
    let dir = tempfile::tempdir().unwrap();
    let (whole, path) = paged_tree(dir.path());
    for shading in [false, true] {
        let mut streamed = Streamed::open(&path, u64::MAX, settings(shading)).unwrap();
        let mut refiner = Refiner::new(&whole, settings(shading));
        for camera in fly_in(12, 7) {
            settle_at(&mut streamed, &camera);
            for _ in 0..3 {
                refiner.update(&whole, &camera);
            }
            let before = streamed.front().active().len();
            let st = streamed.update(&camera);
            eprintln!(
                "extra update: {} -> {} splits {} unifies {}",
                before,
                streamed.front().active().len(),
                st.stats.splits,
                st.stats.unifies
            );
            let part = streamed.part();
            let h = streamed.hierarchy();
            check_refiner(h, streamed.refiner()).unwrap();
            let range = |u: u32| {
                let (lo, hi, _) = whole.leaf_range(u);
                [lo, hi]
            };
            let cut_of = |ranges: Vec<[u32; 2]>| ranges.into_iter().collect::<HashSet<_>>();
            let streamed_cut = cut_of(
                streamed
                    .front()
                    .active()
                    .iter()
                    .map(|&u| part.whole_range(u))
                    .collect(),
            );
            let whole_cut = cut_of(refiner.front.active().iter().map(|&u| range(u)).collect());
            if shading {
                // Every node of the whole front holds nodes of the streamed one.
                for r in &whole_cut {
                    assert!(
                        streamed_cut.iter().any(|s| r[0] <= s[0] && s[1] <= r[1]),
                        "the streamed front is coarser at {r:?}"
                    );
                }
            } else {
                if streamed_cut != whole_cut {
                    let view = vunify::refine::View::new(&camera);
                    let tests = settings(false).tests;
                    for &u in &refiner.front.active() {
                        if !streamed_cut.contains(&range(u)) {
                            let p = u;
                            let px = tests.error_px(&whole, &view, p);
                            let vis = tests.visible(&whole, &view, p);
                            let pu = part.cut_at(&[range(u)])[0];
                            let ppx = if h.is_leaf(pu) {
                                -1.0
                            } else {
                                tests.error_px(h, &view, pu)
                            };
                            eprintln!(
                                "whole node {u} range {:?} px {px} vis {vis}; part node {pu} range {:?} px {ppx} leaf {}",
                                range(u),
                                part.whole_range(pu),
                                h.is_leaf(pu)
                            );
                        }
                    }
                }
                assert_eq!(streamed_cut, whole_cut);
                assert_eq!(
                    drawn(streamed.front(), |u| part.whole_range(u)),
                    drawn(&refiner.front, range)
                );
            }
        }
    }
}

/// A disk that hands pages over in its own order: each fetch waits until the test lets one
/// through, and pages asked for are let through in a random order.
struct Shuffled {
    file: PagedFile,
    delay: Mutex<Rng>,
}

impl PageSource for Shuffled {
    fn pages(&self) -> usize {
        self.file.entries.len()
    }
    fn fetch(&self, page: usize) -> Result<DecodedPage, FormatError> {
        let ms = self.delay.lock().unwrap().below(4);
        std::thread::sleep(std::time::Duration::from_millis(ms as u64));
        self.file.read_page(page)
    }
}

/// Frames never wait: while pages arrive late and in any order, and parts are taken in
/// whenever they are ready, the front after every frame is a valid cut of the part with exactly
/// the triangles it implies (the from-scratch checker), and the fly-in still ends refined.
#[test]
fn pages_arriving_in_any_order_keep_every_frame_valid() {
    let dir = tempfile::tempdir().unwrap();
    let (whole, path) = paged_grid(dir.path(), 240);
    for seed in [1, 2, 3] {
        let file = Arc::new(PagedFile::open(&path).unwrap());
        let source = Arc::new(Shuffled {
            file: PagedFile::open(&path).unwrap(),
            delay: Mutex::new(Rng(seed)),
        });
        let mut streamed = Streamed::with_source(file, source, u64::MAX, settings(true)).unwrap();
        let cameras = fly_in_at(120, seed, [640, 480], 240.0, Vec3::new(0.5, 0.5, 0.0));
        for camera in &cameras {
            streamed.update(camera);
            check_refiner(streamed.hierarchy(), streamed.refiner()).unwrap();
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        settle_at(&mut streamed, cameras.last().unwrap());
        check_refiner(streamed.hierarchy(), streamed.refiner()).unwrap();
        assert!(streamed.parts > 2, "{} parts", streamed.parts);
        // As fine as the whole tree's runtime at the last camera, or finer (see the first test).
        let mut whole_refiner = Refiner::new(&whole, settings(true));
        for _ in 0..3 {
            whole_refiner.update(&whole, cameras.last().unwrap());
        }
        let (got, want) = (
            streamed.front().triangle_count(),
            whole_refiner.front.triangle_count(),
        );
        assert!(
            got >= want && want > 100,
            "{got} triangles, the whole tree's {want}"
        );
    }
}

/// Under a budget of about one page, pages are let go as the view moves on (over a 400 × 400
/// grid, whose front lies in a few dozen of its 90-odd pages at a time), the front after every
/// frame is valid, and once the view's pages have arrived again the front is as fine as the
/// whole tree's runtime makes it: a small cache costs reading, not detail.
#[test]
fn a_tiny_budget_evicts_and_loses_no_detail() {
    let dir = tempfile::tempdir().unwrap();
    let (whole, path) = paged_grid(dir.path(), 400);
    let file = PagedFile::open(&path).unwrap();
    let one_page = file.read_page(0).unwrap().bytes();
    let fine = Settings {
        tolerance_px: 0.25,
        ..settings(true)
    };
    let mut streamed = Streamed::open(&path, one_page, fine).unwrap();
    let mut refiner = Refiner::new(&whole, fine);
    let size = [320, 240];
    let corner = |x: f32, y: f32| Vec3::new(x, y, 0.0);
    // Into one corner, back out, and into the opposite one.
    let mut cameras = fly_in_at(40, 5, size, 400.0, corner(0.1, 0.1));
    cameras.extend(
        fly_in_at(40, 9, size, 400.0, corner(0.1, 0.1))
            .into_iter()
            .rev(),
    );
    cameras.extend(fly_in_at(40, 11, size, 400.0, corner(0.9, 0.9)));
    for camera in cameras.iter().step_by(3) {
        settle_at(&mut streamed, camera);
        check_refiner(streamed.hierarchy(), streamed.refiner()).unwrap();
        for _ in 0..3 {
            refiner.update(&whole, camera);
        }
        let part = streamed.part();
        let streamed_cut: Vec<[u32; 2]> = streamed
            .front()
            .active()
            .iter()
            .map(|&u| part.whole_range(u))
            .collect();
        for u in refiner.front.active() {
            let (lo, hi, _) = whole.leaf_range(u);
            assert!(
                streamed_cut.iter().any(|s| lo <= s[0] && s[1] <= hi),
                "the streamed front is coarser at {lo}..{hi}"
            );
        }
    }
    let stats = streamed.cache_stats();
    assert!(stats.evicted > 10, "{stats:?}");
    // Pages the parts used only some nodes of were kept so, and read whole again when wanted.
    assert!(stats.rereads > 0, "{stats:?}");
    assert!(stats.resident_pages < file.entries.len() / 2, "{stats:?}");
    assert_eq!(stats.loaded - stats.evicted, stats.resident_pages as u64);
    assert_eq!(stats.failed, 0);
}

/// A page that cannot be read is reported once, with its number; the front stays coarse where
/// it would have gone, the frames go on, and the other pages arrive.
#[test]
fn a_corrupt_page_is_reported_and_the_front_carries_on() {
    let dir = tempfile::tempdir().unwrap();
    let (_, path) = paged_tree(dir.path());
    let file = PagedFile::open(&path).unwrap();
    let pages = file.entries.len();
    let data_at = {
        let bytes = std::fs::read(&path).unwrap();
        common::section(&bytes, b"PDAT").start as u64
    };
    // The first page: a bottom page, which a close view of its corner needs.
    let entry = file.entries[0];
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[(data_at + entry.offset + entry.length as u64 / 2) as usize] ^= 0x40;
    std::fs::write(&path, &bytes).unwrap();
    let mut streamed = Streamed::open(&path, u64::MAX, settings(true)).unwrap();
    let mut failures = Vec::new();
    // Fly over every part of the grid.
    for seed in 0..6 {
        for camera in fly_in(30, seed) {
            settle_at(&mut streamed, &camera);
            failures.extend(streamed.take_failures());
            check_refiner(streamed.hierarchy(), streamed.refiner()).unwrap();
        }
    }
    assert_eq!(failures.len(), 1, "{failures:?}");
    assert_eq!(failures[0].0, 0);
    assert!(
        failures[0].1.to_string().contains("page 0"),
        "{}",
        failures[0].1
    );
    let stats = streamed.cache_stats();
    assert!(stats.loaded as usize >= pages / 2, "{stats:?}");
}

/// What `--color-by error` shows of a streamed tree: a leaf of the part that stands for a subtree
/// not read yet draws with that subtree's error (so what waits for the disk shows), a leaf of the
/// whole tree with none; a stand-in's leaves are many, a true leaf's one.
#[test]
fn stand_ins_draw_with_the_error_they_stand_for() {
    let dir = tempfile::tempdir().unwrap();
    let (_, path) = paged_grid(dir.path(), 240);
    let streamed = Streamed::open(&path, u64::MAX, settings(true)).unwrap();
    let (part, h) = (streamed.part(), streamed.hierarchy());
    assert!(part.stand_ins() >= 2, "{} stand-ins", part.stand_ins());
    let mut erring = 0;
    for u in 0..h.leaf_count {
        let [a, b] = part.whole_range(u);
        if part.is_stand_in(u) {
            assert!(b - a > 1, "stand-in {u} holds {a}..{b}");
            erring += usize::from(h.drawn_error(u) > 0.0);
        } else {
            assert_eq!((b - a, h.drawn_error(u)), (1, 0.0), "leaf {u}");
        }
    }
    assert!(
        erring * 10 >= part.stand_ins() * 9,
        "{erring} of {}",
        part.stand_ins()
    );
}

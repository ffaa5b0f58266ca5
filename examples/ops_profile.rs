//! Profiling aid: split the bunny's whole tree and unify it back, many times.
use std::time::Instant;
use vunify::mesh::CleanOptions;
use vunify::refine::{Front, Hierarchy};
use vunify::vtree::{self, BuildOptions};

fn main() {
    let path = std::env::args()
        .nth(1)
        .unwrap_or("../shared/models/stanford-bunny.obj".into());
    let (mesh, _) = vunify::mesh::load(path.as_ref(), &CleanOptions::default()).unwrap();
    let (tree, _) = vtree::build(&mesh, &BuildOptions::default(), &mut |_, _| {}).unwrap();
    let h = Hierarchy::new(&tree);
    let mut f = Front::new(&h);
    let t0 = Instant::now();
    for _ in 0..20 {
        f.refine_all(&h);
        f.coarsen_all(&h);
    }
    let ops = f.splits + f.unifies;
    println!(
        "{:.2} M ops/s",
        ops as f64 / t0.elapsed().as_secs_f64() / 1e6
    );
}

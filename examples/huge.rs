//! Huge test models, streamed to binary PLY without ever holding the mesh (`vunify::generate`):
//!
//!     cargo run --release --example huge -- terrain terrain.ply [--triangles 100M] [--seed S]
//!     cargo run --release --example huge -- city city.ply [--triangles 100M] [--seed S] [MODEL…]
//!
//! The city repeats the scanned MODELs (any mesh vunify reads; by default the Stanford bunny and
//! dragon and the horse from `$VUNIFY_MODELS`), turned and scaled, on a grid, until it has at least
//! the triangles asked for; the terrain is one connected height field of at least that many. The
//! file is written atomically (a crash leaves no half of it).

use std::io::Write;
use std::path::{Path, PathBuf};
use vunify::generate::{City, Terrain, write_city, write_terrain};
use vunify::mesh::{self, CleanOptions};

/// `100M`, `1.5G`, `50k` or a plain number.
fn count(s: &str) -> Result<u64, String> {
    let (number, unit) = match s.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => (&s[..i], c.to_ascii_lowercase()),
        _ => (s, ' '),
    };
    let factor = match unit {
        'k' => 1e3,
        'm' => 1e6,
        'g' => 1e9,
        ' ' => 1.0,
        _ => return Err(format!("{s}: a count such as 100M, 1G or 50k")),
    };
    number
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite() && *x > 0.0)
        .map(|x| (x * factor).round() as u64)
        .ok_or_else(|| format!("{s}: a count such as 100M, 1G or 50k"))
}

fn fail(message: impl std::fmt::Display) -> ! {
    eprintln!("huge: {message}");
    std::process::exit(2)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(kind), Some(output)) = (args.first(), args.get(1)) else {
        fail("usage: huge terrain|city OUT.ply [--triangles 100M] [--seed S] [MODEL…]");
    };
    let (mut triangles, mut seed, mut models) = (100_000_000u64, 1u64, Vec::new());
    let mut rest = args[2..].iter();
    while let Some(a) = rest.next() {
        match a.as_str() {
            "--triangles" => {
                triangles = count(rest.next().map_or("", |s| s)).unwrap_or_else(|e| fail(e))
            }
            "--seed" => {
                seed = rest
                    .next()
                    .and_then(|s| s.parse().ok())
                    .unwrap_or_else(|| fail("--seed: a whole number"))
            }
            _ => models.push(PathBuf::from(a)),
        }
    }
    let start = std::time::Instant::now();
    let mut last = 0.0;
    let mut progress = |done: u64, total: u64| {
        let t = start.elapsed().as_secs_f64();
        if t - last > 2.0 || done == total {
            eprintln!("  {:5.1} %  {t:.0} s", 100.0 * done as f64 / total as f64);
            last = t;
        }
    };
    let write = |body: &mut (dyn FnMut(&mut dyn Write) -> std::io::Result<()> + Send)| {
        vunify::export::write_atomic_checked(
            Path::new(output),
            |file| {
                let mut out = std::io::BufWriter::with_capacity(1 << 22, file);
                body(&mut out)?;
                out.flush()
            },
            || Ok(()),
        )
        .unwrap_or_else(|e| fail(format!("{output}: {e}")));
    };
    match kind.as_str() {
        "terrain" => {
            let terrain = Terrain::with_triangles(triangles, seed);
            let (v, t) = terrain.counts();
            eprintln!(
                "terrain: {} × {} cells, {v} vertices, {t} triangles",
                terrain.cells, terrain.cells
            );
            write(&mut |out| write_terrain(out, &terrain, &mut progress));
        }
        "city" => {
            if models.is_empty() {
                let dir = std::env::var_os("VUNIFY_MODELS")
                    .unwrap_or_else(|| fail("name the MODELs, or set VUNIFY_MODELS"));
                let dir = PathBuf::from(dir);
                models = ["stanford-bunny.obj", "stanford-dragon.obj.xz", "horse.obj"]
                    .iter()
                    .map(|m| dir.join(m))
                    .collect();
            }
            let meshes: Vec<_> = models
                .iter()
                .map(|m| {
                    mesh::load(m, &CleanOptions::default())
                        .unwrap_or_else(|e| fail(e))
                        .0
                })
                .collect();
            // Copies in turn until the triangles are reached.
            let (mut copies, mut sum) = (0u32, 0u64);
            while sum < triangles {
                sum += meshes[copies as usize % meshes.len()].triangles.len() as u64;
                copies += 1;
            }
            let city = City {
                models: &meshes,
                copies,
                seed,
            };
            let (v, t) = city.counts();
            eprintln!(
                "city: {copies} copies of {} models, {v} vertices, {t} triangles",
                meshes.len()
            );
            write(&mut |out| write_city(out, &city, &mut progress));
        }
        other => fail(format!("{other}: terrain or city")),
    }
    eprintln!("wrote {output} in {:.1} s", start.elapsed().as_secs_f64());
}

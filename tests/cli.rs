//! The `vunify` command line, run as a user would.

mod common;

use common::ok;
use std::path::PathBuf;
use std::process::{Command, Output};

fn vunify(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vunify"))
        .args(args)
        .output()
        .expect("run vunify")
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vunify-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// `vunify measure ORIGINAL SIMPLIFIED --json`: the symmetric maximum, as a fraction of the diagonal.
fn hausdorff_max(original: &str, simplified: &str) -> f64 {
    let args = [
        "measure",
        original,
        simplified,
        "--json",
        "--samples",
        "20000",
    ];
    let m: serde_json::Value = serde_json::from_str(&ok(&vunify(&args))).unwrap();
    m["symmetric"]["max"].as_f64().unwrap()
}

#[test]
fn build_info_extract_measure() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/cessna.obj");
    let tree = tmp("cessna.vtree");
    let t = tree.to_str().unwrap();
    let summary = ok(&vunify(&["build", model, "-o", t, "--json"]));
    let json: serde_json::Value = serde_json::from_str(&summary).unwrap();
    assert_eq!(json["vertices"], 6795);
    assert_eq!(json["triangles"], 13546);
    assert_eq!(json["build"]["nodes"], 2 * 6795 - 1);

    let info: serde_json::Value =
        serde_json::from_str(&ok(&vunify(&["info", t, "--check", "--json"]))).unwrap();
    assert_eq!(info["leaves"], 6795);
    assert_eq!(info["checked"], true);

    let lod = tmp("cessna-10.obj");
    let l = lod.to_str().unwrap();
    let said = ok(&vunify(&["extract", t, "--ratio", "0.1", "-o", l]));
    assert!(
        said.contains("1354 triangles") || said.contains("1355 triangles"),
        "{said}"
    );
    let max = hausdorff_max(model, l);
    assert!(
        max > 0.0 && max < 0.05,
        "10 % of the cessna is within 5 % of its diagonal: {max}"
    );

    let by_count = ok(&vunify(&["extract", t, "--triangles", "100", "-o", l]));
    assert!(
        by_count.contains(" 100 triangles")
            || by_count.contains(" 99 triangles")
            || by_count.contains(" 98 triangles"),
        "{by_count}"
    );
    let triangles = |said: &str| -> u32 {
        let words: Vec<&str> = said.split_whitespace().collect();
        let i = words
            .iter()
            .position(|w| *w == "triangles")
            .expect("a triangle count");
        words[i - 1].parse().unwrap()
    };
    let by_error = triangles(&ok(&vunify(&["extract", t, "--error", "0.01", "-o", l])));
    // The strict bound is a guarantee, paid for in triangles: more of them for the same number, and
    // the measured distance within it.
    let by_bound = triangles(&ok(&vunify(&["extract", t, "--bound", "0.01", "-o", l])));
    assert!(by_bound > by_error, "{by_bound} vs {by_error}");
    let max = hausdorff_max(model, l);
    assert!(max <= 0.01, "--bound 0.01 measured {max} of the diagonal");
    let out = vunify(&["extract", t, "--bound=-1", "-o", l]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--bound must be"));
}

/// `vunify build` writes the paged file (version 6) unless told `--exact` (version 1 here, no
/// appearance): at most 32 bytes a triangle against about 98, the position error stated by
/// `info`, and the same levels extracted from both.
#[test]
fn build_writes_paged_files_unless_exact() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/cessna.obj");
    let (paged, exact) = (tmp("paged.vtree"), tmp("exact.vtree"));
    let (p, e) = (paged.to_str().unwrap(), exact.to_str().unwrap());
    let said = ok(&vunify(&["build", model, "-o", p]));
    assert!(
        said.contains("bytes a triangle (paged, quantised)"),
        "{said}"
    );
    ok(&vunify(&["build", model, "-o", e, "--exact"]));
    let version = |path: &PathBuf| std::fs::read(path).unwrap()[8];
    assert_eq!((version(&paged), version(&exact)), (6, 1));
    let info = |t: &str| -> serde_json::Value {
        serde_json::from_str(&ok(&vunify(&["info", t, "--check", "--json"]))).unwrap()
    };
    let (ip, ie) = (info(p), info(e));
    assert_eq!((&ip["version"], &ie["version"]), (&6.into(), &1.into()));
    let triangles = 13546.0;
    let per_triangle = |i: &serde_json::Value| i["file_bytes"].as_f64().unwrap() / triangles;
    assert!(per_triangle(&ip) <= 32.0, "{}", per_triangle(&ip));
    assert!(per_triangle(&ie) > 90.0, "{}", per_triangle(&ie));
    let stated = ip["position_error"].as_f64().unwrap();
    assert!(stated > 0.0 && stated < 1e-4 * ip["diagonal"].as_f64().unwrap());
    assert_eq!(ie["position_error"], 0.0);
    let text = ok(&vunify(&["info", p]));
    assert!(text.contains("stored     paged"), "{text}");
    assert!(
        text.contains("format     version 6: leaves numbered depth-first"),
        "{text}"
    );
    // A version 4 file (before leaves were numbered depth-first) reads, and says so.
    let v4 = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/cessna-v4.vtree"
    );
    let text = ok(&vunify(&["info", v4]));
    assert!(
        text.contains("format     version 4: leaves in the input's order"),
        "{text}"
    );
    let level = |t: &str, name: &str| {
        let out = tmp(name);
        ok(&vunify(&[
            "extract",
            t,
            "--ratio",
            "0.1",
            "-o",
            out.to_str().unwrap(),
        ]))
    };
    assert_eq!(
        level(p, "p10.obj")
            .split_whitespace()
            .find(|w| w.parse::<u32>().is_ok()),
        level(e, "e10.obj")
            .split_whitespace()
            .find(|w| w.parse::<u32>().is_ok())
    );
}

/// `--cell-triangles`: the cessna in cells of at most 2000 triangles (8 cells, 4 levels) is one
/// tree that `info --check` passes, its 10 % level close to the whole build's; 0 is refused.
#[test]
fn build_in_cells() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/cessna.obj");
    let tree = tmp("cessna-cells.vtree");
    let t = tree.to_str().unwrap();
    let args = ["build", model, "-o", t, "--cell-triangles", "2000"];
    let said = ok(&vunify(&args));
    assert!(
        said.contains("cells      8 of at most 2000 triangles, 4 levels"),
        "{said}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&ok(&vunify(&[&args[..], &["--json"]].concat()))).unwrap();
    assert_eq!(json["build"]["nodes"], 2 * 6795 - 1);
    assert_eq!(json["build"]["cells"], 8);
    let info: serde_json::Value =
        serde_json::from_str(&ok(&vunify(&["info", t, "--check", "--json"]))).unwrap();
    assert_eq!(info["checked"], true);
    let lod = tmp("cessna-cells-10.obj");
    let l = lod.to_str().unwrap();
    ok(&vunify(&["extract", t, "--ratio", "0.1", "-o", l]));
    let max = hausdorff_max(model, l);
    assert!(max > 0.0 && max < 0.05, "10 % in cells: {max}");
    for (bad, says) in [
        (&["--cell-triangles", "0"][..], "at least 1"),
        (
            &["--cell-triangles", "100", "--schedule", "greedy"][..],
            "drop --schedule greedy",
        ),
    ] {
        let out = vunify(&[&["build", model, "-o", t][..], bad].concat());
        assert_eq!(out.status.code(), Some(1));
        assert!(String::from_utf8_lossy(&out.stderr).contains(says));
    }
}

/// `--memory SIZE`: a 200,000-triangle terrain (written here) in 90 MiB goes in cells and
/// peaks within the budget and a tenth; a budget below what any build needs is refused, saying
/// how much would do, and that much does; what a whole build fits is built whole.
#[test]
fn build_within_memory() {
    let terrain = tmp("terrain-200k.ply");
    let t = vunify::generate::Terrain::with_triangles(200_000, 7);
    let mut out = std::io::BufWriter::new(std::fs::File::create(&terrain).unwrap());
    vunify::generate::write_terrain(&mut out, &t, &mut |_, _| {}).unwrap();
    drop(out);
    let input = terrain.to_str().unwrap();
    let tree = tmp("terrain-200k.vtree");
    let build = |memory: &str| {
        Command::new(env!("CARGO_BIN_EXE_vunify"))
            .args(["build", input, "-o", tree.to_str().unwrap(), "--json"])
            .arg(format!("--memory={memory}"))
            // The cells are chosen for this many at once.
            .env("RAYON_NUM_THREADS", "2")
            .output()
            .unwrap()
    };
    let within = |memory: &str, budget: f64| {
        let out = build(memory);
        let json: serde_json::Value = serde_json::from_str(&ok(&out)).unwrap();
        let peak = json["peak_memory_bytes"].as_f64().unwrap();
        assert!(peak <= 1.1 * budget, "--memory {memory}: peak {peak}");
        assert_eq!(json["memory_budget_bytes"].as_f64(), Some(budget));
        let note = String::from_utf8_lossy(&out.stderr).to_string();
        (json["build"]["cells"].as_u64().unwrap(), note)
    };
    let mib = (1u64 << 20) as f64;
    let (cells, note) = within("90M", 90.0 * mib);
    assert!(cells > 1, "{cells} cells");
    assert!(note.contains("to stay within --memory 90 MiB"), "{note}");
    let info: serde_json::Value = serde_json::from_str(&ok(&vunify(&[
        "info",
        tree.to_str().unwrap(),
        "--check",
        "--json",
    ])))
    .unwrap();
    assert_eq!(info["checked"], true);
    // The same budget as separate steps (plan, each cell, join): the same cells, the same bytes.
    let one_process = std::fs::read(&tree).unwrap();
    let dir = tmp("terrain-plan");
    let with_threads = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_vunify"))
            .args(args)
            .env("RAYON_NUM_THREADS", "2")
            .output()
            .unwrap();
        ok(&out)
    };
    let dir_s = dir.to_str().unwrap();
    let plan: serde_json::Value = serde_json::from_str(&with_threads(&[
        "build", input, "--memory", "90M", "--plan", dir_s, "--json",
    ]))
    .unwrap();
    assert_eq!(plan["cells"].as_u64(), Some(cells));
    for i in 0..cells {
        with_threads(&["cell", dir_s, "--index", &i.to_string()]);
    }
    let joined = tmp("terrain-joined.vtree");
    with_threads(&["join", dir_s, "-o", joined.to_str().unwrap()]);
    assert!(std::fs::read(&joined).unwrap() == one_process);
    // Whole where a whole build fits.
    assert_eq!(within("1G", 1024.0 * mib).0, 0);
    // Too little: refused, no output, and the size it names is enough.
    std::fs::remove_file(&tree).unwrap();
    let out = build("40M");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        err.contains("terrain-200k.ply") && err.contains("too little"),
        "{err}"
    );
    assert!(!tree.exists(), "no output when refused");
    let enough = err
        .split("give --memory ")
        .nth(1)
        .and_then(|rest| rest.split('M').next())
        .unwrap_or_else(|| panic!("{err}"));
    within(&format!("{enough}M"), enough.parse::<f64>().unwrap() * mib);
    // Sizes: a unit is needed or bytes; nonsense is refused.
    for bad in ["8Q", "-1G", "0"] {
        let out = build(bad);
        assert_eq!(out.status.code(), Some(2), "{bad}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("--memory"));
    }
}

#[test]
fn bad_input_is_a_clear_error() {
    let bad = tmp("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    let out = vunify(&[
        "build",
        bad.to_str().unwrap(),
        "-o",
        tmp("x.vtree").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.obj:4:") && err.contains("out of range"),
        "{err}"
    );
    assert!(!tmp("x.vtree").exists(), "no output on failure");

    let junk = tmp("junk.vtree");
    std::fs::write(&junk, b"VUNIFYVT\x01\0\0\0").unwrap();
    let out = vunify(&["info", junk.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("junk.vtree"));

    // Exactly one target for extract.
    let out = vunify(&["extract", junk.to_str().unwrap(), "-o", "x.obj"]);
    assert!(!out.status.success());
}

#[test]
fn help_explains_every_option() {
    let help = ok(&vunify(&["build", "--help"]));
    for option in [
        "--metric",
        "--pair-distance",
        "--max-pairs",
        "--sharp-angle",
        "--w-dist",
        "--w-feature",
        "--no-weld",
        "--cell-triangles",
        "--memory",
        "--plan",
        "qem-midpoint",
        "hybrid",
    ] {
        assert!(help.contains(option), "build --help lacks {option}");
    }
}

/// `vunify path` writes a path that `vunify render` reads; a broken path file is an error naming the
/// file, line and column; with no Vulkan adapter `render` says how to install lavapipe.
/// `vunify info` on a paged tree reads its pages one at a time (never the whole tree) and says
/// what reading it whole says (`--check` reads it whole): the same JSON but for `checked`, the
/// same text but for the check's line.
#[test]
fn info_of_a_paged_tree_is_read_page_by_page() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/cessna.obj");
    let paged = tmp("info-paged.vtree");
    ok(&vunify(&["build", model, "-o", paged.to_str().unwrap()]));
    let info = |extra: &[&str]| {
        let mut args = vec!["info", paged.to_str().unwrap()];
        args.extend_from_slice(extra);
        ok(&vunify(&args))
    };
    let json = |extra: &[&str]| {
        let mut j: serde_json::Value = serde_json::from_str(&info(extra)).unwrap();
        j.as_object_mut().unwrap().remove("checked");
        j
    };
    assert_eq!(json(&["--json"]), json(&["--json", "--check"]));
    let whole: Vec<String> = info(&["--check"])
        .lines()
        .filter(|l| !l.starts_with("check"))
        .map(String::from)
        .collect();
    let pages: Vec<String> = info(&[]).lines().map(String::from).collect();
    assert_eq!(pages, whole);
    assert!(pages.iter().any(|l| l.contains("depth")), "{pages:?}");
}

/// `vunify path` reads a paged tree page by page (never the whole tree) and makes the same path as
/// from the same positions read whole: the paged tree written back exactly, which it reads whole.
#[test]
fn path_of_a_paged_tree_is_read_page_by_page() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/cessna.obj");
    let paged = tmp("path-paged.vtree");
    ok(&vunify(&["build", model, "-o", paged.to_str().unwrap()]));
    let exact = tmp("path-exact.vtree");
    let tree = vunify::vtree::read(&paged).unwrap();
    vunify::vtree::write_with(&tree, &exact, vunify::vtree::Encoding::Exact).unwrap();
    let path_of = |tree: &std::path::Path, name: &str| {
        let out = tmp(name);
        ok(&vunify(&[
            "path",
            "--kind",
            "fly-in",
            tree.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]));
        std::fs::read(out).unwrap()
    };
    assert_eq!(
        path_of(&paged, "path-paged.json"),
        path_of(&exact, "path-exact.json")
    );
    // A page corrupted: the path says which page, and writes nothing.
    let mut bytes = std::fs::read(&paged).unwrap();
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x40;
    std::fs::write(&paged, &bytes).unwrap();
    let out_path = tmp("path-corrupt.json");
    let out = vunify(&[
        "path",
        paged.to_str().unwrap(),
        "-o",
        out_path.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("path-paged.vtree") && err.contains("page"),
        "{err}"
    );
    assert!(!out_path.exists());
}

#[test]
fn path_and_render_commands() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/cessna.obj");
    let path = tmp("fly.json");
    let out = ok(&vunify(&[
        "path",
        "--kind",
        "fly-in",
        model,
        "--seconds",
        "2",
        "-o",
        path.to_str().unwrap(),
    ]));
    assert!(out.contains("keyframes"), "{out}");
    vunify::camera_path::CameraPath::load(&path).unwrap();

    let broken = tmp("broken.json");
    std::fs::write(
        &broken,
        "{\n  \"keyframes\": [\n    {\"time\": 0, \"position\": [1, 2]}\n  ]\n}",
    )
    .unwrap();
    let out = vunify(&["render", model, "--path", broken.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("broken.json:3:"), "{err}");

    let out = Command::new(env!("CARGO_BIN_EXE_vunify"))
        .args([
            "render",
            model,
            "--path",
            path.to_str().unwrap(),
            "--out",
            tmp("r").to_str().unwrap(),
        ])
        .env("WGPU_BACKEND", "vulkan")
        .env("VK_DRIVER_FILES", "/nonexistent.json")
        .env("VK_ICD_FILENAMES", "/nonexistent.json")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no Vulkan adapter") && err.contains("mesa-vulkan-drivers"),
        "{err}"
    );

    // --json: the summary as JSON, with what a user of a big model asks first.
    let out = Command::new(env!("CARGO_BIN_EXE_vunify"))
        .args([
            "render",
            model,
            "--path",
            path.to_str().unwrap(),
            "--size",
            "96x64",
            "--fps",
            "2",
            "--every",
            "1000",
            "--json",
            "--out",
            tmp("rj").to_str().unwrap(),
        ])
        .env("CI", "true")
        .output()
        .unwrap();
    if out.status.success() || std::env::var_os("CI").is_some() {
        let summary: serde_json::Value = serde_json::from_str(&ok(&out)).unwrap();
        for key in [
            "first_frame_s",
            "max_frame_ms",
            "refine_ms_median",
            "frames",
        ] {
            assert!(summary[key].as_f64().is_some(), "{key}: {summary}");
        }
        assert!(summary["first_frame_s"].as_f64().unwrap() > 0.0);
        if cfg!(target_os = "linux") {
            assert!(summary["peak_resident_mb"].as_f64().unwrap() > 1.0);
        }
    }

    let help = ok(&vunify(&["render", "--help"]));
    for option in [
        "--path",
        "--out",
        "--size",
        "--tau",
        "--budget",
        "--every",
        "--compare",
        "--wireframe",
        "--color-by",
        "--json",
        "--cache",
    ] {
        assert!(help.contains(option), "render --help lacks {option}");
    }
}

/// `render --cache SIZE` streams a paged tree: its summary counts the pages read and the parts
/// taken in, stats.csv has each frame's pages; the full mesh cannot be compared against, and a
/// version 4 file is refused with the advice to rebuild it.
#[test]
fn render_streams_a_paged_tree() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/cessna.obj");
    let tree = tmp("streamed-cessna.vtree");
    ok(&vunify(&["build", model, "-o", tree.to_str().unwrap()]));
    let out_dir = tmp("streamed-render");
    let out = Command::new(env!("CARGO_BIN_EXE_vunify"))
        .args(["render", tree.to_str().unwrap(), "--cache", "64M", "--json"])
        .args(["--size", "96x64", "--fps", "3", "--every", "1000", "--out"])
        .arg(&out_dir)
        .env("CI", "true")
        .output()
        .unwrap();
    if out.status.success() || std::env::var_os("CI").is_some() {
        let summary: serde_json::Value = serde_json::from_str(&ok(&out)).unwrap();
        assert!(summary["pages_loaded"].as_u64().unwrap() >= 1, "{summary}");
        assert!(summary["parts"].as_u64().unwrap() >= 1, "{summary}");
        let csv = std::fs::read_to_string(out_dir.join("stats.csv")).unwrap();
        let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
        for column in ["pages_loaded", "pages_pending", "cache_mb"] {
            let k = header.iter().position(|h| *h == column).unwrap();
            for line in csv.lines().skip(1) {
                let value: f64 = line.split(',').nth(k).unwrap().parse().unwrap();
                assert!(value >= 0.0, "{column}: {line}");
            }
        }
    }
    let out = vunify(&[
        "render",
        tree.to_str().unwrap(),
        "--cache",
        "64M",
        "--compare",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--compare") && err.contains("--cache"),
        "{err}"
    );
    let old = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/cessna-v4.vtree"
    );
    let out = vunify(&["render", old, "--cache", "64M"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cessna-v4.vtree") && err.contains("rebuild it with `vunify build`"),
        "{err}"
    );
}

/// Printing into a closed pipe (`vunify measure A B | head -0`) ends the process quietly, as `cat`
/// does, instead of panicking in `println!`.
#[test]
fn closed_stdout_ends_quietly() {
    let obj = tmp("one-triangle.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let o = obj.to_str().unwrap();
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = Command::new(env!("CARGO_BIN_EXE_vunify"))
        .args(["measure", o, o, "--samples", "1000"])
        .stdout(writer)
        .output()
        .expect("run vunify");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(
            out.status.signal(),
            Some(13),
            "SIGPIPE ends it: {:?}",
            out.status
        );
    }
}

/// `kill -9` while `vunify build` writes over an existing tree, at several moments (before, during
/// and after the build, and the moment its temporary file appears): the old file stays byte for byte
/// (or, when the build had finished, the new file is whole), and the next run leaves no temporary
/// file behind.
#[test]
fn kill_9_during_a_build_keeps_the_old_tree() {
    let dir = tmp("kill9");
    std::fs::create_dir_all(&dir).unwrap();
    // A 250 × 250 grid (125,000 triangles): a build long enough to be killed in.
    let big = dir.join("big.obj");
    let mut text = String::new();
    let n = 250;
    for y in 0..=n {
        for x in 0..=n {
            text += &format!("v {x} {y} {}\n", ((x * y) as f32 * 0.01).sin());
        }
    }
    let id = |x: u32, y: u32| y * (n + 1) + x + 1;
    for y in 0..n {
        for x in 0..n {
            text += &format!("f {} {} {}\n", id(x, y), id(x + 1, y), id(x + 1, y + 1));
            text += &format!("f {} {} {}\n", id(x, y), id(x + 1, y + 1), id(x, y + 1));
        }
    }
    std::fs::write(&big, text).unwrap();
    let small = dir.join("small.obj");
    std::fs::write(
        &small,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 1\nf 1 2 3\nf 2 4 3\n",
    )
    .unwrap();
    let out = dir.join("model.vtree");
    let (b, s, o) = (
        big.to_str().unwrap(),
        small.to_str().unwrap(),
        out.to_str().unwrap(),
    );
    ok(&vunify(&["build", s, "-o", o]));
    let mut old = std::fs::read(&out).unwrap();
    let temporaries = || {
        std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
            .count()
    };
    let mut killed_with_temporary = false;
    // The moment the temporary file appears comes last: each later run removes what a killed one left.
    for delay_ms in [Some(0), Some(30), Some(100), Some(300), Some(1000), None] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_vunify"))
            .args(["build", b, "-o", o])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        match delay_ms {
            Some(ms) => std::thread::sleep(std::time::Duration::from_millis(ms)),
            // The moment the temporary file appears (or the build ends).
            None => {
                while temporaries() == 0 && child.try_wait().unwrap().is_none() {
                    std::thread::sleep(std::time::Duration::from_micros(200));
                }
                killed_with_temporary = temporaries() > 0;
            }
        }
        child.kill().ok();
        child.wait().unwrap();
        let now = std::fs::read(&out).unwrap();
        if now != old {
            // The build finished before the kill: the new tree is whole.
            ok(&vunify(&["info", o, "--check"]));
            old = now;
        }
    }
    assert!(
        killed_with_temporary,
        "no run was killed while its temporary file existed"
    );
    assert!(temporaries() > 0, "a killed run left its temporary file");
    // The next run removes what killed runs left.
    ok(&vunify(&["build", s, "-o", o]));
    assert_eq!(temporaries(), 0, "temporary files left behind");
    ok(&vunify(&["info", o, "--check"]));
    std::fs::remove_dir_all(&dir).ok();
}

/// `vunify measure --certified --json`: both directions' bounds, in the documented fields.
#[test]
fn measure_certified_json() {
    let a = tmp("certified-a.obj");
    let b = tmp("certified-b.obj");
    std::fs::write(&a, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(&b, "v 0 0 0.5\nv 1 0 0.5\nv 0 1 0.5\nf 1 2 3\n").unwrap();
    let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
    let j: serde_json::Value =
        serde_json::from_str(&ok(&vunify(&["measure", a, b, "--certified", "--json"]))).unwrap();
    let exact = 0.5 / 2f64.sqrt();
    for side in ["forward", "backward"] {
        let (lo, hi) = (
            j[side]["lower"].as_f64().unwrap(),
            j[side]["upper"].as_f64().unwrap(),
        );
        assert!(
            lo <= exact + 1e-12 && exact <= hi + 1e-12,
            "{side}: {lo} {hi}"
        );
        assert!(hi - lo <= 0.01 * lo, "{side}: {lo} {hi}");
    }
    assert!(j["seconds"].as_f64().is_some());
    let out = vunify(&["measure", a, b, "--certified", "--tolerance", "2"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--tolerance must be between 0 and 1"));
}

/// `vunify simplify` with every method writes every mesh format vunify reads, and `--json` has the
/// summary; the output reads back with the triangle count the summary gives.
#[test]
fn simplify_every_method_and_format() {
    let input = tmp("simplify-box.obj");
    let box_mesh = vunify::fixtures::cuboid(glam::Vec3::new(2.0, 1.0, 1.0));
    std::fs::write(&input, vunify::export::obj_string(&box_mesh)).unwrap();
    for method in ["bounded", "offset-patch", "single-envelope", "cohen"] {
        for ext in ["obj", "ply", "off", "obj.xz", "glb", "gltf"] {
            let output = tmp(&format!("simplify-{method}.{ext}"));
            let args = [
                "simplify",
                input.to_str().unwrap(),
                "-o",
                output.to_str().unwrap(),
                "--method",
                method,
                "--epsilon",
                "0.05",
                "--json",
            ];
            let j: serde_json::Value = serde_json::from_str(&ok(&vunify(&args))).unwrap();
            assert_eq!(j["method"], method);
            assert!(j["seconds"].as_f64().is_some());
            let (back, _) =
                vunify::mesh::load(&output, &vunify::mesh::CleanOptions::default()).unwrap();
            assert_eq!(
                back.triangle_count() as u64,
                j["triangles"].as_u64().unwrap(),
                "{method} .{ext}"
            );
        }
    }
    let out = vunify(&["simplify", input.to_str().unwrap(), "-o", "out.stl"]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr)
            .contains("must end in .obj, .ply, .off (optionally .xz), .glb or .gltf")
    );
}

/// `vunify measure A B --certified --epsilon E` answers the question with its exit status: 0 when
/// both directions are proven at most E, 1 when a point is proven farther, 3 when the distance is
/// too close to E to tell, 2 for a usage error. Two triangles 0.5 apart: the distance is
/// 0.5 / √2 of the diagonal (√2), about 0.35355.
#[test]
fn measure_epsilon_answers_with_its_exit_status() {
    let a = tmp("verdict-a.obj");
    let b = tmp("verdict-b.obj");
    std::fs::write(&a, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(&b, "v 0 0 0.5\nv 1 0 0.5\nv 0 1 0.5\nf 1 2 3\n").unwrap();
    let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
    let status = |e: &str| {
        vunify(&["measure", a, b, "--certified", "--epsilon", e])
            .status
            .code()
    };
    assert_eq!(status("0.36"), Some(0));
    assert_eq!(status("0.35"), Some(1));
    // A hair above the exact value: proven within only with bounds tighter than the 1 % default.
    assert_eq!(status("0.353560"), Some(0));
    // Exactly on it (to f64): no finite search can tell.
    let exact = format!("{}", 0.5 / 2f64.sqrt());
    let out = vunify(&["measure", a, b, "--certified", "--epsilon", &exact]);
    assert_eq!(out.status.code(), Some(3), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("undecided"));
    assert_eq!(
        vunify(&["measure", a, b, "--epsilon", "0.1"]).status.code(),
        Some(2),
        "--epsilon needs --certified"
    );
    let out = vunify(&["measure", a, b, "--certified", "--epsilon", "-1"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("--epsilon must be between 0 and 1"));
}

/// `vunify simplify` reports the certified distance its result reached, both ways, for every
/// method (JSON and text); `bounded`'s is confirmed within ε by the meter before it writes.
#[test]
fn simplify_reports_the_certified_distance() {
    let input = tmp("certify-bumps.obj");
    let mesh = vunify::fixtures::cuboid(glam::Vec3::new(2.0, 1.0, 1.0));
    std::fs::write(&input, vunify::export::obj_string(&mesh)).unwrap();
    for method in ["bounded", "offset-patch", "single-envelope", "cohen"] {
        let output = tmp(&format!("certify-{method}.obj"));
        let (i, o) = (input.to_str().unwrap(), output.to_str().unwrap());
        let args = [
            "simplify",
            i,
            "-o",
            o,
            "--method",
            method,
            "--epsilon",
            "0.05",
        ];
        let mut json_args = args.to_vec();
        json_args.push("--json");
        let j: serde_json::Value = serde_json::from_str(&ok(&vunify(&json_args))).unwrap();
        let c = &j["certified"];
        for side in ["input_to_output", "output_to_input"] {
            let (lo, hi) = (
                c[side]["lower"].as_f64().unwrap(),
                c[side]["upper"].as_f64().unwrap(),
            );
            assert!(lo <= hi, "{method} {side}");
        }
        if method == "bounded" {
            assert_eq!(c["within_epsilon_both_ways"], true, "{j}");
        }
        let text = ok(&vunify(&args));
        assert!(text.contains("certified  input → output"), "{text}");
        let claims = c["within_epsilon_both_ways"] == true;
        assert_eq!(text.contains("NOT within ε"), !claims, "{text}");
    }
}

/// `vunify radiosity` with a budget: `--max-shots` and `--max-seconds` stop the solve and still
/// write the lit mesh with its unshot share; the JSON says why it stopped. Ctrl-C does the same,
/// and progress reaches a standard error that is not a terminal.
#[test]
fn radiosity_budget_and_interrupt() {
    let dir = tmp("furnace");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("f.mtl"), "newmtl glow\nKd 0.9 0.9 0.9\nKe 1 1 1\n").unwrap();
    std::fs::write(
        dir.join("f.obj"),
        "mtllib f.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
         usemtl glow\nf 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 4 3 7 8\nf 1 4 8 5\nf 2 6 7 3\n",
    )
    .unwrap();
    let scene = dir.join("f.obj");
    let lit = dir.join("f.ply");
    let run = |extra: &[&str]| {
        let _ = std::fs::remove_file(&lit);
        let mut args = vec![
            "radiosity",
            scene.to_str().unwrap(),
            "-o",
            lit.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        args.push("--json");
        let j: serde_json::Value = serde_json::from_str(&ok(&vunify(&args))).unwrap();
        assert!(lit.exists());
        j
    };
    let j = run(&["--max-shots", "3", "--element-size", "0.1"]);
    assert_eq!(j["stop"], "max-shots");
    assert!(j["unshot"].as_f64().unwrap() > 0.01, "{j}");
    let j = run(&["--max-seconds", "0", "--element-size", "0.1"]);
    assert_eq!(j["stop"], "max-seconds");

    // Ctrl-C once plain progressive refinement (which would take minutes) reports shots on a
    // standard error that is not a terminal.
    let _ = std::fs::remove_file(&lit);
    let mut child = Command::new(env!("CARGO_BIN_EXE_vunify"))
        .args([
            "radiosity",
            scene.to_str().unwrap(),
            "-o",
            lit.to_str().unwrap(),
        ])
        .args([
            "--no-overshoot",
            "--no-ambient",
            "--unshot",
            "1e-9",
            "--json",
        ])
        .args(["--element-size", "0.05"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let mut progress = String::new();
    let mut lines = std::io::BufRead::lines(std::io::BufReader::new(stderr));
    for line in lines.by_ref() {
        let line = line.unwrap();
        progress.push_str(&line);
        if line.starts_with("radiosity: ") && line.contains("shots") {
            break;
        }
    }
    assert!(progress.contains("shots"), "{progress}");
    // Keep reading, so that what it writes after the interrupt finds the pipe open.
    let rest = std::thread::spawn(move || lines.map_while(Result::ok).collect::<Vec<_>>());
    // SAFETY: sending a signal to our own child process, whose pid is valid until it is reaped.
    unsafe {
        libc::kill(child.id() as libc::pid_t, libc::SIGINT);
    }
    let out = child.wait_with_output().unwrap();
    let j: serde_json::Value = serde_json::from_str(&ok(&out)).unwrap();
    assert_eq!(j["stop"], "interrupted");
    assert!(lit.exists());
    rest.join().unwrap();
}

/// Bad scenes name what is wrong: a missing material library by its file, an unknown material by
/// its name, a bow-tie quad as a polygon that crosses itself; a negative option gets the option's
/// own message, not a parse error.
#[test]
fn bad_scenes_say_what_is_wrong() {
    let dir = tmp("bad-scenes");
    std::fs::create_dir_all(&dir).unwrap();
    let lit = dir.join("out.ply");
    let err = |obj: &str, mtl: Option<&str>| {
        let scene = dir.join("s.obj");
        std::fs::write(&scene, obj).unwrap();
        if let Some(mtl) = mtl {
            std::fs::write(dir.join("s.mtl"), mtl).unwrap();
        } else {
            let _ = std::fs::remove_file(dir.join("s.mtl"));
        }
        let out = vunify(&[
            "radiosity",
            scene.to_str().unwrap(),
            "-o",
            lit.to_str().unwrap(),
        ]);
        assert_eq!(out.status.code(), Some(1));
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let square = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
    let light = "newmtl light\nKd 0.5 0.5 0.5\nKe 1 1 1\n";
    let e = err(
        &format!("mtllib s.mtl\n{square}usemtl light\nf 1 2 3 4\n"),
        None,
    );
    assert!(e.contains("s.mtl") && e.contains("line 1"), "{e}");
    let e = err(
        &format!("mtllib s.mtl\n{square}usemtl paint\nf 1 2 3 4\n"),
        Some(light),
    );
    assert!(
        e.contains("'paint'") && e.contains("line 6") && e.contains("light"),
        "{e}"
    );
    let e = err(
        &format!("mtllib s.mtl\n{square}usemtl light\nf 1 2 4 3\n"),
        Some(light),
    );
    assert!(e.contains("crosses itself"), "{e}");
    let out = vunify(&["superfaces", "x.ply", "-o", "y.ply", "--epsilon", "-1"]);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--epsilon must be"),
        "{out:?}"
    );
    let out = vunify(&["simplify", "x.obj", "-o", "y.obj", "--epsilon", "-1"]);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--epsilon must be"),
        "{out:?}"
    );
}

/// `extract --lod-chain` writes one glTF with a mesh and a scene per level, the finest the
/// default, each level's ratio, triangles, error and bound in its `extras`, coarser levels with
/// fewer triangles and no smaller error; a ratio out of range or a non-glTF output is refused.
#[test]
fn extract_a_lod_chain() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/cessna.obj");
    let tree = tmp("chain.vtree");
    let t = tree.to_str().unwrap();
    ok(&vunify(&["build", model, "-o", t]));
    let out = tmp("chain.glb");
    let o = out.to_str().unwrap();
    ok(&vunify(&[
        "extract",
        t,
        "--lod-chain",
        "0.5,0.25,0.1,0.01",
        "-o",
        o,
    ]));
    let glb = std::fs::read(&out).unwrap();
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    assert_eq!(doc["scene"], 0);
    let scenes = doc["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 4);
    assert_eq!(doc["meshes"].as_array().unwrap().len(), 4);
    let mut last = (u64::MAX, 0.0);
    for (k, (scene, ratio)) in scenes.iter().zip([0.5, 0.25, 0.1, 0.01]).enumerate() {
        let extras = &scene["extras"];
        assert_eq!(extras["ratio"], ratio, "LOD{k}");
        assert_eq!(doc["meshes"][k]["extras"], *extras);
        let triangles = extras["triangles"].as_u64().unwrap();
        let want = (13546.0 * ratio) as u64;
        assert!(
            triangles <= want + 1 && triangles + want / 20 >= want,
            "LOD{k}: {triangles}"
        );
        let error = extras["error"].as_f64().unwrap();
        assert!(triangles < last.0 && error >= last.1, "LOD{k}");
        assert!(extras["bound"].as_f64().unwrap() >= error, "LOD{k}");
        last = (triangles, error);
    }
    let bad = vunify(&["extract", t, "--lod-chain", "0.5,2", "-o", o]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("got 2"));
    let obj = tmp("chain.obj");
    let bad = vunify(&[
        "extract",
        t,
        "--lod-chain",
        "0.5",
        "-o",
        obj.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&bad.stderr).contains(".glb or .gltf"));
    assert!(!obj.exists());
}

/// `vunify` with no command and no display (what `scripts/run.sh` does on a headless machine): it
/// says so, builds the bundled textured water bottle's tree and renders the default camera path.
#[test]
fn the_default_job_renders_the_bundled_model_headless() {
    let dir = tmp("default-job");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_vunify"))
        .current_dir(&dir)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        // Without a GPU outside CI, the build must still have happened and the error be the adapter's.
        assert!(
            std::env::var_os("CI").is_none() && err.contains("no Vulkan adapter"),
            "{stdout}\n{err}"
        );
    } else {
        assert!(
            dir.join("out/default-path/contact_sheet.png").is_file(),
            "{stdout}"
        );
    }
    assert!(
        stdout.contains("WaterBottle.glb") && stdout.contains("no display"),
        "{stdout}"
    );
    let tree = vunify::vtree::read(&dir.join("out/WaterBottle.vtree")).unwrap();
    let appearance = tree.appearance.expect("the bundled model is textured");
    assert!(!appearance.textures.is_empty());
    assert!(tree.materials.is_some());
}

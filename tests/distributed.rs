//! The partitioned build in separate steps (`build --plan`, `cell`, `join`) and on Ray, run as a
//! user runs them: the same tree byte for byte as one process, whatever order the cells run in and
//! whoever picks their index; a missing, corrupt or foreign cell refused by name.

mod common;

use common::ok;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const CESSNA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/cessna.obj");
/// The cessna (13,546 triangles) in cells of at most 2000: 8 cells.
const CELL: &str = "2000";

fn vunify(args: &[&str]) -> Output {
    vunify_env(args, &[])
}

fn vunify_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_vunify"));
    c.args(args)
        .env_remove("JOB_COMPLETION_INDEX")
        .env_remove("SLURM_ARRAY_TASK_ID");
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("run vunify")
}

/// The error of a command that must fail with exit status 1.
fn fails(out: &Output) -> String {
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    String::from_utf8(out.stderr.clone()).unwrap()
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vunify-distributed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The one-process tree the steps must reproduce.
fn one_process(name: &str) -> Vec<u8> {
    let out = tmp(name);
    ok(&vunify(&[
        "build",
        CESSNA,
        "-o",
        s(&out),
        "--cell-triangles",
        CELL,
    ]));
    std::fs::read(out).unwrap()
}

/// Plans the cessna into `dir`; returns its cell count.
fn plan(dir: &Path) -> u32 {
    let said = ok(&vunify(&[
        "build",
        CESSNA,
        "--cell-triangles",
        CELL,
        "--plan",
        s(dir),
        "--json",
    ]));
    let json: serde_json::Value = serde_json::from_str(&said).unwrap();
    json["cells"].as_u64().unwrap() as u32
}

/// Plan, the cells in reverse order (by `--index`, and one each by a Kubernetes and a SLURM array
/// index), join: the one-process tree, byte for byte, and `info --check` passes.
#[test]
fn steps_make_the_one_process_tree() {
    let dir = tmp("plan");
    let cells = plan(&dir);
    assert_eq!(cells, 8);
    for i in (2..cells).rev() {
        ok(&vunify(&["cell", s(&dir), "--index", &i.to_string()]));
    }
    ok(&vunify_env(
        &["cell", s(&dir)],
        &[("JOB_COMPLETION_INDEX", "1")],
    ));
    ok(&vunify_env(
        &["cell", s(&dir)],
        &[("SLURM_ARRAY_TASK_ID", "0")],
    ));
    let joined = tmp("joined.vtree");
    let said = ok(&vunify(&["join", s(&dir), "-o", s(&joined)]));
    assert!(
        said.contains("cells      8 of at most 2000 triangles"),
        "{said}"
    );
    assert_eq!(std::fs::read(&joined).unwrap(), one_process("whole.vtree"));
    let info = ok(&vunify(&["info", s(&joined), "--check"]));
    assert!(
        info.contains("every cut of the build order is a valid mesh"),
        "{info}"
    );
    // `--exact` on both sides: the f32 layout (version 1), again the same bytes.
    let exact = tmp("joined-exact.vtree");
    ok(&vunify(&["join", s(&dir), "-o", s(&exact), "--exact"]));
    let whole = tmp("whole-exact.vtree");
    ok(&vunify(&[
        "build",
        CESSNA,
        "-o",
        s(&whole),
        "--cell-triangles",
        CELL,
        "--exact",
    ]));
    let bytes = std::fs::read(&exact).unwrap();
    assert_eq!(bytes[8], 1);
    assert_eq!(bytes, std::fs::read(&whole).unwrap());
}

/// The join refuses a missing cell, a corrupt one (a flipped byte), a truncated one, another
/// cell's file under its name, and a cell of another plan; each error names the file, and no
/// tree is written. A cell index out of the plan, or none at all, is refused by `cell`.
#[test]
fn the_join_refuses_missing_and_corrupt_cells() {
    let dir = tmp("bad-plan");
    let cells = plan(&dir);
    for i in 0..cells {
        ok(&vunify(&["cell", s(&dir), "--index", &i.to_string()]));
    }
    let out = tmp("bad.vtree");
    let cell3 = dir.join("cell-3.out");
    let good = std::fs::read(&cell3).unwrap();
    let join = || {
        let e = fails(&vunify(&["join", s(&dir), "-o", s(&out)]));
        assert!(!out.exists(), "a tree was written despite: {e}");
        e
    };

    std::fs::remove_file(&cell3).unwrap();
    let e = join();
    assert!(
        e.contains("cell-3.out: missing") && e.contains("--index 3"),
        "{e}"
    );

    let mut flipped = good.clone();
    flipped[good.len() / 2] ^= 0x20;
    std::fs::write(&cell3, &flipped).unwrap();
    assert!(join().contains("cell-3.out: corrupt or truncated"));

    std::fs::write(&cell3, &good[..good.len() - 100]).unwrap();
    assert!(join().contains("cell-3.out: corrupt or truncated"));

    std::fs::copy(dir.join("cell-4.out"), &cell3).unwrap();
    assert!(join().contains("cell-3.out: holds cell 4, not cell 3"));

    // A cell of another plan: the same cessna in cells of another size.
    let other = tmp("other-plan");
    ok(&vunify(&[
        "build",
        CESSNA,
        "--cell-triangles",
        "1900",
        "--plan",
        s(&other),
    ]));
    ok(&vunify(&["cell", s(&other), "--index", "3"]));
    std::fs::copy(other.join("cell-3.out"), &cell3).unwrap();
    assert!(join().contains("belongs to another plan"));

    std::fs::write(&cell3, &good).unwrap();
    ok(&vunify(&["join", s(&dir), "-o", s(&out)]));

    let e = fails(&vunify(&["cell", s(&dir), "--index", "8"]));
    assert!(
        e.contains("cell 8 is not in the plan") && e.contains("8 cells"),
        "{e}"
    );
    assert!(fails(&vunify(&["cell", s(&dir)])).contains("which cell?"));
    let e = fails(&vunify(&["join", s(&tmp("no-plan")), "-o", s(&out)]));
    assert!(e.contains("plan.json") && e.contains("--plan"), "{e}");
    // A plan is of a build in cells: --plan alone is a usage error.
    let alone = vunify(&["build", CESSNA, "--plan", s(&tmp("no-cells"))]);
    assert_eq!(alone.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&alone.stderr).contains("--cell-triangles"));
}

/// The Python that has Ray: scripts/test.sh's virtual environment (`VUNIFY_PYTHON`), or
/// `python3`. `None` outside CI when neither has Ray; in CI that is a failure.
fn python_with_ray() -> Option<String> {
    let python = std::env::var("VUNIFY_PYTHON").unwrap_or_else(|_| "python3".into());
    let has_ray = Command::new(&python)
        .args(["-c", "import ray"])
        .output()
        .is_ok_and(|o| o.status.success());
    if has_ray {
        return Some(python);
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "CI runs the Ray test: {python} has no `ray` (scripts/test.sh installs it)"
    );
    eprintln!("skipped: {python} has no `ray` (scripts/test.sh installs it)");
    None
}

/// `scripts/ray_build.py` on a local Ray instance (2 CPUs): the cells as Ray tasks, one of them
/// crashing on its first try (a wrapper that fails once for cell 1) and retried, and the tree
/// byte for byte the one-process build's.
#[test]
fn ray_driver_makes_the_one_process_tree() {
    let Some(python) = python_with_ray() else {
        return;
    };
    let wrapper = tmp("flaky-vunify.sh");
    std::fs::write(
        &wrapper,
        format!(
            "#!/bin/sh\n\
             if [ \"$1\" = cell ] && [ \"$4\" = 1 ] && [ ! -e \"$2/.failed-once\" ]; then\n\
               touch \"$2/.failed-once\"; echo 'simulated crash' >&2; exit 9\n\
             fi\n\
             exec '{}' \"$@\"\n",
            env!("CARGO_BIN_EXE_vunify")
        ),
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&wrapper, std::fs::Permissions::from_mode(0o755)).unwrap();
    let out = tmp("ray.vtree");
    let driver = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/ray_build.py");
    let run = Command::new(python)
        .args([driver, CESSNA, s(&out), "--cell-triangles", CELL])
        .args(["--vunify", s(&wrapper), "--num-cpus", "2"])
        .env_remove("RAY_ADDRESS")
        .output()
        .expect("run the Ray driver");
    let said = ok(&run);
    assert!(
        said.contains("(8/8)") && said.contains("join       wrote"),
        "{said}"
    );
    assert!(
        said.contains("cell       1 failed") && said.contains("simulated crash"),
        "no cell was retried: {said}"
    );
    assert_eq!(std::fs::read(&out).unwrap(), one_process("for-ray.vtree"));
}

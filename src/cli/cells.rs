//! A build in separate steps (docs/DISTRIBUTED.md): `vunify build IN --cell-triangles N --plan DIR`
//! writes the plan, `vunify cell DIR --index I` builds one cell, `vunify join DIR -o OUT.vtree`
//! finishes the tree.

use super::build::{How, build_and_write};
use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vunify::mesh::{self, CleanOptions};
use vunify::vtree::{BuildOptions, cells};

/// What `plan.json` records: everything the join needs to rebuild the plan's shared data.
#[derive(serde::Serialize, serde::Deserialize)]
struct PlanFile {
    /// The input mesh, as an absolute path: the join reads it again.
    input: PathBuf,
    cell_triangles: usize,
    weld: bool,
    options: BuildOptions,
    cells: u32,
    id: u32,
}

fn plan_path(dir: &Path) -> PathBuf {
    dir.join("plan.json")
}

/// The plan step: loads `input`, writes `dir/plan.json` and a `cell-I.in` per cell.
pub fn plan(
    input: &Path,
    options: &BuildOptions,
    clean: &CleanOptions,
    how: How,
    dir: &Path,
    json: bool,
) -> Result<()> {
    let t0 = Instant::now();
    let input = std::path::absolute(input)
        .with_context(|| format!("cannot resolve {}", input.display()))?;
    let (mesh, cleaned) = mesh::load(&input, clean)?;
    for note in &cleaned.notes {
        eprintln!("note: {}: {note}", input.display());
    }
    // A budget a whole build fits is one cell of every triangle: the join builds it whole.
    let cell_triangles = match super::build::resolve(how, &input, &mesh)? {
        How::Cells(cells) => cells,
        _ => mesh.triangle_count().max(1),
    };
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let plan = cells::plan(&mesh, options, cell_triangles, dir)?;
    let file = PlanFile {
        input: input.clone(),
        cell_triangles,
        weld: clean.weld,
        options: options.clone(),
        cells: plan.cells,
        id: plan.id,
    };
    let path = plan_path(dir);
    vunify::export::write_atomic(&path, &serde_json::to_vec_pretty(&file)?)
        .with_context(|| format!("cannot write {}", path.display()))?;
    if json {
        let out = serde_json::json!({
            "plan": path, "cells": plan.cells, "id": plan.id, "triangles": mesh.triangle_count(),
            "seconds": t0.elapsed().as_secs_f64(),
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!("input      {}", input.display());
    println!(
        "           {} vertices, {} triangles",
        mesh.vertex_count(),
        mesh.triangle_count()
    );
    if plan.cells == 0 {
        println!("cells      none: the mesh is built whole by the join");
    } else {
        println!(
            "cells      {} of at most {cell_triangles} triangles: cell-0.in … cell-{}.in",
            plan.cells,
            plan.cells - 1
        );
    }
    println!(
        "wrote      {} in {:.2} s",
        path.display(),
        t0.elapsed().as_secs_f64()
    );
    println!(
        "next       vunify cell {0} --index I   (I = 0 … {1}, anywhere, in any order)\n           \
         vunify join {0} -o OUT.vtree",
        dir.display(),
        plan.cells.saturating_sub(1)
    );
    Ok(())
}

#[derive(Args)]
pub struct CellArgs {
    /// The plan's folder (`vunify build IN --cell-triangles N --plan DIR`).
    dir: PathBuf,
    /// Which cell, from 0. Default: the batch system's array index, `JOB_COMPLETION_INDEX`
    /// (Kubernetes Indexed Job) or `SLURM_ARRAY_TASK_ID` (SLURM array).
    #[arg(long)]
    index: Option<u32>,
}

/// The cell index: `--index`, or the batch system's.
fn cell_index(args: &CellArgs) -> Result<u32> {
    if let Some(i) = args.index {
        return Ok(i);
    }
    for var in ["JOB_COMPLETION_INDEX", "SLURM_ARRAY_TASK_ID"] {
        if let Ok(value) = std::env::var(var) {
            return value
                .trim()
                .parse()
                .with_context(|| format!("{var}={value:?} is not a cell index"));
        }
    }
    bail!(
        "which cell? give --index I (or run under a batch array: JOB_COMPLETION_INDEX, SLURM_ARRAY_TASK_ID)"
    )
}

pub fn run_cell(args: CellArgs) -> Result<()> {
    let t0 = Instant::now();
    let index = cell_index(&args)?;
    let plan = read_plan(&args.dir)?;
    if index >= plan.cells {
        bail!(
            "cell {index} is not in the plan {}: it has {} cells (0 … {})",
            plan_path(&args.dir).display(),
            plan.cells,
            plan.cells.saturating_sub(1)
        );
    }
    cells::build_cell(&args.dir, index)?;
    println!(
        "cell {index}: built in {:.2} s, wrote {}",
        t0.elapsed().as_secs_f64(),
        cells::cell_output_path(&args.dir, index).display()
    );
    Ok(())
}

#[derive(Args)]
pub struct JoinArgs {
    /// The plan's folder, its cells built (`vunify cell DIR --index I` for every I).
    dir: PathBuf,
    /// Output .vtree file (written atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// Write the exact layout, as `vunify build --exact` does.
    #[arg(long)]
    exact: bool,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

pub fn run_join(args: JoinArgs) -> Result<()> {
    let plan = read_plan(&args.dir)?;
    let clean = CleanOptions { weld: plan.weld };
    build_and_write(
        &plan.input,
        &args.output,
        &plan.options,
        &clean,
        How::Join(&args.dir, plan.cell_triangles),
        super::build::encoding(args.exact),
        args.json,
    )
}

fn read_plan(dir: &Path) -> Result<PlanFile> {
    let path = plan_path(dir);
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!(
            "cannot read {}: plan first with `vunify build IN --cell-triangles N --plan {}`",
            path.display(),
            dir.display()
        )
    })?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a vunify plan", path.display()))
}

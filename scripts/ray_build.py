#!/usr/bin/env python3
"""Build a vertex tree on a Ray cluster: the cells of a partitioned build as Ray tasks.

    scripts/ray_build.py IN OUT.vtree [--cell-triangles N | --memory SIZE] [--address ADDR]
                         [--vunify PATH] [--plan-dir DIR] [--retries K] [--keep]

The three steps are vunify's own (docs/DISTRIBUTED.md): this driver runs `vunify build IN
--cell-triangles N --plan DIR` (or `--memory SIZE`, which picks the cells) here, `vunify cell DIR
--index I` once per cell as a Ray task (retried when it fails, up to --retries times), and
`vunify join DIR -o OUT.vtree` here. The tree is byte for byte the one of `vunify build IN -o
OUT.vtree --cell-triangles N` (or `--memory SIZE`, on this machine) in one process.

Every task reads and writes DIR, so DIR must be a path every node of the cluster sees (NFS, a
shared volume, an object store mounted as a folder); by default it is made beside OUT. Without
--address the driver starts a local Ray instance (or joins the one RAY_ADDRESS names).
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import ray


def run(command):
    """Runs a vunify command; its stderr becomes the error when it fails."""
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)}: {done.stderr.strip() or done.returncode}")
    return done.stdout


@ray.remote
def build_cell(vunify, plan_dir, index):
    """One cell, on whichever node Ray picks."""
    started = time.time()
    run([vunify, "cell", plan_dir, "--index", str(index)])
    return index, time.time() - started


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("input", help="the mesh (any format vunify build reads)")
    parser.add_argument("output", help="the .vtree to write")
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--cell-triangles", type=int,
                      help="cell size, as vunify build --cell-triangles (default 1000000)")
    size.add_argument("--memory", metavar="SIZE",
                      help="the cells that keep a one-process build within SIZE (64M, 8G), "
                      "as vunify build --memory, chosen on this machine")
    parser.add_argument("--address", help="the Ray cluster (ray.init address); default: local")
    parser.add_argument("--vunify", help="the vunify binary (default: the one on PATH)")
    parser.add_argument("--plan-dir", help="the shared folder for the plan and cells "
                        "(default: a new folder beside OUTPUT)")
    parser.add_argument("--retries", type=int, default=3, help="times a failed cell is retried")
    parser.add_argument("--num-cpus", type=int, help="CPUs of a local Ray instance")
    parser.add_argument("--keep", action="store_true", help="keep the plan folder afterwards")
    args = parser.parse_args()

    vunify = args.vunify or shutil.which("vunify")
    if not vunify:
        sys.exit("error: no vunify on PATH; give --vunify PATH")
    vunify = os.path.abspath(vunify)
    out_dir = os.path.dirname(os.path.abspath(args.output))
    plan_dir = args.plan_dir or tempfile.mkdtemp(prefix=".vunify-plan-", dir=out_dir)
    plan_dir = os.path.abspath(plan_dir)

    try:
        started = time.time()
        cells_by = (["--memory", args.memory] if args.memory else
                    ["--cell-triangles", str(args.cell_triangles or 1_000_000)])
        plan = json.loads(run([vunify, "build", args.input, *cells_by, "--plan", plan_dir,
                               "--json"]))
        cells = plan["cells"]
        print(f"plan       {cells} cells in {plan_dir} ({time.time() - started:.1f} s)", flush=True)

        if cells:
            if args.address:
                ray.init(address=args.address)
            else:
                ray.init(num_cpus=args.num_cpus)
            # Ray itself retries a task whose worker or node died; a cell step that failed
            # (its exit status) is retried here, where it can be reported.
            task = build_cell.options(max_retries=args.retries)
            pending = {task.remote(vunify, plan_dir, i): (i, 0) for i in range(cells)}
            done = 0
            while pending:
                [ready], _ = ray.wait(list(pending))
                index, tries = pending.pop(ready)
                try:
                    _, seconds = ray.get(ready)
                except ray.exceptions.RayError as e:
                    cause = str(e.cause if hasattr(e, "cause") else e).strip().splitlines()[-1]
                    if tries >= args.retries:
                        raise RuntimeError(f"cell {index} failed {tries + 1} times: {cause}")
                    print(f"cell       {index} failed ({cause}); retry {tries + 1} of "
                          f"{args.retries}", flush=True)
                    pending[task.remote(vunify, plan_dir, index)] = (index, tries + 1)
                    continue
                done += 1
                print(f"cell       {index} built in {seconds:.1f} s ({done}/{cells})", flush=True)
            ray.shutdown()

        started = time.time()
        run([vunify, "join", plan_dir, "-o", args.output])
        print(f"join       wrote {args.output} ({time.time() - started:.1f} s)", flush=True)
    except (RuntimeError, ray.exceptions.RayError) as e:
        sys.exit(f"error: {e}")
    finally:
        if not args.keep and not args.plan_dir:
            shutil.rmtree(plan_dir, ignore_errors=True)


if __name__ == "__main__":
    main()

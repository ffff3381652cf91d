"""Batches before and after a change: two checkouts of deik taking turns on the same batches.

    PYTHONPATH=src python -m benchmarks.before_after --before ../before [--batch 10000] [--repeats 3]

--before is a checkout of an earlier commit (`git worktree add ../before COMMIT`). Each checkout
runs in its own long-lived worker process (this module with --worker, its src/ first on the
path), which builds the problems and compiles or loads its kernels before the first turn. Then,
repeat by repeat, every case runs once in each worker, the order swapped every repeat so load
drift hits both alike. Cases, seeded as benchmarks.batch's:
- chain20: deik.chain(20), Position("tip") within 1 % of its reach, population 16, float32;
- panda: 6-D tip targets at 1e-5 m / 1e-4 rad from the mid-limit pose, the settings of
  benchmarks.peers.deik_peer (float64), scored here by benchmarks.robot_targets.pose_errors.
Writes results/before_after/batches.{json,md} atomically; problems per second are the batch
over its wall time (the call to deik.solve, set-up included), best of the repeats and median.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CASES = ("chain20", "panda")
CHAIN_SETTINGS = {"population": 16, "dtype": "float32"}


def _worker(batch: int, seed: int) -> int:
    """Serve turns: each stdin line names a case; answer one JSON line {seconds, success}."""
    import deik
    from benchmarks.harness import chain_problem
    from benchmarks.peers.deik_peer import SETTINGS, STRICT
    from benchmarks.robot_targets import make_targets, pose_errors

    chain = chain_problem(20, batch, seed, tolerance=0.01 * deik.chain(20).reach)
    targets = make_targets("panda", batch, seed)
    skeleton = deik.read_urdf(targets["urdf"], targets["base"], targets["tip"])
    tip, start = targets["tip"], targets["start"][None]
    panda = deik.Problem(
        skeleton,
        [
            deik.Position(tip, targets["positions"], tolerance=STRICT[0]),
            deik.Orientation(tip, targets["rotations"], tolerance=STRICT[1]),
        ],
    )

    def run(case: str) -> dict:
        t0 = time.perf_counter()
        if case == "chain20":
            result = deik.solve(chain, seed=seed, **CHAIN_SETTINGS)
            seconds = time.perf_counter() - t0
            return {"seconds": seconds, "success": float(np.mean(result.converged))}
        result = deik.solve(panda, initial=start, seed=seed, **SETTINGS)
        seconds = time.perf_counter() - t0
        pos, rot, inside = pose_errors(skeleton, tip, result.angles, targets["positions"], targets["rotations"])
        return {"seconds": seconds, "success": float(np.mean((pos <= STRICT[0]) & (rot <= STRICT[1]) & inside))}

    for case in CASES:  # compile or load the kernels, untimed
        run(case)
    print(json.dumps({"ready": deik.__file__}), flush=True)
    for line in sys.stdin:
        print(json.dumps(run(line.strip())), flush=True)
    return 0


def _start(tree: Path, batch: int, seed: int) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join((str(tree / "src"), str(ROOT)))}
    command = [sys.executable, "-m", "benchmarks.before_after", "--worker", "--batch", str(batch), "--seed", str(seed)]
    return subprocess.Popen(command, cwd=ROOT, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)


def _ask(worker: subprocess.Popen, case: str) -> dict:
    worker.stdin.write(case + "\n")
    worker.stdin.flush()
    return json.loads(worker.stdout.readline())


def _commit(tree: Path) -> str:
    done = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    return done.stdout.strip() or str(tree)


def markdown(result: dict) -> str:
    lines = [
        f"Batches of {result['batch']} problems, before ({result['trees']['before']}) and after "
        f"({result['trees']['after']}) taking turns, {result['repeats']} repeats; CPU {result['cpu_model']}, "
        "2 threads, shared and noisy.",
        "",
        "| case | tree | problems/s (best) | problems/s (median) | success |",
        "|---|---|---:|---:|---:|",
    ]
    for case, rows in result["cases"].items():
        for tree, row in rows.items():
            lines.append(
                f"| {case} | {tree} | {row['best_per_second']:.0f} | {row['median_per_second']:.0f} | "
                f"{100 * row['success']:.1f} % |"
            )
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--before", type=Path, help="a checkout of the earlier deik")
    p.add_argument("--batch", type=int, default=10000, help="problems per batch")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "before_after")
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.worker:
        return _worker(a.batch, a.seed)
    if a.before is None or not (a.before / "src" / "deik").is_dir():
        p.error("--before DIR: give a checkout of deik (git worktree add DIR COMMIT)")
    from benchmarks.serial_vs_parallel import write_atomic
    from deik.experiments.timing import cpu_model, environment

    trees = {"before": a.before.resolve(), "after": ROOT}
    workers = {name: _start(tree, a.batch, a.seed) for name, tree in trees.items()}
    for name, worker in workers.items():
        print(f"{name}: {json.loads(worker.stdout.readline())['ready']}", file=sys.stderr, flush=True)
    turns: dict = {case: {name: [] for name in trees} for case in CASES}
    for repeat in range(a.repeats):
        order = list(trees) if repeat % 2 == 0 else list(trees)[::-1]
        for case in CASES:
            for name in order:
                turns[case][name].append(_ask(workers[name], case))
        print(f"repeat {repeat + 1}/{a.repeats} done", file=sys.stderr, flush=True)
    for worker in workers.values():
        worker.stdin.close()
        worker.wait()
    result = {
        "benchmark": "before_after",
        "command": "PYTHONPATH=src python -m benchmarks.before_after " + " ".join(argv or sys.argv[1:]),
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "batch": a.batch,
        "repeats": a.repeats,
        "trees": {name: _commit(tree) for name, tree in trees.items()},
        "settings": {"chain20": CHAIN_SETTINGS, "panda": "benchmarks.peers.deik_peer.SETTINGS"},
        "cpu_model": cpu_model(),
        "environment": environment(),
        "cases": {
            case: {
                name: {
                    "seconds": [t["seconds"] for t in runs],
                    "best_per_second": a.batch / min(t["seconds"] for t in runs),
                    "median_per_second": a.batch / float(np.median([t["seconds"] for t in runs])),
                    "success": min(t["success"] for t in runs),
                }
                for name, runs in rows.items()
            }
            for case, rows in turns.items()
        },
    }
    text = markdown(result)
    write_atomic(a.out / "batches.json", lambda tmp: Path(tmp).write_text(json.dumps(result, indent=2) + "\n"))
    write_atomic(a.out / "batches.md", lambda tmp: Path(tmp).write_text(text))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Robot IK benchmark on the TRAC-IK protocol: deik and peer IK libraries on the same targets.

    PYTHONPATH=src python -m benchmarks.robots [--targets 500] [--chunks 10] [--cases panda iiwa human]
                                              [--peers all|none|ikpy,pk,...] [--before TREE]
                                              [--out benchmarks/results]

Per case (benchmarks.robot_targets): N random in-limit poses of the tip, every solver starting
from the mid-limit pose. The targets are split into chunks and the solvers take turns on each
chunk (benchmarks.robot_turns): deik one target per call (building the Problem and deik.solve),
deik through one reused deik.Solver that swaps the targets, deik on the chunk as one batch, then
each peer, a long-lived process in .venv-peers (benchmarks.peer_process) whose local solvers
restart from random in-limit poses within 5 ms per target. Peers are skipped, with the reason
recorded, when that venv is missing or the peer fails. Every answer is scored by
robot_targets.pose_errors (deik's float64 FK): success = within 1e-5 m and 1e-4 rad with every
joint in its limits; also at 1e-3 m / 1e-2 rad, and the strict success reached within 5 ms.
--before TREE adds "deik-before": the deik of another checkout (e.g. `git worktree add
../before COMMIT`) through a reused Solver in its own process (benchmarks.peers.deik_peer),
taking its turn on every chunk beside the current deik: before and after in one run.
Writes results/robots.{json,md,png} atomically.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import deik
from benchmarks.peer_process import PeerFailed, PeerProcess
from benchmarks.peers.deik_peer import SETTINGS as DEIK
from benchmarks.peers.run_peer import PEERS
from benchmarks.robot_report import markdown, plot
from benchmarks.robot_targets import CASES, ROBOTS, load_case, make_targets, pose_errors, save_targets
from benchmarks.robot_turns import run_turns
from benchmarks.serial_vs_parallel import RESULTS, write_atomic
from deik.experiments.timing import cpu_model, environment

STRICT, LOOSE, BUDGET_S = (1e-5, 1e-4), (1e-3, 1e-2), 0.005
LIBRARY_PEERS = tuple(name for name in PEERS if name != "deik")  # in .venv-peers; deik's own is --before
BEFORE = "deik-before"
DEIK_TURNS = ("deik", "deik-solver", "deik-batch")


def deik_problem(skeleton, tip, positions, rotations) -> deik.Problem:
    """Tip pose goals at the strict tolerances; targets (3,) / (3, 3) or batched (B, 3) / (B, 3, 3)."""
    return deik.Problem(
        skeleton,
        [deik.Position(tip, positions, tolerance=STRICT[0]), deik.Orientation(tip, rotations, tolerance=STRICT[1])],
    )


def solve_deik_single(skeleton, tip, position, rotation, start, seed) -> np.ndarray:
    """One target: position (3,) m, rotation (3, 3), start (D,) -> angles (D,)."""
    result = deik.solve(deik_problem(skeleton, tip, position, rotation), seed=seed, initial=start[None], **DEIK)
    return result.angles


def solve_deik_batch(skeleton, tip, positions, rotations, start, seed) -> np.ndarray:
    """B targets in one call: positions (B, 3), rotations (B, 3, 3), start (D,) -> angles (B, D)."""
    result = deik.solve(deik_problem(skeleton, tip, positions, rotations), seed=seed, initial=start[None], **DEIK)
    return result.angles


def deik_runners(skeleton, targets: dict, seed: int) -> dict:
    """deik's three turns as runners (start, stop) -> {"angles", "seconds"} (+ "wall" per batch).
    Compilation and the reused Solver's set-up happen here, untimed. Target k gets seed + k in
    the single and reused solves; a batch gets seed + its first index."""
    tip, start = targets["tip"], targets["start"]
    P, R = targets["positions"], targets["rotations"]
    solve_deik_single(skeleton, tip, P[0], R[0], start, seed)
    solve_deik_batch(skeleton, tip, P[:2], R[:2], start, seed)
    solver = deik.Solver(deik_problem(skeleton, tip, P[0], R[0]), **DEIK)
    labels = solver.problem.table.labels
    solver.solve({labels[0]: P[0], labels[1]: R[0]}, initial=start[None], seed=seed)

    def timed(solve_one):
        def run(a: int, b: int) -> dict:
            angles, seconds = [], []
            for k in range(a, b):
                t0 = time.perf_counter()
                angles.append(solve_one(k))
                seconds.append(time.perf_counter() - t0)
            return {"angles": angles, "seconds": seconds}

        return run

    def batch(a: int, b: int) -> dict:
        t0 = time.perf_counter()
        angles = solve_deik_batch(skeleton, tip, P[a:b], R[a:b], start, seed + a)
        wall = time.perf_counter() - t0
        return {"angles": list(angles), "seconds": [wall / (b - a)] * (b - a), "wall": [wall]}

    return {
        "deik": timed(lambda k: solve_deik_single(skeleton, tip, P[k], R[k], start, seed + k)),
        "deik-solver": timed(
            lambda k: solver.solve({labels[0]: P[k], labels[1]: R[k]}, initial=start[None], seed=seed + k).angles
        ),
        "deik-batch": batch,
    }


def score(skeleton, targets: dict, angles, seconds) -> dict:
    """Success rates and time statistics of solutions (N, D) with per-target seconds (N,)."""
    pos, rot, inside = pose_errors(skeleton, targets["tip"], angles, targets["positions"], targets["rotations"])
    strict = (pos <= STRICT[0]) & (rot <= STRICT[1]) & inside
    loose = (pos <= LOOSE[0]) & (rot <= LOOSE[1]) & inside
    seconds = np.asarray(seconds, dtype=float)
    return {
        "n": len(pos),
        "success_strict": float(strict.mean()),
        "success_loose": float(loose.mean()),
        "success_strict_within_budget": float((strict & (seconds <= BUDGET_S)).mean()),
        "within_limits": float(inside.mean()),
        "median_position_error_m": float(np.median(pos)),
        "median_orientation_error_rad": float(np.median(rot)),
        "median_ms": float(np.median(seconds) * 1e3),
        "p95_ms": float(np.percentile(seconds, 95) * 1e3),
        "mean_ms": float(seconds.mean() * 1e3),
    }


def deik_row(skeleton, targets: dict, outputs: dict) -> dict:
    """deik's result: the single solves' score, with the batch and the reused Solver beside it."""
    single, reused, batch = (outputs[name] for name in DEIK_TURNS)
    n, wall = len(targets["positions"]), float(np.sum(batch["wall"]))
    row = {
        "version": deik.__version__,
        "settings": {**DEIK, "seed": "seed + target index (single, Solver); seed + first index (batch)"},
        **score(skeleton, targets, np.array(single["angles"]), single["seconds"]),
    }
    batch_score = score(skeleton, targets, np.array(batch["angles"]), batch["seconds"])
    row["batch"] = {
        "seconds": wall,
        "problems_per_second": n / wall,
        "batch_size": int(np.ceil(n / len(batch["wall"]))),
        "batches": len(batch["wall"]),
        "success_strict": batch_score["success_strict"],
        "success_loose": batch_score["success_loose"],
    }
    solver_score = score(skeleton, targets, np.array(reused["angles"]), reused["seconds"])
    keep = ("success_strict", "success_loose", "success_strict_within_budget", "median_ms", "p95_ms", "mean_ms")
    row["solver"] = {k: solver_score[k] for k in keep}
    return row


def peer_row(skeleton, targets: dict, info: dict, output: dict) -> dict:
    """A peer's result, its answers rescored here; attempts = local solves per target."""
    if "skipped" in output:
        return output
    keep = ("package", "version", "settings", "setup_s", "frame_check")
    attempts = np.asarray(output["attempts"])
    return {
        **{k: info[k] for k in keep},
        **score(skeleton, targets, np.array(output["angles"]), output["seconds"]),
        "attempts": {
            "mean": float(attempts.mean()),
            "max": int(attempts.max()),
            "restarted": float((attempts > 1).mean()),
        },
    }


def run_case(
    case: str, targets: dict, folder: Path, peers: tuple, chunks: int, seed: int, robots: Path, before=None
) -> dict:
    """Every solver on the case's targets in turns; the per-solver rows. before: a checkout
    whose deik runs as the peer "deik-before"."""
    skeleton = load_case(case, robots)[0]
    save_targets(targets, folder / "targets.npz")
    processes, skipped = {}, {}
    for name in peers:  # start them all first: they load while deik compiles
        try:
            if name == BEFORE:
                processes[name] = PeerProcess("deik", folder / "targets.npz", Path(sys.executable), before / "src")
            else:
                processes[name] = PeerProcess(name, folder / "targets.npz")
        except PeerFailed as error:
            skipped[name] = {"skipped": str(error)}
    runners = deik_runners(skeleton, targets, seed)
    for name, process in processes.items():
        try:
            process.ready()
            runners[name] = process.solve
        except PeerFailed as error:
            skipped[name] = {"skipped": str(error)}
    try:
        outputs = run_turns(runners, len(targets["positions"]), chunks, label=case)
    finally:
        for process in processes.values():
            process.close()
    solvers = {"deik": deik_row(skeleton, targets, outputs)}
    for name in peers:
        solvers[name] = skipped.get(name) or peer_row(skeleton, targets, processes[name].info, outputs[name])
    return {
        "dofs": skeleton.n_dofs,
        "base": targets["base"],
        "tip": targets["tip"],
        "dof_names": list(skeleton.dof_names),
        "solvers": solvers,
    }


def _describe(tree: Path) -> str:
    """The checkout's commit (git rev-parse) or its path."""
    import subprocess

    done = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    return f"{tree} at {done.stdout.strip()}" if done.returncode == 0 else str(tree)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--targets", type=int, default=500, help="targets per case")
    p.add_argument("--chunks", type=int, default=10, help="chunks of targets the solvers take turns on")
    p.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    p.add_argument("--peers", default="all", help="all, none, or a comma list of " + ",".join(LIBRARY_PEERS))
    p.add_argument("--before", type=Path, help="a checkout of an earlier deik to run beside this one")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--robots", type=Path, default=ROBOTS, help="folder of the robot URDFs")
    p.add_argument("--out", type=Path, default=RESULTS, help="results folder")
    a = p.parse_args(argv)
    peers = LIBRARY_PEERS if a.peers == "all" else () if a.peers == "none" else tuple(a.peers.split(","))
    unknown = sorted(set(peers) - set(LIBRARY_PEERS))
    if unknown:
        p.error(f"unknown peers {unknown}; choose from {LIBRARY_PEERS}")
    if a.before:
        if not (a.before / "src" / "deik").is_dir():
            p.error(f"--before {a.before}: no src/deik there; give a checkout of deik (git worktree add DIR COMMIT)")
        peers = (BEFORE,) + peers
    began, load_before = time.perf_counter(), list(os.getloadavg())
    result = {
        "benchmark": "robots",
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "settings": {
            "targets": a.targets,
            "chunks": a.chunks,
            "seed": a.seed,
            "strict": STRICT,
            "loose": LOOSE,
            "budget_s": BUDGET_S,
            "deik": DEIK,
            "peers": list(peers),
            "before": None if a.before is None else _describe(a.before),
            "turns": "per chunk: " + ", ".join(DEIK_TURNS + peers),
        },
        "cases": {},
    }
    with tempfile.TemporaryDirectory() as work:
        for case in a.cases:
            targets = make_targets(case, a.targets, a.seed, a.robots)
            folder = Path(work) / case
            folder.mkdir()
            result["cases"][case] = run_case(case, targets, folder, peers, a.chunks, a.seed, a.robots, a.before)
            print(f"{case} done", file=sys.stderr, flush=True)
    result["environment"] = {**environment(), "cpu_model": cpu_model(), "load_average_before": load_before}
    result["wall_s"] = time.perf_counter() - began
    write_atomic(a.out / "robots.json", lambda tmp: Path(tmp).write_text(json.dumps(result, indent=2) + "\n"))
    text = markdown(result)
    write_atomic(a.out / "robots.md", lambda tmp: Path(tmp).write_text(text))
    plot(result, a.out / "robots.png", BUDGET_S)
    print(text)
    print(f"wall {result['wall_s']:.0f} s; wrote {a.out / 'robots.json'}, robots.md, robots.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

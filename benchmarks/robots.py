"""Robot IK benchmark on the TRAC-IK protocol: deik and peer IK libraries on the same targets.

    PYTHONPATH=src python -m benchmarks.robots [--targets 500] [--cases panda iiwa human]
                                              [--peers all|none|ikpy,pk,...] [--out benchmarks/results]

Per case (benchmarks.robot_targets): N random in-limit poses of the tip, every solver starting
from the mid-limit pose. deik solves each target alone (timed per call: building the Problem
and deik.solve), again through one reused deik.Solver that swaps the targets (timed per call),
and then all of them in one batched call (throughput). Each peer runs in .venv-peers through
benchmarks.peers.run_peer (skipped, with the reason recorded, when that venv is missing or the
peer fails). Every answer is scored by robot_targets.pose_errors (deik's float64 FK): success
= within 1e-5 m and 1e-4 rad with every joint in its limits; also at 1e-3 m / 1e-2 rad, and the
strict success reached within 5 ms. Writes results/robots.{json,md,png} atomically.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import deik
from benchmarks.robot_targets import CASES, ROBOTS, load_case, make_targets, pose_errors, save_targets
from benchmarks.serial_vs_parallel import RESULTS, write_atomic
from deik.experiments.timing import environment

ROOT = Path(__file__).resolve().parents[1]
PEERS_PYTHON = ROOT / ".venv-peers" / "bin" / "python"
PEERS = ("ikpy", "pk", "placo", "pink", "mink", "pybullet")
STRICT, LOOSE, BUDGET_S = (1e-5, 1e-4), (1e-3, 1e-2), 0.005
DEIK = {"population": 32, "polish_count": 32, "generations": 2000, "patience": 50, "dtype": "float64"}  # retune here
PEER_TIMEOUT_S = 900


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


def solve_deik_reused(skeleton, tip, positions, rotations, start, seed) -> tuple[np.ndarray, list[float]]:
    """Every target through one deik.Solver (set up once, untimed), one timed call each, seeds
    as the single solves: (angles (N, D), seconds per call)."""
    solver = deik.Solver(deik_problem(skeleton, tip, positions[0], rotations[0]), **DEIK)
    labels = solver.problem.table.labels
    angles, seconds = [], []
    for k in range(len(positions)):
        t0 = time.perf_counter()
        angles.append(
            solver.solve({labels[0]: positions[k], labels[1]: rotations[k]}, initial=start[None], seed=seed + k).angles
        )
        seconds.append(time.perf_counter() - t0)
    return np.array(angles), seconds


def solve_deik_batch(skeleton, tip, positions, rotations, start, seed) -> np.ndarray:
    """B targets in one call: positions (B, 3), rotations (B, 3, 3), start (D,) -> angles (B, D)."""
    result = deik.solve(deik_problem(skeleton, tip, positions, rotations), seed=seed, initial=start[None], **DEIK)
    return result.angles


def score(skeleton, targets: dict, angles, seconds) -> dict:
    """Success rates and time statistics of solutions (N, D) with per-solve seconds (N,)."""
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


def run_deik(skeleton, targets: dict, seed: int) -> dict:
    """deik one target at a time (timed per call), then all targets in one batched call."""
    tip, start = targets["tip"], targets["start"]
    P, R = targets["positions"], targets["rotations"]
    solve_deik_single(skeleton, tip, P[0], R[0], start, seed)  # compile, not timed
    solve_deik_batch(skeleton, tip, P[:2], R[:2], start, seed)
    angles, seconds = [], []
    for k in range(len(P)):
        t0 = time.perf_counter()
        angles.append(solve_deik_single(skeleton, tip, P[k], R[k], start, seed + k))
        seconds.append(time.perf_counter() - t0)
    reused = solve_deik_reused(skeleton, tip, P, R, start, seed)
    t0 = time.perf_counter()
    batch = solve_deik_batch(skeleton, tip, P, R, start, seed)
    wall = time.perf_counter() - t0
    row = {
        "version": deik.__version__,
        "settings": {**DEIK, "seed": "seed + target index (single); seed (batch)"},
        **score(skeleton, targets, np.array(angles), seconds),
    }
    batch_score = score(skeleton, targets, batch, np.full(len(P), wall / len(P)))
    row["batch"] = {
        "seconds": wall,
        "problems_per_second": len(P) / wall,
        "success_strict": batch_score["success_strict"],
        "success_loose": batch_score["success_loose"],
    }
    solver_score = score(skeleton, targets, reused[0], reused[1])
    row["solver"] = {k: solver_score[k] for k in ("success_strict", "median_ms", "p95_ms")}
    return row


def run_peer(name: str, skeleton, targets: dict, targets_file: Path) -> dict:
    """One peer in the peers venv; its answers rescored here. {"skipped": reason} when it cannot run."""
    if not PEERS_PYTHON.exists():
        return {"skipped": f"{PEERS_PYTHON} is missing (make bench-peers creates it)"}
    out = targets_file.with_name(f"{name}.json")
    cmd = [str(PEERS_PYTHON), "-m", "benchmarks.peers.run_peer", name, str(targets_file), str(out)]
    try:
        proc = subprocess.run(
            cmd,
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=PEER_TIMEOUT_S,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
        )
    except subprocess.TimeoutExpired:
        return {"skipped": f"timed out after {PEER_TIMEOUT_S} s"}
    if not out.exists():
        return {"skipped": f"exit {proc.returncode}: {(proc.stderr or proc.stdout).strip()[-800:]}"}
    raw = json.loads(out.read_text())
    if "error" in raw:
        return {"skipped": raw["error"], "traceback": raw.get("traceback")}
    keep = ("package", "version", "settings", "setup_s", "frame_check")
    return {**{k: raw[k] for k in keep}, **score(skeleton, targets, np.array(raw["angles"]), raw["seconds"])}


def markdown(result: dict) -> str:
    """One table per case: success rates and times per solver."""
    lines = [
        f"Robot IK, TRAC-IK protocol: {result['settings']['targets']} random in-limit targets per case, "
        "start at mid-limits, scored by deik's float64 FK. strict = 1e-5 m and 1e-4 rad with joints in "
        "limits; loose = 1e-3 m and 1e-2 rad; ≤5 ms = strict within 5 ms. Times per solve call; CPU shared, "
        "timings noisy."
    ]
    for case, data in result["cases"].items():
        lines += [
            "",
            f"### {case} ({data['dofs']} DOF, {data['base']} -> {data['tip']})",
            "",
            "| solver | version | strict | loose | ≤5 ms | median ms | p95 ms | note |",
            "|---|---|---:|---:|---:|---:|---:|---|",
        ]
        for name, row in data["solvers"].items():
            if "skipped" in row:
                lines.append(f"| {name} | | | | | | | skipped: {row['skipped'][:120]} |")
                continue
            note = ""
            if "batch" in row:
                b = row["batch"]
                note = (
                    f"batch of {row['n']}: {b['problems_per_second']:.0f} problems/s, "
                    f"strict {100 * b['success_strict']:.1f} %, loose {100 * b['success_loose']:.1f} %"
                )
            if "solver" in row:
                s = row["solver"]
                note += (
                    f"; deik.Solver reused: median {s['median_ms']:.2f} ms, p95 {s['p95_ms']:.2f} ms, "
                    f"strict {100 * s['success_strict']:.1f} %"
                )
            lines.append(
                f"| {name} | {row['version']} | {100 * row['success_strict']:.1f} % | "
                f"{100 * row['success_loose']:.1f} % | {100 * row['success_strict_within_budget']:.1f} % | "
                f"{row['median_ms']:.2f} | {row['p95_ms']:.2f} | {note} |"
            )
    return "\n".join(lines) + "\n"


def plot(result: dict, path: Path) -> None:
    """Strict success rate against median time per solve (bar to the 95th percentile), per case."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = result["cases"]
    fig, axes = plt.subplots(1, len(cases), figsize=(4.6 * len(cases), 4.0), squeeze=False)
    for ax, (case, data) in zip(axes[0], cases.items()):
        for k, (name, row) in enumerate((n, r) for n, r in data["solvers"].items() if "skipped" not in r):
            colour = f"C{k}"
            y = 100 * row["success_strict"]
            ax.plot([row["median_ms"], row["p95_ms"]], [y, y], "-", color=colour, alpha=0.5)
            ax.plot(row["median_ms"], y, "o", color=colour, label=name)
            if "batch" in row:
                per = 1e3 / row["batch"]["problems_per_second"]
                ax.plot(
                    per,
                    100 * row["batch"]["success_strict"],
                    "*",
                    ms=11,
                    color=colour,
                    label=f"{name} batch (amortised)",
                )
        ax.axvline(BUDGET_S * 1e3, color="grey", ls=":", lw=1)
        ax.set_xscale("log")
        ax.set_ylim(-3, 103)
        ax.set_xlabel("time per solve, ms (median; line to p95)")
        ax.set_ylabel("success 1e-5 m / 1e-4 rad, %")
        ax.set_title(f"{case} ({data['dofs']} DOF)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--targets", type=int, default=500, help="targets per case")
    p.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    p.add_argument("--peers", default="all", help="all, none, or a comma list of " + ",".join(PEERS))
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--robots", type=Path, default=ROBOTS, help="folder of the robot URDFs")
    p.add_argument("--out", type=Path, default=RESULTS, help="results folder")
    a = p.parse_args(argv)
    peers = PEERS if a.peers == "all" else () if a.peers == "none" else tuple(a.peers.split(","))
    unknown = sorted(set(peers) - set(PEERS))
    if unknown:
        p.error(f"unknown peers {unknown}; choose from {PEERS}")
    began, load_before = time.perf_counter(), list(os.getloadavg())
    result = {
        "benchmark": "robots",
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "settings": {
            "targets": a.targets,
            "seed": a.seed,
            "strict": STRICT,
            "loose": LOOSE,
            "budget_s": BUDGET_S,
            "deik": DEIK,
            "peers": list(peers),
        },
        "cases": {},
    }
    with tempfile.TemporaryDirectory() as work:
        for case in a.cases:
            skeleton = load_case(case, a.robots)[0]
            targets = make_targets(case, a.targets, a.seed, a.robots)
            folder = Path(work) / case
            folder.mkdir()
            save_targets(targets, folder / "targets.npz")
            solvers = {"deik": run_deik(skeleton, targets, a.seed)}
            for name in peers:
                solvers[name] = run_peer(name, skeleton, targets, folder / "targets.npz")
                print(f"{case}: {name} done", file=sys.stderr, flush=True)
            result["cases"][case] = {
                "dofs": skeleton.n_dofs,
                "base": targets["base"],
                "tip": targets["tip"],
                "dof_names": list(skeleton.dof_names),
                "solvers": solvers,
            }
    result["environment"] = {**environment(), "load_average_before": load_before}
    result["wall_s"] = time.perf_counter() - began
    write_atomic(a.out / "robots.json", lambda tmp: Path(tmp).write_text(json.dumps(result, indent=2) + "\n"))
    text = markdown(result)
    write_atomic(a.out / "robots.md", lambda tmp: Path(tmp).write_text(text))
    plot(result, a.out / "robots.png")
    print(text)
    print(f"wall {result['wall_s']:.0f} s; wrote {a.out / 'robots.json'}, robots.md, robots.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

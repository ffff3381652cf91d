"""DE against DE: deik, scipy.optimize.differential_evolution and evosax's DE on the same problems.

    PYTHONPATH=src python -m benchmarks.de_peers [--trials 10] [--seed 0] [--out benchmarks/results]

Problems, each with --trials random in-limit target poses (the FK of a seeded random pose):
- chain20: the paper's planar chain deik.chain(20), Position on site 'tip'; success when the
  tip is within 1 % of the reach (0.2 length units);
- panda: panda_link0 -> panda_hand_tcp, full pose; success within 5 mm and 0.05 rad.
Every solver starts from a random population inside the joint limits and stops as soon as its
best member meets the thresholds (or at 2000 generations). The peers run in .venv-peers
(benchmarks.peers.run_de_peer) on the chain exported by robot_targets.export_chain, their
objective evaluated by a vectorised FK (NumPy for SciPy, jax.numpy for evosax). Recorded per
trial: wall time, objective evaluations (deik: population x (generations + 1), its LM polish
steps not counted), generations; every answer rescored with robot_targets.pose_errors. deik
runs twice: with its defaults, and as DE alone (polish=0, "deik-no-polish").
Writes results/de_peers.{json,md}.
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
from benchmarks.peer_process import PEERS_PYTHON, ROOT
from benchmarks.robot_targets import ROBOTS, export_chain, load_case, pose_errors
from benchmarks.serial_vs_parallel import RESULTS, write_atomic
from deik.experiments.timing import environment

DE_PEERS = ("scipy_de", "evosax")
MAX_GENERATIONS = 2000
DEIK = {"population": 32, "patience": 50, "generations": MAX_GENERATIONS}  # retune here (dtype: deik's default)
DEIK_VARIANTS = {"deik": DEIK, "deik-no-polish": {**DEIK, "population": 256, "polish": 0, "patience": 300}}  # DE alone
TARGET_SPEEDUP = 10.0


def problems(robots: Path) -> dict:
    """name -> (skeleton, tip, pose goal?, (position tolerance, orientation tolerance))."""
    chain = deik.chain(20)
    panda = load_case("panda", robots)[0]
    return {
        "chain20": (chain, "tip", False, (0.01 * chain.reach, np.inf)),
        "panda": (panda, "panda_hand_tcp", True, (5e-3, 0.05)),
    }


def deik_goals(tip: str, pose: bool, tolerances, position, rotation) -> list:
    goals = [deik.Position(tip, position, tolerance=tolerances[0])]
    return goals + [deik.Orientation(tip, rotation, tolerance=tolerances[1])] if pose else goals


def run_deik(settings: dict, skeleton, tip, pose, tolerances, positions, rotations, seeds) -> dict:
    """deik with `settings` on every trial (a warm-up solve first, not timed). Evaluations count
    DE members, population x (generations + 1); LM polish steps, where on, are not counted."""

    def solve(k, seed):
        problem = deik.Problem(skeleton, deik_goals(tip, pose, tolerances, positions[k], rotations[k]))
        t0 = time.perf_counter()
        result = deik.solve(problem, seed=seed, **settings)
        seconds = time.perf_counter() - t0
        return {
            "angles": result.angles.tolist(),
            "seconds": seconds,
            "generations": int(result.generations),
            "evaluations": settings["population"] * (int(result.generations) + 1),
        }

    solve(0, seeds[0] + 10_000)
    return {
        "version": deik.__version__,
        "settings": {**settings, "other": "deik defaults (float32)"},
        "trials": [solve(k, s) for k, s in enumerate(seeds)],
    }


def run_peer(name: str, problem_file: Path) -> dict:
    """A DE peer in the peers venv, or {"skipped": reason}."""
    if not PEERS_PYTHON.exists():
        return {"skipped": f"{PEERS_PYTHON} is missing (make bench-peers creates it)"}
    out = problem_file.with_name(f"{name}.json")
    cmd = [str(PEERS_PYTHON), "-m", "benchmarks.peers.run_de_peer", name, str(problem_file), str(out)]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    if not out.exists():
        return {"skipped": f"exit {proc.returncode}: {(proc.stderr or proc.stdout).strip()[-800:]}"}
    raw = json.loads(out.read_text())
    return {"skipped": raw["error"], "traceback": raw.get("traceback")} if "error" in raw else raw


def summarise(row: dict, skeleton, tip, pose, tolerances, positions, rotations) -> dict:
    """Add success (rescored in float64, joints in limits) and medians over the trials."""
    trials = row["trials"]
    pos, rot, inside = pose_errors(skeleton, tip, np.array([t["angles"] for t in trials]), positions, rotations)
    ok = (pos < tolerances[0]) & (inside if not pose else inside & (rot < tolerances[1]))
    for t, p, r, s in zip(trials, pos, rot, ok):
        t.update(position_error=float(p), orientation_error=float(r), success=bool(s))
    keys = ("seconds", "evaluations", "generations")
    medians = {f"median_{k}": float(np.median([t[k] for t in trials])) for k in keys}
    return {**row, "success": float(ok.mean()), **medians}


def markdown(result: dict) -> str:
    lines = [
        f"DE against DE, {result['settings']['trials']} random targets per problem; success and "
        "time to reach the error (median over trials; a failed trial counts its full time). "
        "CPU shared, timings noisy. deik's evaluations count DE members only (not its LM polish); "
        "deik-no-polish is its DE alone.",
        "",
        "| problem | solver | version | success | median s | median evaluations | median generations "
        "| deik faster by | deik-no-polish faster by |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name, data in result["problems"].items():
        solvers = data["solvers"]
        for solver, row in solvers.items():
            if "skipped" in row:
                lines.append(f"| {name} | {solver} | | | | | | | skipped: {row['skipped'][:100]} |")
                continue
            ratios = [
                "" if solver in DEIK_VARIANTS else f"{row['median_seconds'] / solvers[v]['median_seconds']:.1f}x"
                for v in DEIK_VARIANTS
            ]
            lines.append(
                f"| {name} | {solver} | {row['version']} | {100 * row['success']:.0f} % | "
                f"{row['median_seconds']:.4f} | {row['median_evaluations']:.0f} | "
                f"{row['median_generations']:.0f} | {' | '.join(ratios)} |"
            )
    met = result["target"]["met"]
    lines += [
        "",
        f"Target: deik (defaults) >= {TARGET_SPEEDUP:.0f}x faster than each peer on each problem: "
        + ("not measured (a peer was skipped)" if met is None else "MET" if met else "NOT MET"),
    ]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--trials", type=int, default=10, help="targets per problem")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--robots", type=Path, default=ROBOTS, help="folder of the robot URDFs")
    p.add_argument("--out", type=Path, default=RESULTS, help="results folder")
    a = p.parse_args(argv)
    began, load_before = time.perf_counter(), list(os.getloadavg())
    result = {
        "benchmark": "de_peers",
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "settings": {"trials": a.trials, "seed": a.seed, "max_generations": MAX_GENERATIONS},
        "problems": {},
    }
    ratios = []
    with tempfile.TemporaryDirectory() as work:
        for name, (skeleton, tip, pose, tol) in problems(a.robots).items():
            rng = np.random.default_rng(a.seed)
            poses = rng.uniform(skeleton.lower, skeleton.upper, (a.trials, skeleton.n_dofs))
            kin = deik.forward_kinematics(skeleton, poses)
            P, R, seeds = kin.position(tip), kin.rotation(tip), [a.seed + k for k in range(a.trials)]
            problem_file = Path(work) / name / "problem.npz"
            problem_file.parent.mkdir()
            np.savez(
                problem_file,
                **export_chain(skeleton, tip),
                positions=P,
                rotations=R,
                seeds=np.array(seeds),
                pose=pose,
                tolerances=np.array(tol),
                max_generations=MAX_GENERATIONS,
            )
            solvers = {
                name_: run_deik(settings, skeleton, tip, pose, tol, P, R, seeds)
                for name_, settings in DEIK_VARIANTS.items()
            }
            solvers.update({peer: run_peer(peer, problem_file) for peer in DE_PEERS})
            for solver, row in solvers.items():
                if "skipped" not in row:
                    solvers[solver] = summarise(row, skeleton, tip, pose, tol, P, R)
                print(f"{name}: {solver} done", file=sys.stderr, flush=True)
            for peer in DE_PEERS:
                row = solvers[peer]
                ratios.append(None if "skipped" in row else row["median_seconds"] / solvers["deik"]["median_seconds"])
            tolerances = [tol[0], None if np.isinf(tol[1]) else tol[1]]
            result["problems"][name] = {
                "dofs": skeleton.n_dofs,
                "tip": tip,
                "pose": pose,
                "tolerances": tolerances,
                "solvers": solvers,
            }
    met = None if None in ratios else bool(min(ratios) >= TARGET_SPEEDUP)
    result["target"] = {"speedup": TARGET_SPEEDUP, "met": met, "ratios": ratios}
    result["environment"] = {**environment(), "load_average_before": load_before}
    result["wall_s"] = time.perf_counter() - began
    write_atomic(a.out / "de_peers.json", lambda tmp: Path(tmp).write_text(json.dumps(result, indent=2) + "\n"))
    text = markdown(result)
    write_atomic(a.out / "de_peers.md", lambda tmp: Path(tmp).write_text(text))
    print(text)
    print(f"wall {result['wall_s']:.0f} s; wrote {a.out / 'de_peers.json'} and de_peers.md")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""DE against DE: deik, scipy.optimize.differential_evolution and evosax's DE on the same problems.

    python -m benchmarks.de_peers [--trials 10] [--seed 0] [--out benchmarks/results]

Problems, each with --trials random in-limit target poses (the FK of a seeded random pose):
- chain20: the paper's planar chain deik.chain(20), Position on site 'tip'; success when the
  tip is within 1 % of the reach (0.2 length units);
- panda: panda_link0 -> panda_hand_tcp, full pose; success within 5 mm and 0.05 rad.
Every solver starts from a random population inside the joint limits and stops as soon as its
best member meets the thresholds (or at 2000 generations). The peers run in .venv-peers
(benchmarks.peers.run_peer) on the chain exported by robot_targets.export_chain, their
objective evaluated by a vectorised FK (NumPy for SciPy, jax.numpy for evosax). Recorded per
trial: wall time, objective evaluations (deik: population x (generations + 1), its LM polish
steps not counted), generations; every answer rescored with robot_targets.pose_errors. deik
runs twice: with its defaults, and as DE alone (polish=0, "deik-no-polish").
Target: deik (defaults) >= 10x faster than each peer on each problem (median seconds).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import deik
from benchmarks import harness
from benchmarks.peer_process import PEERS_PYTHON, ROOT
from benchmarks.peers.run_peer import DE_PEERS
from benchmarks.robot_targets import export_chain, load_case, pose_errors

MAX_GENERATIONS = 2000
DEIK = {"population": 32, "patience": 50, "generations": MAX_GENERATIONS}  # dtype: deik's default
DEIK_VARIANTS = {"deik": DEIK, "deik-no-polish": {**DEIK, "population": 256, "polish": 0, "patience": 300}}
TARGET_SPEEDUP = 10.0


def problems() -> dict:
    """name -> (skeleton, tip, pose goal?, (position tolerance, orientation tolerance))."""
    chain = deik.chain(20)
    panda = load_case("panda")[0]
    return {
        "chain20": (chain, "tip", False, (0.01 * chain.reach, np.inf)),
        "panda": (panda, "panda_hand_tcp", True, (5e-3, 0.05)),
    }


def run_deik(settings: dict, case: tuple, positions, rotations, seeds) -> dict:
    """deik with `settings` on every trial of `case` (a warm-up solve first, untimed)."""
    skeleton, tip, pose, tolerances = case

    def solve(k: int, seed: int) -> dict:
        goals = [deik.Position(tip, positions[k], tolerance=tolerances[0])]
        goals += [deik.Orientation(tip, rotations[k], tolerance=tolerances[1])] if pose else []
        began = time.perf_counter()
        result = deik.solve(deik.Problem(skeleton, goals), seed=seed, **settings)
        generations = int(result.generations)
        return {
            "angles": result.angles.tolist(),
            "seconds": time.perf_counter() - began,
            "generations": generations,
            "evaluations": settings["population"] * (generations + 1),
        }

    solve(0, seeds[0] + 10_000)
    return {"version": deik.__version__, "settings": settings, "trials": [solve(k, s) for k, s in enumerate(seeds)]}


def run_peer(name: str, problem_file: Path) -> dict:
    """A DE peer in the peers venv, or {"skipped": reason}."""
    if not PEERS_PYTHON.exists():
        return {"skipped": f"{PEERS_PYTHON} is missing (make bench-peers creates it)"}
    out = problem_file.with_name(f"{name}.json")
    cmd = [str(PEERS_PYTHON), "-m", "benchmarks.peers.run_peer", name, str(problem_file), str(out)]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    if not out.exists():
        return {"skipped": f"exit {done.returncode}: {(done.stderr or done.stdout).strip()[-800:]}"}
    raw = json.loads(out.read_text())
    return {"skipped": raw["error"], "traceback": raw.get("traceback")} if "error" in raw else raw


def summarise(row: dict, case: tuple, positions, rotations) -> dict:
    """`row` with success (rescored in float64, joints in limits) and medians over the trials."""
    skeleton, tip, pose, tolerances = case
    trials = row["trials"]
    pos, rot, inside = pose_errors(skeleton, tip, np.array([t["angles"] for t in trials]), positions, rotations)
    ok = (pos < tolerances[0]) & inside & ((rot < tolerances[1]) if pose else True)
    for t, p, r, s in zip(trials, pos, rot, ok):
        t.update(position_error=float(p), orientation_error=float(r), success=bool(s))
    medians = {
        f"median_{k}": float(np.median([t[k] for t in trials])) for k in ("seconds", "evaluations", "generations")
    }
    return {**row, "success": float(ok.mean()), **medians}


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--trials", type=int, default=10, help="targets per problem")
    run = harness.start("de_peers", p, argv)
    args = run.args
    result, ratios, cells = {"trials": args.trials, "max_generations": MAX_GENERATIONS, "problems": {}}, [], []
    with tempfile.TemporaryDirectory() as work:
        for name, case in problems().items():
            skeleton, tip, pose, tolerances = case
            poses = np.random.default_rng(args.seed).uniform(
                skeleton.lower, skeleton.upper, (args.trials, skeleton.n_dofs)
            )
            kin = deik.forward_kinematics(skeleton, poses)
            P, R, seeds = kin.position(tip), kin.rotation(tip), [args.seed + k for k in range(args.trials)]
            problem_file = Path(work) / name / "problem.npz"
            problem_file.parent.mkdir()
            np.savez(
                problem_file,
                **export_chain(skeleton, tip),
                positions=P,
                rotations=R,
                seeds=np.array(seeds),
                pose=pose,
                tolerances=np.array(tolerances),
                max_generations=MAX_GENERATIONS,
            )
            solvers = {solver: run_deik(settings, case, P, R, seeds) for solver, settings in DEIK_VARIANTS.items()}
            solvers |= {peer: run_peer(peer, problem_file) for peer in DE_PEERS}
            for solver, row in solvers.items():
                if "skipped" in row:
                    cells.append([name, solver, "", "", "", "", "", f"skipped: {row['skipped'][:100]}", ""])
                    continue
                row = solvers[solver] = summarise(row, case, P, R)
                faster = [
                    "" if solver in DEIK_VARIANTS else f"{row['median_seconds'] / solvers[v]['median_seconds']:.1f}x"
                    for v in DEIK_VARIANTS
                ]
                cells.append(
                    [
                        name,
                        solver,
                        row["version"],
                        f"{row['success']:.0%}",
                        f"{row['median_seconds']:.4f}",
                        f"{row['median_evaluations']:.0f}",
                        f"{row['median_generations']:.0f}",
                        *faster,
                    ]
                )
                print(f"{name}: {solver} done", file=sys.stderr, flush=True)
            ratios += [
                None
                if "skipped" in solvers[peer]
                else solvers[peer]["median_seconds"] / solvers["deik"]["median_seconds"]
                for peer in DE_PEERS
            ]
            result["problems"][name] = {
                "dofs": skeleton.n_dofs,
                "tip": tip,
                "pose": pose,
                "solvers": solvers,
                "tolerances": [tolerances[0], tolerances[1] if pose else None],
            }
    reached = None if None in ratios else min(ratios)
    run.target(
        "deik (defaults) faster than each DE peer on each problem", TARGET_SPEEDUP, reached, "x", reached is not None
    )
    header = [
        "problem",
        "solver",
        "version",
        "success",
        "median s",
        "median evaluations",
        "median generations",
        "deik faster by",
        "deik-no-polish faster by",
    ]
    figures = {
        f"{name} {solver} median s": row.get("median_seconds")
        for name, data in result["problems"].items()
        for solver, row in data["solvers"].items()
    }
    return run.finish(result, harness.md_table(header, cells), figures=figures)


if __name__ == "__main__":
    main()

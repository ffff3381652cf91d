"""Robot IK on the TRAC-IK protocol: deik and peer IK libraries on the same targets, taking turns.

    python -m benchmarks.robots [--targets 500] [--chunks 10] [--cases panda iiwa human]
                                [--peers all|none|ikpy,pk,...] [--out benchmarks/results]

Per case (benchmarks.robot_targets): N random in-limit poses of the tip, every solver starting
from the mid-limit pose. The targets are split into chunks and on each chunk every solver takes
its turn (harness.take_turns): deik one target per call (building the Problem and deik.solve),
deik through one reused deik.Solver that swaps the targets, deik on the chunk as one batch, then
each peer, a long-lived process in .venv-peers (benchmarks.peer_process) whose local solvers
restart from random in-limit poses within 5 ms per target. deik's settings are DEIK's, or
--deik's (e.g. `--deik dtype=float32 polish_count=16 patience=300`, the defaults beside the
README's population=32). A peer is skipped, with the reason
recorded, when that venv is missing or the peer fails. Every answer is scored by
robot_targets.pose_errors (deik's float64 FK): strict = within 1e-5 m and 1e-4 rad with every
joint in its limits; loose = 1e-3 m and 1e-2 rad; "<= 5 ms" = strict within TRAC-IK's budget.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import deik
from benchmarks import harness
from benchmarks.peer_process import PeerFailed, PeerProcess
from benchmarks.peers.run_peer import PEERS
from benchmarks.robot_targets import CASES, load_case, make_targets, pose_errors, save_targets

STRICT, LOOSE, BUDGET_S = (1e-5, 1e-4), (1e-3, 1e-2), 0.005
DEIK = {"population": 32, "polish_count": 32, "generations": 2000, "patience": 50, "dtype": "float64"}
DEIK_TURNS = ("deik", "deik-solver", "deik-batch")


def deik_settings(overrides: list[str]) -> dict:
    """DEIK with the --deik KEY=VALUE overrides (whole numbers as int, e.g. dtype=float32 polish_count=16)."""
    settings = dict(DEIK)
    for item in overrides:
        key, _, value = item.partition("=")
        settings[key] = int(value) if value.isdigit() else value
    return settings


def deik_runners(skeleton, targets: dict, seed: int, settings: dict) -> dict:
    """deik's three turns as runners (start, stop) -> {"angles", "seconds"} (+ "wall" per batch);
    compilation and the reused Solver's set-up happen here, untimed. Target k gets seed + k in
    the single and reused solves; a batch gets seed + its first index."""
    tip, start = targets["tip"], targets["start"][None]
    P, R = targets["positions"], targets["rotations"]

    def problem(a: int, b: int | None = None) -> deik.Problem:
        part = slice(a, b) if b is not None else a
        goals = [deik.Position(tip, P[part], tolerance=STRICT[0]), deik.Orientation(tip, R[part], tolerance=STRICT[1])]
        return deik.Problem(skeleton, goals)

    solver = deik.Solver(problem(0), **settings)
    labels = solver.problem.table.labels
    singles = {
        "deik": lambda k: deik.solve(problem(k), seed=seed + k, initial=start, **settings).angles,
        "deik-solver": lambda k: solver.solve({labels[0]: P[k], labels[1]: R[k]}, initial=start, seed=seed + k).angles,
    }
    for one in singles.values():
        one(0)
    deik.solve(problem(0, 2), seed=seed, initial=start, **settings)

    def timed(one):
        def run(a: int, b: int) -> dict:
            out = {"angles": [], "seconds": []}
            for k in range(a, b):
                began = time.perf_counter()
                out["angles"].append(one(k))
                out["seconds"].append(time.perf_counter() - began)
            return out

        return run

    def batch(a: int, b: int) -> dict:
        began = time.perf_counter()
        angles = deik.solve(problem(a, b), seed=seed + a, initial=start, **settings).angles
        wall = time.perf_counter() - began
        return {"angles": list(angles), "seconds": [wall / (b - a)] * (b - a), "wall": [wall]}

    return {name: timed(one) for name, one in singles.items()} | {"deik-batch": batch}


def score(skeleton, targets: dict, angles, seconds) -> dict:
    """Success rates and time statistics (ms) of solutions (N, D) with per-target seconds (N,)."""
    pos, rot, inside = pose_errors(skeleton, targets["tip"], angles, targets["positions"], targets["rotations"])
    strict = (pos <= STRICT[0]) & (rot <= STRICT[1]) & inside
    seconds = np.asarray(seconds, dtype=float)
    return {
        "n": len(pos),
        "success_strict": float(strict.mean()),
        "success_loose": float(((pos <= LOOSE[0]) & (rot <= LOOSE[1]) & inside).mean()),
        "success_strict_within_budget": float((strict & (seconds <= BUDGET_S)).mean()),
        "within_limits": float(inside.mean()),
        "median_position_error_m": float(np.median(pos)),
        "median_orientation_error_rad": float(np.median(rot)),
        "median_ms": float(np.median(seconds) * 1e3),
        "p95_ms": float(np.percentile(seconds, 95) * 1e3),
        "mean_ms": float(seconds.mean() * 1e3),
    }


def rows_of(skeleton, targets: dict, outputs: dict, peers: dict, settings: dict) -> dict:
    """Per solver its row: deik's single solves with its reused Solver and batch beside them;
    each peer's answers rescored here (attempts = local solves per target)."""
    single, reused, batch = (outputs[name] for name in DEIK_TURNS)
    deik_row = {"version": deik.__version__, "settings": settings}
    deik_row |= score(skeleton, targets, np.array(single["angles"]), single["seconds"])
    deik_row["solver"] = score(skeleton, targets, np.array(reused["angles"]), reused["seconds"])
    wall, n = float(np.sum(batch["wall"])), len(targets["positions"])
    deik_row["batch"] = {
        "batches": len(batch["wall"]),
        "batch_size": int(np.ceil(n / len(batch["wall"]))),
        "problems_per_second": n / wall,
    }
    deik_row["batch"] |= score(skeleton, targets, np.array(batch["angles"]), batch["seconds"])
    rows = {"deik": deik_row}
    for name, info in peers.items():
        out = outputs.get(name, info)
        if "skipped" in out:
            rows[name] = {"skipped": out["skipped"]}
            continue
        attempts = np.asarray(out["attempts"])
        rows[name] = {k: info[k] for k in ("package", "version", "settings", "setup_s", "frame_check")}
        rows[name] |= score(skeleton, targets, np.array(out["angles"]), out["seconds"])
        rows[name]["attempts"] = {
            "mean": float(attempts.mean()),
            "max": int(attempts.max()),
            "restarted": float((attempts > 1).mean()),
        }
    return rows


def run_case(case: str, args, peers: tuple, folder: Path) -> dict:
    """Every solver on the case's targets in turns; the case's record."""
    skeleton = load_case(case)[0]
    targets = make_targets(case, args.targets, args.seed)
    save_targets(targets, folder / "targets.npz")
    processes, infos = {}, {}
    for name in peers:  # start them all first: they load while deik compiles
        try:
            processes[name] = PeerProcess(name, folder / "targets.npz")
        except PeerFailed as error:
            infos[name] = {"skipped": str(error)}
    runners = deik_runners(skeleton, targets, args.seed, deik_settings(args.deik))
    for name, process in processes.items():
        try:
            infos[name] = process.ready()
            runners[name] = process.solve
        except PeerFailed as error:
            infos[name] = {"skipped": str(error)}
    try:
        outputs = harness.take_turns(runners, args.targets, args.chunks, label=case)
    finally:
        for process in processes.values():
            process.close()
    rows = rows_of(skeleton, targets, outputs, {name: infos[name] for name in peers}, deik_settings(args.deik))
    return {"dofs": skeleton.n_dofs, "base": targets["base"], "tip": targets["tip"], "solvers": rows}


def note(row: dict) -> str:
    """The note column: deik's batch and reused Solver; a peer's restarts."""
    parts = []
    if "batch" in row:
        b = row["batch"]
        parts.append(
            f"batch of {b['batch_size']} x {b['batches']}: {b['problems_per_second']:.0f} problems/s, "
            f"strict {b['success_strict']:.1%}, loose {b['success_loose']:.1%}"
        )
    if "solver" in row:
        s = row["solver"]
        parts.append(
            f"deik.Solver reused: median {s['median_ms']:.2f} ms, p95 {s['p95_ms']:.2f} ms, "
            f"strict {s['success_strict']:.1%}, ≤5 ms {s['success_strict_within_budget']:.1%}"
        )
    if "attempts" in row:
        a = row["attempts"]
        parts.append(f"attempts: mean {a['mean']:.2f}, max {a['max']}, restarted {a['restarted']:.1%}")
    return "; ".join(parts)


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--targets", type=int, default=500, help="targets per case")
    p.add_argument("--chunks", type=int, default=10, help="chunks of targets the solvers take turns on")
    p.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    p.add_argument("--peers", default="all", help="all, none, or a comma list of " + ",".join(PEERS))
    p.add_argument("--deik", nargs="*", default=[], metavar="KEY=VALUE", help="deik settings replacing DEIK's")
    run = harness.start("robots", p, argv)
    args = run.args
    peers = tuple(PEERS) if args.peers == "all" else () if args.peers == "none" else tuple(args.peers.split(","))
    if set(peers) - set(PEERS):
        p.error(f"unknown peers {sorted(set(peers) - set(PEERS))}; choose from {tuple(PEERS)}")
    cases = {}
    with tempfile.TemporaryDirectory() as work:
        for case in args.cases:
            (Path(work) / case).mkdir()
            cases[case] = run_case(case, args, peers, Path(work) / case)
            print(f"{case} done", file=sys.stderr, flush=True)

    body, figures = "", {}
    fig, axes = harness.figure(len(cases), width=4.6, height=4.0)
    for ax, (case, data) in zip(axes[0], cases.items()):
        cells = []
        for name, row in data["solvers"].items():
            if "skipped" in row:
                cells.append([name, "", "", "", "", "", "", f"skipped: {row['skipped'][:120]}"])
                continue
            cells.append(
                [name, row["version"], f"{row['success_strict']:.1%}", f"{row['success_loose']:.1%}"]
                + [f"{row['success_strict_within_budget']:.1%}", f"{row['median_ms']:.2f}"]
                + [f"{row['p95_ms']:.2f}", note(row)]
            )
            for label, r in ((name, row), (f"{name} reused Solver", row.get("solver"))):
                if r:
                    ax.plot([r["median_ms"], r["p95_ms"]], [100 * r["success_strict"]] * 2, "-", alpha=0.5)
                    ax.plot(r["median_ms"], 100 * r["success_strict"], "o", label=label)
                    figures[f"{case} {label} median ms"] = r["median_ms"]
                    figures[f"{case} {label} p95 ms"] = r["p95_ms"]
                    figures[f"{case} {label} strict success"] = r["success_strict"]
        title = f"{case} ({data['dofs']} DOF, {data['base']} -> {data['tip']})"
        header = ["solver", "version", "strict", "loose", "≤5 ms", "median ms", "p95 ms", "note"]
        body += harness.md_table(header, cells, title) + "\n"
        ax.axvline(BUDGET_S * 1e3, color="grey", ls=":", lw=1)
        harness.style_axes(ax, "time per target, ms (median; line to p95)", "strict success, %", title, ylog=False)
    settings = {
        "targets": args.targets,
        "chunks": args.chunks,
        "seed": args.seed,
        "strict": STRICT,
        "loose": LOOSE,
        "budget_s": BUDGET_S,
        "deik": deik_settings(args.deik),
        "peers": list(peers),
        "turns": ", ".join(DEIK_TURNS + peers),
    }
    return run.finish({"settings": settings, "cases": cases}, body, fig, figures)


if __name__ == "__main__":
    main()

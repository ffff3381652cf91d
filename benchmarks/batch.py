"""Batch throughput: IK problems solved per second by one batched deik.solve() call.

    PYTHONPATH=src python -m benchmarks.batch [--device cpu|gpu] [--quick] [--out DIR]
        [--batches 1 10 100 1000 10000] [--populations 16 32 64] [--pick-batch 100]

Two problem sets, targets = FK of random in-limit poses (seeded):
- chain20: deik.chain(20), Position("tip") to within 1 % of its reach (tolerance 0.01 x reach);
- panda: the Panda arm (shared/data/robots/panda.urdf, panda_link0 -> panda_hand_tcp), Position
  to 5 mm and Orientation to 0.05 rad, every population seeded with the mid-limit pose.
Default Settings apart from a small population: each population of --populations is tried on a
batch of --pick-batch problems and the fastest with a success rate >= 99 % is kept (else the
most successful). Then for each batch size B: throughput = B / seconds of the single batched
solve() call (compilation excluded by a warm-up solve), success = fraction of problems whose
goals are met (Result.converged, errors recomputed in float64). On the CPU each batch is timed
with all Numba threads and with 1, side by side. GPU target for the Panda: >= 500,000 problems
per second (published: PyRoki about 70,000, cuRobo about 38,000 on an RTX 4090-class GPU).
Writes batch.json and batch.png into --out.
"""

from __future__ import annotations

import time

import numpy as np

import deik
from benchmarks import harness
from benchmarks.robot_targets import make_targets

GPU_TARGET = 5e5  # Panda problems per second
PUBLISHED = {"PyRoki": 7e4, "cuRobo": 3.8e4}  # Panda problems per second on an RTX 4090-class GPU
RELIABLE = 0.99
PANDA_TOLERANCES = (5e-3, 0.05)  # m, rad


def make_problem(name: str, batch: int, seed: int) -> tuple[deik.Problem, np.ndarray | None]:
    """(problem with `batch` targets, initial poses (1, D) or None) of problem set `name`."""
    if name == "chain20":
        sk = deik.chain(20)
        return harness.chain_problem(20, batch, seed, tolerance=0.01 * sk.reach), None
    t = make_targets("panda", batch, seed=seed)
    sk = deik.read_urdf(t["urdf"], t["base"], t["tip"])
    goals = [
        deik.Position(t["tip"], t["positions"], tolerance=PANDA_TOLERANCES[0]),
        deik.Orientation(t["tip"], t["rotations"], tolerance=PANDA_TOLERANCES[1]),
    ]
    return deik.Problem(sk, goals), t["start"][None]


def measure(name: str, batch: int, population: int, threads: int, args) -> dict:
    """Solve `batch` problems of set `name` in one call; seconds, problems/s and success."""
    problem, initial = make_problem(name, batch, args.seed)
    with harness.threads(threads):
        t = time.perf_counter()
        result = deik.solve(problem, initial=initial, **solve_settings(population, args))
        seconds = time.perf_counter() - t
    converged, generations = result.converged, result.generations
    return {
        "problem": name,
        "batch": batch,
        "population": population,
        "threads": threads,
        "seconds": seconds,
        "solver_wall_time": result.wall_time,
        "problems_per_second": batch / seconds,
        "success": float(converged.mean()),
        "generations_median": float(np.median(generations)),
        "generations_max": int(generations.max()),
        "errors_median": {g.label: float(np.median(g.error)) for g in result.goals},
    }


def solve_settings(population: int, args) -> dict:
    """deik.solve keyword overrides: the defaults but population. --quick keeps the default
    budget too: its batches are tiny, and a cut budget leaves a Panda target unmet at random."""
    return {"population": population, "seed": args.seed, "device": args.device, "dtype": args.dtype}


def pick_population(name: str, args) -> tuple[int, list[dict]]:
    """The fastest population with success >= RELIABLE on --pick-batch problems (else the most
    successful), and the rows of the trial."""
    trials = [measure(name, args.pick_batch, p, harness.thread_counts(args.device)[0], args) for p in args.populations]
    reliable = [r for r in trials if r["success"] >= RELIABLE]
    if not reliable:
        return max(trials, key=lambda r: r["success"])["population"], trials
    best = max(reliable, key=lambda r: r["problems_per_second"])
    return best["population"], trials


def plot(rows: list[dict], device: str):
    fig, axes = harness.figure()
    ax = axes[0, 0]
    counts = sorted({r["threads"] for r in rows}, reverse=True)
    for k, name in enumerate(sorted({r["problem"] for r in rows})):
        for threads, style in zip(counts, ("-", ":")):
            line = sorted(
                (r["batch"], r["problems_per_second"], r["success"])
                for r in rows
                if r["problem"] == name and r["threads"] == threads
            )
            population = next(r["population"] for r in rows if r["problem"] == name)
            ax.plot(
                [x[0] for x in line],
                [x[1] for x in line],
                "o" + style,
                color=f"C{k}",
                label=f"{name}, population {population}, {threads} thr.",
            )
            for b, rate, success in line:
                if success < 1:
                    ax.annotate(
                        f"{100 * success:.2f}%", (b, rate), fontsize=7, textcoords="offset points", xytext=(3, -9)
                    )
    if device == "gpu":
        ax.axhline(GPU_TARGET, color="k", linestyle="--", linewidth=1, label="target (Panda, GPU)")
        for k, (peer, rate) in enumerate(PUBLISHED.items()):
            ax.axhline(rate, color="grey", linestyle=":-"[k], linewidth=1, label=f"{peer} (published, RTX 4090)")
    harness.style_axes(
        ax,
        "batch size (problems per solve() call)",
        "problems solved per second",
        f"Batched IK throughput, {device.upper()} (labels: success < 100 %)",
    )
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    p = harness.parser(__doc__)
    p.add_argument("--problems", nargs="+", default=["chain20", "panda"], choices=("chain20", "panda"))
    p.add_argument("--batches", type=int, nargs="+", help="batch sizes (default 1 10 100 1000 10000; GPU also 100000)")
    p.add_argument("--populations", type=int, nargs="+", help="populations tried (default 16 32 64)")
    p.add_argument("--pick-batch", type=int, help="batch size of the population trial (default 100)")
    args = p.parse_args(argv)
    full_batches = [1, 10, 100, 1000, 10_000] + ([100_000] if args.device == "gpu" else [])
    sizes = (
        {"batches": [1, 4], "populations": [16, 32], "pick_batch": 4}
        if args.quick
        else {"batches": full_batches, "populations": [16, 32, 64], "pick_batch": 100}
    )
    opening = harness.start(args, sizes)

    rows, trials, chosen = [], [], {}
    for name in args.problems:
        measure(name, 2, args.populations[0], harness.thread_counts(args.device)[0], args)  # compile / load
        chosen[name], tried = pick_population(name, args)
        trials += tried
        for batch in args.batches:
            for threads in harness.thread_counts(args.device):
                row = measure(name, batch, chosen[name], threads, args)
                rows.append(row)
                print(
                    f"{name} batch {batch:6d} population {chosen[name]} threads {threads}: "
                    f"{row['problems_per_second']:.4g} problems/s, success {100 * row['success']:.2f} %",
                    flush=True,
                )

    panda = [r for r in rows if r["problem"] == "panda"]
    targets = []
    if panda:
        reached = max((r["problems_per_second"] for r in panda if r["success"] >= RELIABLE), default=0.0)
        targets.append(
            harness.target(
                f"Panda problems per second at >= {100 * RELIABLE:.0f} % success ({args.device})",
                GPU_TARGET,
                reached,
                "/s",
                args.device == "gpu" and not args.quick,
            )
        )
    result = harness.finish(
        "batch",
        args,
        opening,
        {
            "settings": {
                **solve_settings(0, args),
                "population": chosen,
                "populations_tried": args.populations,
                "pick_batch": args.pick_batch,
                "reliable_success": RELIABLE,
                "quick": args.quick,
                "chain20_tolerance": "0.01 x reach",
                "panda_tolerances_m_rad": PANDA_TOLERANCES,
                "panda_initial": "mid-limit pose",
            },
            "published_panda_problems_per_second": PUBLISHED,
            "population_trials": trials,
            "rows": rows,
            "targets": targets,
        },
        plot(rows, args.device),
    )
    harness.print_report(
        result,
        ["problem", "batch", "population", "threads", "seconds", "problems/s", "success", "generations median / max"],
        [
            [
                r["problem"] + (" (trial)" if r in trials else ""),
                r["batch"],
                r["population"],
                r["threads"],
                f"{r['seconds']:.3g}",
                f"{r['problems_per_second']:.4g}",
                f"{100 * r['success']:.2f} %",
                f"{r['generations_median']:g} / {r['generations_max']}",
            ]
            for r in trials + rows
        ],
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

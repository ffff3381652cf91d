"""Batch throughput: IK problems solved per second by one batched deik.solve() call.

    python -m benchmarks.batch [--device cpu|gpu] [--quick] [--problems chain20 panda]
        [--batches 1 10 100 1000 10000] [--populations 16 32 64] [--pick-batch 100]

Targets are the FK of random in-limit poses (seeded):
- chain20: deik.chain(20), Position("tip") within 1 % of its reach;
- panda: the Panda arm (panda_link0 -> panda_hand_tcp), Position to 5 mm and Orientation to
  0.05 rad, every population seeded with the mid-limit pose.
Default Settings but a small population: each of --populations is tried on --pick-batch
problems and the fastest with a success rate >= 99 % is kept (else the most successful). Then
per batch size B: problems per second = B / seconds of the one solve() call (compilation
excluded by a warm-up solve), success = the share of problems whose goals are met; on the CPU
with all Numba threads and with one. GPU target for the Panda: >= 500,000 problems per second
(published: PyRoki about 70,000, cuRobo about 38,000 on an RTX 4090-class GPU).
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
    """(a problem of `batch` targets of set `name`, initial poses (1, D) or None)."""
    if name == "chain20":
        return harness.chain_problem(20, batch, seed, tolerance=0.01 * deik.chain(20).reach), None
    t = make_targets("panda", batch, seed=seed)
    goals = [
        deik.Position(t["tip"], t["positions"], tolerance=PANDA_TOLERANCES[0]),
        deik.Orientation(t["tip"], t["rotations"], tolerance=PANDA_TOLERANCES[1]),
    ]
    return deik.Problem(deik.read_urdf(t["urdf"], t["base"], t["tip"]), goals), t["start"][None]


def measure(name: str, batch: int, population: int, threads: int, args) -> dict:
    """Solve `batch` problems of set `name` in one call: seconds, problems per second, success."""
    problem, initial = make_problem(name, batch, args.seed)
    settings = {"population": population, "seed": args.seed, "device": args.device, "dtype": args.dtype}
    with harness.threads(threads):
        began = time.perf_counter()
        result = deik.solve(problem, initial=initial, **settings)
        seconds = time.perf_counter() - began
    return {
        "problem": name,
        "batch": batch,
        "population": population,
        "threads": threads,
        "seconds": seconds,
        "problems_per_second": batch / seconds,
        "success": float(np.mean(result.converged)),
        "generations_median": float(np.median(result.generations)),
        "generations_max": int(np.max(result.generations)),
    }


def pick_population(name: str, args) -> tuple[int, list[dict]]:
    """The fastest population with success >= RELIABLE on --pick-batch problems (else the most
    successful), and the trial's rows."""
    threads = harness.thread_counts(args.device)[0]
    trials = [measure(name, args.pick_batch, pop, threads, args) for pop in args.populations]
    reliable = [r for r in trials if r["success"] >= RELIABLE]
    if not reliable:
        return max(trials, key=lambda r: r["success"])["population"], trials
    return max(reliable, key=lambda r: r["problems_per_second"])["population"], trials


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--problems", nargs="+", default=["chain20", "panda"], choices=("chain20", "panda"))
    p.add_argument("--batches", type=int, nargs="+", help="batch sizes (default 1 10 100 1000 10000; GPU 100000 too)")
    p.add_argument("--populations", type=int, nargs="+", help="populations tried (default 16 32 64)")
    p.add_argument("--pick-batch", type=int, help="batch size of the population trial (default 100)")
    full = {"batches": [1, 10, 100, 1000, 10_000], "populations": [16, 32, 64], "pick_batch": 100}
    run = harness.start("batch", p, argv, full, {"batches": [1, 4], "populations": [16, 32], "pick_batch": 4})
    args = run.args
    if args.device == "gpu" and not args.quick and 100_000 not in args.batches:
        args.batches.append(100_000)
    rows, trials, chosen = [], [], {}
    for name in args.problems:
        measure(name, 2, args.populations[0], 1, args)  # compile or load the kernels
        chosen[name], tried = pick_population(name, args)
        trials += tried
        for batch in args.batches:
            for threads in harness.thread_counts(args.device):
                rows.append(measure(name, batch, chosen[name], threads, args))
                r = rows[-1]
                print(f"{name} {batch} x{threads}: {r['problems_per_second']:.4g}/s, {r['success']:.2%}", flush=True)

    panda = [r["problems_per_second"] for r in rows if r["problem"] == "panda" and r["success"] >= RELIABLE]
    if "panda" in args.problems:
        what = f"Panda problems per second at >= {RELIABLE:.0%} success ({args.device})"
        run.target(what, GPU_TARGET, max(panda, default=0.0), "/s", args.device == "gpu" and not args.quick)
    fig, axes = harness.figure()
    for key in sorted({(r["problem"], r["threads"]) for r in rows}):
        line = [(r["batch"], r["problems_per_second"]) for r in rows if (r["problem"], r["threads"]) == key]
        axes[0, 0].plot(*zip(*line), "o-", label=f"{key[0]}, population {chosen[key[0]]}, {key[1]} thread(s)")
    if args.device == "gpu":
        for peer, rate in PUBLISHED.items():
            axes[0, 0].axhline(rate, color="grey", linestyle=":", label=f"{peer} (published, RTX 4090)")
    harness.style_axes(axes[0, 0], "problems per solve() call", "problems solved per second", args.device.upper())
    header = ["problem", "batch", "population", "threads", "seconds", "problems/s", "success", "generations median/max"]
    cells = [
        [r["problem"] + (" (trial)" if r in trials else ""), r["batch"], r["population"], r["threads"]]
        + [f"{r['seconds']:.3g}", f"{r['problems_per_second']:.4g}", f"{r['success']:.2%}"]
        + [f"{r['generations_median']:g} / {r['generations_max']}"]
        for r in trials + rows
    ]
    figures = {
        f"{r['problem']} x{r['batch']}, {r['threads']} thread(s), problems/s": r["problems_per_second"] for r in rows
    }
    figures |= {f"{r['problem']} x{r['batch']}, {r['threads']} thread(s), success": r["success"] for r in rows}
    result = {
        "settings": {
            "population": chosen,
            "populations_tried": args.populations,
            "dtype": args.dtype,
            "panda_tolerances_m_rad": PANDA_TOLERANCES,
            "quick": args.quick,
        },
        "published_panda_problems_per_second": PUBLISHED,
        "population_trials": trials,
        "rows": rows,
    }
    return run.finish(result, harness.md_table(header, cells), fig, figures)


if __name__ == "__main__":
    main()

"""Joint evaluations per second of the parallel DE engine, vs chain length and population.

    PYTHONPATH=src python -m benchmarks.throughput [--device cpu|gpu] [--quick] [--out DIR]
        [--links 10 20 50 100] [--populations 100 500 2000] [--batches 64] [--seconds 0.5]

Rate = population x joints x generations x batch / seconds of one Engine.run call (joints =
links of deik.chain(n), one Position goal on its tip). Only DE evaluation runs: polish and
restarts off, stop_on_converged False and a huge patience, so every generation evaluates every
individual. Each configuration is warmed up (compile or cache load excluded), its generation
count calibrated so one run takes about --seconds, then timed --repeats times (best kept).
The time of a 1-generation run (copies, launch) is recorded; "marginal" rates leave it out.
On the CPU every configuration is timed with all Numba threads and with 1, side by side.
Single problems (batch 1) are swept over links x populations; the batched rows fill the device
(CPU: 64 problems x 500 on the 100-link chain; GPU: 64, 4 and 16 problems per multiprocessor).
Targets: >= 5e7 per second on the CPU, >= 1e11 per second on the GPU with a batch.
Writes throughput.json and throughput.png into --out.
"""

from __future__ import annotations

import math

import deik
from benchmarks import harness

CPU_TARGET, GPU_TARGET = 5e7, 1e11


def measure(links: int, population: int, batch: int, threads: int, args) -> dict:
    """One configuration's timing row (rates in joint evaluations per second)."""
    problem = harness.chain_problem(links, batch, args.seed)
    engine = deik.Engine(problem, harness.evaluation_settings(population, args.device, args.dtype, args.seed))
    with harness.threads(threads):
        timed = harness.time_engine(engine, args.seconds, args.repeats)
    work = population * links * batch
    extra = min(timed["seconds"]) - timed["one_generation_seconds"]
    marginal = extra / (timed["generations"] - 1) if timed["generations"] > 1 else math.nan
    return {
        "links": links,
        "population": population,
        "batch": batch,
        "threads": threads,
        **timed,
        "joint_evaluations_per_second": work / timed["seconds_per_generation"],
        "marginal_joint_evaluations_per_second": work / marginal if marginal > 0 else math.nan,
    }


def batched_sizes(args) -> list[int]:
    """Batch sizes that fill the device: --batches, else 64 on the CPU and 64, 4 and 16 blocks
    per multiprocessor on the GPU."""
    if args.batches:
        return args.batches
    if args.device == "cpu":
        return [64]
    from numba import cuda

    sm = cuda.get_current_device().MULTIPROCESSOR_COUNT
    return [64, 4 * sm, 16 * sm]


def plot(rows: list[dict], goal: float, device: str):
    fig, axes = harness.figure()
    ax = axes[0, 0]
    counts = sorted({r["threads"] for r in rows}, reverse=True)
    for k, p in enumerate(sorted({r["population"] for r in rows if r["batch"] == 1})):
        for threads, style in zip(counts, ("-", ":")):
            line = sorted(
                (r["links"], r["joint_evaluations_per_second"])
                for r in rows
                if r["batch"] == 1 and r["population"] == p and r["threads"] == threads
            )
            ax.plot(*zip(*line), "o" + style, color=f"C{k}", label=f"population {p}, 1 problem, {threads} thr.")
    for k, r in enumerate(r for r in rows if r["batch"] > 1):
        ax.plot(
            r["links"],
            r["joint_evaluations_per_second"],
            "**^v<>"[k % 6],
            markersize=10,
            color=f"C{k + 3}",
            label=f"{r['batch']} problems x population {r['population']}, {r['threads']} thr.",
        )
    ax.axhline(goal, color="k", linestyle="--", linewidth=1, label=f"target {goal:.0e}/s")
    harness.style_axes(ax, "links (joints)", "joint evaluations per second", f"DE throughput, {device.upper()}")
    links = sorted({r["links"] for r in rows})
    ax.set_xticks(links, [str(n) for n in links])
    ax.minorticks_off()
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    p = harness.parser(__doc__)
    p.add_argument("--links", type=int, nargs="+", help="chain lengths (default 10 20 50 100)")
    p.add_argument("--populations", type=int, nargs="+", help="population sizes (default 100 500 2000)")
    p.add_argument("--batches", type=int, nargs="+", help="batch sizes of the batched rows")
    p.add_argument("--batch-links", type=int, help="chain length of the batched rows (default 100)")
    p.add_argument("--batch-population", type=int, help="population of the batched rows (default 500)")
    p.add_argument("--seconds", type=float, help="target seconds of one timed run (default 0.5)")
    p.add_argument("--repeats", type=int, default=3, help="timed runs per configuration, best kept")
    args = p.parse_args(argv)
    sizes = (
        {
            "links": [5, 10],
            "populations": [50, 100],
            "batches": [4],
            "batch_links": 10,
            "batch_population": 100,
            "seconds": 0.02,
        }
        if args.quick
        else {
            "links": [10, 20, 50, 100],
            "populations": [100, 500, 2000],
            "batch_links": 100,
            "batch_population": 500,
            "seconds": 0.5,
        }
    )
    opening = harness.start(args, sizes)

    rows = []
    configs = [(n, pop, 1) for n in args.links for pop in args.populations]
    configs += [(args.batch_links, args.batch_population, b) for b in batched_sizes(args)]
    for links, population, batch in configs:
        for threads in harness.thread_counts(args.device):
            row = measure(links, population, batch, threads, args)
            rows.append(row)
            print(
                f"links {links:4d} population {population:5d} batch {batch:5d} threads {threads}: "
                f"{row['joint_evaluations_per_second']:.3g} joint evaluations/s",
                flush=True,
            )

    gpu = args.device == "gpu"
    goal = GPU_TARGET if gpu else CPU_TARGET
    eligible = [r for r in rows if r["batch"] > 1] if gpu else rows
    best = max(eligible, key=lambda r: r["joint_evaluations_per_second"])
    settings = evaluation_settings_record(args)
    result = harness.finish(
        "throughput",
        args,
        opening,
        {
            "settings": settings,
            "rows": rows,
            "best": {k: best[k] for k in ("links", "population", "batch", "threads", "joint_evaluations_per_second")},
            "targets": [
                harness.target(
                    f"joint evaluations per second ({args.device})",
                    goal,
                    best["joint_evaluations_per_second"],
                    "/s",
                    not args.quick,
                )
            ],
        },
        plot(rows, goal, args.device),
    )
    harness.print_report(
        result,
        [
            "links",
            "population",
            "batch",
            "threads",
            "generations",
            "s/gen",
            "joint evals/s",
            "marginal /s",
            "1-gen run s",
        ],
        [
            [
                r["links"],
                r["population"],
                r["batch"],
                r["threads"],
                r["generations"],
                f"{r['seconds_per_generation']:.3g}",
                f"{r['joint_evaluations_per_second']:.3g}",
                f"{r['marginal_joint_evaluations_per_second']:.3g}",
                f"{r['one_generation_seconds']:.3g}",
            ]
            for r in rows
        ],
    )
    return 0


def evaluation_settings_record(args) -> dict:
    """The settings every row used, for the JSON."""
    s = harness.evaluation_settings(4, args.device, args.dtype, args.seed)
    return {
        "strategy": s.strategy,
        "adaptive": s.adaptive,
        "polish": s.polish,
        "restarts": s.restarts,
        "stop_on_converged": s.stop_on_converged,
        "dtype": s.dtype,
        "device": s.device,
        "seed": s.seed,
        "seconds_per_run": args.seconds,
        "repeats": args.repeats,
        "quick": args.quick,
        "problem": "deik.chain(n), Position('tip', FK of random in-limit poses)",
    }


if __name__ == "__main__":
    raise SystemExit(main())

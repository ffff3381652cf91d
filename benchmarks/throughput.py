"""Joint evaluations per second of the parallel DE engine, by problem, batch and population.

    python -m benchmarks.throughput [--device cpu|gpu] [--quick] [--dtype float32|float64]
        [--configs chain100x64 humanoidx8 ...] [--populations 100 500 2000] [--seconds 0.5]

Rate = problems x population x joints x generations / seconds of one Engine.run call. Only DE
evaluation runs (polish and restarts off, no stopping). A config is PROBLEMxBATCH: chainN (the
paper's chain, one Position goal on its tip; N joints) or humanoid (deik.humanoid(), Position
goals on both hands and both heels; its kernel joints), with BATCH problems whose targets are
the FK of random in-limit poses; every config runs at every population. Default: chain10,
chain20, chain50, chain100 x1 at populations 100, 500, 2000, and batches that fill the device
at population 500 (CPU: chain100x64; GPU: x64 and 4 and 16 problems per multiprocessor). Each
row is warmed up, its generation count calibrated to about --seconds a run, then timed
--repeats times (best kept); on the CPU with all Numba threads and with one, side by side, the
one-thread rows also by the thread's CPU time, which other processes inflate far less.
Targets: >= 5e7 per second on the CPU, >= 1e11 per second on the GPU with a batch.
"""

from __future__ import annotations

import numpy as np

import deik
from benchmarks import harness

CPU_TARGET, GPU_TARGET = 5e7, 1e11
HANDS_AND_HEELS = ("left_hand", "right_hand", "left_heel", "right_heel")


def problem(config: str, seed: int) -> tuple[deik.Problem, int, int]:
    """(the Problem, its kernel joints, its batch) of config PROBLEMxBATCH."""
    name, batch = config.split("x")
    if name.startswith("chain"):
        return harness.chain_problem(int(name[5:]), int(batch), seed), int(name[5:]), int(batch)
    h = deik.humanoid()
    poses = np.random.default_rng((seed, int(batch))).uniform(h.lower, h.upper, (int(batch), h.n_dofs))
    kin = deik.forward_kinematics(h, poses)
    goals = [deik.Position(site, kin.position(site)) for site in HANDS_AND_HEELS]
    return deik.Problem(h, goals), len(h.joint_names), int(batch)


def default_configs(args) -> list[tuple[str, int]]:
    """(config, population) pairs of the default sweep: single chains, then batches filling the device."""
    links, batches = ([5, 10], [4]) if args.quick else ([10, 20, 50, 100], [64])
    pairs = [(f"chain{n}x1", pop) for n in links for pop in args.populations]
    if args.device == "gpu" and not args.quick:
        from numba import cuda

        sm = cuda.get_current_device().MULTIPROCESSOR_COUNT
        batches = [64, 4 * sm, 16 * sm]
    population = 500 if 500 in args.populations else args.populations[-1]
    return pairs + [(f"chain{links[-1]}x{b}", population) for b in batches]


def measure(config: str, population: int, threads: int, args) -> dict:
    """One row: the timing and the rates in joint evaluations per second (wall; CPU time with one thread)."""
    prob, joints, batch = problem(config, args.seed)
    engine = deik.Engine(prob, harness.evaluation_settings(population, args.device, args.dtype, args.seed))
    with harness.threads(threads):
        timed = harness.time_engine(engine, args.seconds, args.repeats)
    work = population * joints * batch * timed["generations"]
    row = {
        "config": config,
        "population": population,
        "threads": threads,
        **timed,
        "rate": work / min(timed["seconds"]),
    }
    if threads == 1 and args.device == "cpu":
        row["cpu_time_rate"] = work / float(np.median(timed["cpu_seconds"]))
    return row


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--configs", nargs="+", help="PROBLEMxBATCH configs (default: the sweep above)")
    p.add_argument("--populations", type=int, nargs="+", help="population sizes (default 100 500 2000)")
    p.add_argument("--seconds", type=float, help="target seconds of one timed run (default 0.5)")
    p.add_argument("--repeats", type=int, help="timed runs per row, best kept (default 3)")
    quick = {"populations": [50, 100], "seconds": 0.02, "repeats": 1}
    run = harness.start("throughput", p, argv, {"populations": [100, 500, 2000], "seconds": 0.5, "repeats": 3}, quick)
    args = run.args
    pairs = [(c, pop) for c in args.configs for pop in args.populations] if args.configs else default_configs(args)
    rows = []
    for config, population in pairs:
        for threads in harness.thread_counts(args.device):
            rows.append(measure(config, population, threads, args))
            print(f"{config} population {population} threads {threads}: {rows[-1]['rate']:.3g}/s", flush=True)

    gpu = args.device == "gpu"
    eligible = [r for r in rows if not gpu or not r["config"].endswith("x1")] or rows
    best = max(eligible, key=lambda r: r["rate"])
    run.target(
        f"joint evaluations per second ({args.device})",
        GPU_TARGET if gpu else CPU_TARGET,
        best["rate"],
        "/s",
        not args.quick,
    )
    fig, axes = harness.figure()
    for label in sorted({(r["config"], r["threads"]) for r in rows}):
        line = [(r["population"], r["rate"]) for r in rows if (r["config"], r["threads"]) == label]
        axes[0, 0].plot(*zip(*line), "o-", label=f"{label[0]}, {label[1]} thread(s)")
    harness.style_axes(axes[0, 0], "population", "joint evaluations per second", f"DE throughput, {args.dtype}")
    header = [
        "config",
        "population",
        "threads",
        "generations",
        "s/gen",
        "joint evals/s",
        "CPU-time rate",
        "1-gen run s",
    ]
    cells = [
        [r["config"], r["population"], r["threads"], r["generations"], f"{r['seconds_per_generation']:.3g}"]
        + [
            f"{r['rate']:.3g}",
            f"{r['cpu_time_rate']:.3g}" if "cpu_time_rate" in r else "",
            f"{r['one_generation_seconds']:.3g}",
        ]
        for r in rows
    ]
    figures = {}
    for r in rows:
        label = f"{r['config']} population {r['population']}, {r['threads']} thread(s)"
        figures[label + ", joint evaluations/s"] = r["rate"]
        if "cpu_time_rate" in r:
            figures[label + ", by CPU time"] = r["cpu_time_rate"]
    settings = {"dtype": args.dtype, "seconds": args.seconds, "repeats": args.repeats, "quick": args.quick}
    return run.finish({"settings": settings, "rows": rows}, harness.md_table(header, cells), fig, figures)


if __name__ == "__main__":
    main()

"""Serial (Algorithm 1) against parallel (Figure 1) DE: seconds per generation against chain
length, the paper's headline case among them (issue 5 items 4a and 4c).

    python -m benchmarks.serial_vs_parallel [--device cpu|gpu] [--quick] [--links 10 20 50 100]
        [--population 500] [--generations 200] [--serial-epochs 3] [--repeats 5]

For each length n, deik.chain(n) with one Position goal on its tip (the FK of a random in-limit
pose; deik.experiments.timing), in one process, side by side:
- serial NumPy: deik.experiments.serial_numpy.SerialDE, one candidate evaluated at a time and
  replaced in place, averaged over --serial-epochs epochs (it is slow);
- serial compiled: CompiledSerialDE, the same Algorithm 1 compiled with the kernels' maths for
  one CPU thread (the paper's "serial CPU"), taking turns with the parallel engine repeat by
  repeat so that load drift hits both alike;
- parallel CPU: deik.Engine with Settings.paper (rand/1/bin, F 0.5, CR 0.5), every generation
  run, warmed up, best of --repeats runs of --generations generations;
- parallel GPU (--device gpu): the same on the GPU, --gpu-generations per launch.
Targets: the CPU engine >= 100x the NumPy serial at 100 links, population 500 (a; most of the
ratio is compiled code against NumPy); the GPU >= 1000x (c; the paper reports 12x).
"""

from __future__ import annotations

import numba

from benchmarks import harness
from deik.experiments.timing import make_problem, time_parallel, time_serial, time_serial_compiled

TARGET_LINKS, TARGET_POPULATION = 100, 500
ENGINES = {"serial": "serial NumPy", "serial_compiled": "serial compiled", "parallel": "parallel CPU", "gpu": "GPU"}


def best_of(runs: list[dict]) -> dict:
    """One timing from single-repeat runs: the fastest, with every repeat's seconds listed."""
    every = [r["seconds_per_generation"] for r in runs]
    return {**runs[every.index(min(every))], "repeats": len(runs), "all_seconds_per_generation": every}


def measure(n: int, args) -> dict:
    """One chain length's row: each engine's timing and the speed-ups over the NumPy serial."""
    problem = make_problem(n, args.seed)
    parallel, compiled = [], []
    for _ in range(args.repeats):
        parallel.append(time_parallel(problem, args.population, args.generations, 1, args.seed, args.dtype))
        compiled.append(
            time_serial_compiled(problem, args.population, args.serial_generations, 1, args.seed, args.dtype)
        )
    row = {
        "links": n,
        "threads": numba.get_num_threads(),
        "serial": time_serial(problem, args.population, args.serial_epochs, args.seed),
        "serial_compiled": best_of(compiled),
        "parallel": best_of(parallel),
    }
    if args.device == "gpu":
        pop, gens = args.population, args.gpu_generations
        row["gpu"] = time_parallel(problem, pop, gens, args.repeats, args.seed, args.dtype, "gpu")
    serial = row["serial"]["seconds_per_generation"]
    row["speedup"] = {e: serial / row[e]["seconds_per_generation"] for e in ENGINES if e in row}
    row["speedup_over_compiled"] = (
        row["serial_compiled"]["seconds_per_generation"] / (row["parallel"]["seconds_per_generation"])
    )
    return row


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--links", type=int, nargs="+", help="chain lengths (default 10 20 50 100)")
    p.add_argument("--population", type=int, help="population size (default 500)")
    p.add_argument("--generations", type=int, help="parallel CPU generations per timed run (default 200)")
    p.add_argument("--gpu-generations", type=int, help="GPU generations per timed launch (default 1000)")
    p.add_argument("--serial-epochs", type=int, help="NumPy serial epochs averaged (default 3)")
    p.add_argument("--serial-generations", type=int, help="compiled serial epochs per repeat (default 20)")
    p.add_argument("--repeats", type=int, help="timed runs of the engines, best kept (default 5)")
    full = {"links": [10, 20, 50, 100], "population": 500, "generations": 200, "gpu_generations": 1000}
    full |= {"serial_epochs": 3, "serial_generations": 20, "repeats": 5}
    quick = {"links": [5, 10, 20], "population": 100, "generations": 50, "gpu_generations": 20}
    quick |= {"serial_epochs": 1, "serial_generations": 5, "repeats": 1}
    run = harness.start("serial_vs_parallel", p, argv, full, quick)
    args = run.args
    rows = []
    for n in args.links:
        rows.append(measure(n, args))
        print(f"links {n}: speed-ups over NumPy {rows[-1]['speedup']}", flush=True)

    at = next((r for r in rows if r["links"] == TARGET_LINKS), None)
    case = at is not None and args.population == TARGET_POPULATION
    speedup = at["speedup"] if at else {}
    run.target("parallel CPU over serial NumPy per generation, 100 links", 100.0, speedup.get("parallel"), "x", case)
    run.target("GPU over serial NumPy per generation, 100 links", 1000.0, speedup.get("gpu"), "x", case and "gpu" in at)

    engines = [e for e in ENGINES if e in rows[0]]
    fig, axes = harness.figure()
    for e in engines:
        axes[0, 0].plot(args.links, [r[e]["seconds_per_generation"] for r in rows], "o-", label=ENGINES[e])
    harness.style_axes(axes[0, 0], "links", "seconds per generation", f"DE, population {args.population}")
    header = ["links", *(f"{ENGINES[e]} s/gen" for e in engines), "parallel CPU vs NumPy", "vs compiled"]
    cells = [
        [r["links"], *(f"{r[e]['seconds_per_generation']:.4g}" for e in engines)]
        + [f"{r['speedup']['parallel']:.0f}x", f"{r['speedup_over_compiled']:.1f}x"]
        for r in rows
    ]
    figures = {f"{ENGINES[e]} s/gen, {r['links']} links": r[e]["seconds_per_generation"] for r in rows for e in engines}
    settings = {k: getattr(args, k) for k in ("population", "generations", "serial_epochs", "repeats", "dtype")}
    return run.finish({"settings": settings, "rows": rows}, harness.md_table(header, cells), fig, figures)


if __name__ == "__main__":
    main()

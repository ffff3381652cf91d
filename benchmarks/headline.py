"""The paper's headline case: time per generation, serial CPU reference vs the parallel engine.

    PYTHONPATH=src python -m benchmarks.headline [--device cpu|gpu] [--quick] [--out DIR]
        [--links 100] [--population 500] [--generations 200] [--serial-epochs 3]

One problem: deik.chain(100), Position("tip", FK of a random pose), population 500, the
paper's settings (rand/1/bin, F 0.5, CR 0.5; deik.experiments.timing). In the same process:
the serial reference (deik.experiments.serial_numpy.SerialDE, Algorithm 1 in NumPy, averaged over
--serial-epochs epochs), the parallel CPU engine, and with --device gpu the GPU engine (one
block, every generation of a run in one launch), each warmed up and timed over --generations
generations (best of --repeats; the GPU runs --gpu-generations per launch). Target (GPU only):
>= 1000x the serial reference per generation (the paper reports 12x). Writes headline.json and
headline.png into --out.
"""

from __future__ import annotations

import numba

from benchmarks import harness
from deik.experiments.timing import make_problem, time_parallel, time_serial

TARGET_SPEEDUP, TARGET_LINKS, TARGET_POPULATION = 1000.0, 100, 500


def plot(rows: list[dict], links: int, population: int):
    fig, axes = harness.figure()
    ax = axes[0, 0]
    seconds = [r["seconds_per_generation"] for r in rows]
    ax.bar([r["engine"] for r in rows], seconds, color=[f"C{k}" for k in range(len(rows))])
    for k, r in enumerate(rows):
        ax.annotate(
            f"{r['seconds_per_generation']:.3g} s" + (f"\n{r['speedup']:.0f}x" if k else ""),
            (k, r["seconds_per_generation"]),
            ha="center",
            va="bottom",
            fontsize=8,
        )
    ax.set_yscale("log")
    ax.set_ylabel("seconds per generation")
    ax.set_title(f"{links}-link chain, population {population}, one problem")
    ax.grid(True, axis="y", which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    p = harness.parser(__doc__)
    p.add_argument("--links", type=int, help="chain length (default 100)")
    p.add_argument("--population", type=int, help="population (default 500)")
    p.add_argument("--generations", type=int, help="CPU engine generations per timed run (default 200)")
    p.add_argument("--gpu-generations", type=int, help="GPU generations per timed launch (default 1000)")
    p.add_argument("--serial-epochs", type=int, help="serial epochs averaged (default 3)")
    p.add_argument("--repeats", type=int, default=5, help="timed runs of the engines, best kept")
    args = p.parse_args(argv)
    sizes = (
        {"links": 20, "population": 100, "generations": 20, "gpu_generations": 20, "serial_epochs": 1}
        if args.quick
        else {
            "links": TARGET_LINKS,
            "population": TARGET_POPULATION,
            "generations": 200,
            "gpu_generations": 1000,
            "serial_epochs": 3,
        }
    )
    opening = harness.start(args, sizes)

    problem = make_problem(args.links, args.seed)
    serial = time_serial(problem, args.population, args.serial_epochs, args.seed)
    rows = [{"engine": "serial (Algorithm 1, NumPy)", **serial}]
    cpu = time_parallel(problem, args.population, args.generations, args.repeats, args.seed, args.dtype, "cpu")
    rows.append({"engine": f"parallel CPU ({numba.get_num_threads()} threads)", **cpu})
    if args.device == "gpu":
        rows.append(
            {
                "engine": "parallel GPU",
                **time_parallel(
                    problem, args.population, args.gpu_generations, args.repeats, args.seed, args.dtype, "gpu"
                ),
            }
        )
    for r in rows:
        r["speedup"] = serial["seconds_per_generation"] / r["seconds_per_generation"]
        print(f"{r['engine']}: {r['seconds_per_generation']:.4g} s/generation, {r['speedup']:.0f}x", flush=True)

    headline = args.links == TARGET_LINKS and args.population == TARGET_POPULATION
    result = harness.finish(
        "headline",
        args,
        opening,
        {
            "settings": {
                "links": args.links,
                "population": args.population,
                "generations": args.generations,
                "gpu_generations": args.gpu_generations,
                "serial_epochs": args.serial_epochs,
                "repeats": args.repeats,
                "seed": args.seed,
                "dtype": args.dtype,
                "quick": args.quick,
                "problem": "deik.chain(n), Position('tip', FK of a random pose); Settings.paper",
            },
            "rows": rows,
            "targets": [
                harness.target(
                    f"speed-up per generation over the serial reference ({rows[-1]['engine']})",
                    TARGET_SPEEDUP,
                    rows[-1]["speedup"],
                    "x",
                    args.device == "gpu" and headline,
                )
            ],
        },
        plot(rows, args.links, args.population),
    )
    harness.print_report(
        result,
        ["engine", "seconds per generation", "speed-up"],
        [[r["engine"], f"{r['seconds_per_generation']:.4g}", f"{r['speedup']:.0f}x"] for r in rows],
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Serial (Algorithm 1) vs parallel (Figure 1) DE: seconds per generation against chain length.

    python -m benchmarks.serial_vs_parallel [--links 10 20 50 100] [--population 500]
                                            [--generations 200] [--serial-epochs 3] [--quick]

For each length n: the paper's planar chain deik.chain(n) with one Position goal on its tip,
the target being the FK of a random in-limit pose. In the same process, side by side:
- serial: deik.experiments.serial_numpy.SerialDE (NumPy, one candidate evaluated at a time, in-place
  replacement), averaged over a few epochs because it is slow;
- serial compiled: deik.experiments.serial_numpy.CompiledSerialDE, the same Algorithm 1 compiled with the
  kernels' maths for one CPU thread (the paper's "serial CPU"), taking turns with the parallel
  engine repeat by repeat;
- parallel: deik.Engine on the CPU (Numba, ping-pong buffers), Settings.paper (rand/1/bin,
  F 0.5, CR 0.5) with stop_on_converged=False and a huge patience so every generation runs,
  warmed up once so compilation is excluded, timed over --generations generations (best of
  --repeats).
Writes benchmarks/results/serial_vs_parallel.{json,png} atomically and prints a markdown table.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import numba

from deik.experiments.shared import log_time_axes
from deik.experiments.timing import environment, make_problem, time_parallel, time_serial, time_serial_compiled

RESULTS = Path(__file__).resolve().parent / "results"
TARGET_LINKS, TARGET_SPEEDUP = 100, 100.0


def write_atomic(path: Path, write) -> None:
    """Write through a temporary file in the same folder, then os.replace it into place."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    try:
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def plot(rows: list[dict], population: int, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    links = [r["links"] for r in rows]
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(links, [r["serial"]["seconds_per_generation"] for r in rows], "o-", label="serial (Algorithm 1, NumPy)")
    ax.plot(
        links,
        [r["serial_compiled"]["seconds_per_generation"] for r in rows],
        "^-",
        label="serial (Algorithm 1, compiled, 1 thread)",
    )
    ax.plot(
        links,
        [r["parallel"]["seconds_per_generation"] for r in rows],
        "s-",
        label=f"parallel CPU engine ({rows[0]['threads']} Numba threads)",
    )
    for r in rows:  # speed-up written halfway (geometrically) between the two curves
        mid = (r["serial"]["seconds_per_generation"] * r["parallel"]["seconds_per_generation"]) ** 0.5
        ax.annotate(f"{r['speedup']:.0f}x", (r["links"], mid), ha="center", va="center", fontsize=8)
    log_time_axes(ax, links, f"DE time per generation, population {population}")
    ax.legend()
    fig.tight_layout()
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=120, format="png"))
    plt.close(fig)


def table(rows: list[dict]) -> str:
    lines = [
        "| links | serial NumPy s/gen | serial compiled s/gen | parallel s/gen | vs NumPy | vs compiled |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['links']} | {r['serial']['seconds_per_generation']:.4f} | "
            f"{r['serial_compiled']['seconds_per_generation']:.6f} | {r['parallel']['seconds_per_generation']:.6f} | "
            f"{r['speedup']:.0f}x | {r['speedup_vs_compiled_serial']:.1f}x |"
        )
    return "\n".join(lines)


def _best_of(runs: list[dict]) -> dict:
    """One timing dict from single-repeat runs: the fastest, with every repeat listed."""
    every = [r["seconds_per_generation"] for r in runs]
    best = runs[every.index(min(every))]
    return {**best, "repeats": len(runs), "all_seconds_per_generation": every}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--links", type=int, nargs="+", help="chain lengths (default 10 20 50 100)")
    p.add_argument("--population", type=int, help="population size (default 500)")
    p.add_argument("--generations", type=int, help="parallel generations timed (default 200)")
    p.add_argument("--serial-epochs", type=int, help="NumPy serial epochs averaged (default 3)")
    p.add_argument("--serial-generations", type=int, help="compiled serial epochs per repeat (default 20)")
    p.add_argument("--repeats", type=int, default=5, help="parallel timing repeats, best taken")
    p.add_argument("--dtype", default="float32", choices=("float32", "float64"), help="parallel engine dtype")
    p.add_argument("--threads", type=int, help="Numba threads for the parallel engine (default: all)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--quick", action="store_true", help="small smoke run (links 5 10 20, population 100)")
    p.add_argument("--out", type=Path, default=RESULTS, help="results folder")
    a = p.parse_args(argv)
    quick = {"links": [5, 10, 20], "population": 100, "generations": 50, "serial_epochs": 1, "serial_generations": 5}
    full = {
        "links": [10, 20, 50, 100],
        "population": 500,
        "generations": 200,
        "serial_epochs": 3,
        "serial_generations": 20,
    }
    for k, v in (quick if a.quick else full).items():
        if getattr(a, k) is None:
            setattr(a, k, v)

    if a.threads:
        numba.set_num_threads(a.threads)
    load_before = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    rows = []
    for n in a.links:
        problem = make_problem(n, a.seed)
        # the parallel engine and the compiled serial DE take turns, one repeat each, so that
        # load drift on a shared machine hits both alike; the best repeat of each counts
        par, comp = [], []
        for _ in range(a.repeats):
            par.append(time_parallel(problem, a.population, a.generations, 1, a.seed, a.dtype))
            comp.append(time_serial_compiled(problem, a.population, a.serial_generations, 1, a.seed, a.dtype))
        par, comp = _best_of(par), _best_of(comp)
        ser = time_serial(problem, a.population, a.serial_epochs, a.seed)
        row = {
            "links": n,
            "dofs": problem.skeleton.n_dofs,
            "threads": numba.get_num_threads(),
            "serial": ser,
            "serial_compiled": comp,
            "parallel": par,
            "speedup": ser["seconds_per_generation"] / par["seconds_per_generation"],
            "speedup_vs_compiled_serial": comp["seconds_per_generation"] / par["seconds_per_generation"],
        }
        rows.append(row)
        print(
            f"links {n:4d}: serial NumPy {ser['seconds_per_generation']:.4f} s/gen, serial compiled "
            f"{comp['seconds_per_generation']:.6f} s/gen, parallel {par['seconds_per_generation']:.6f} s/gen: "
            f"{row['speedup']:.0f}x and {row['speedup_vs_compiled_serial']:.1f}x",
            flush=True,
        )

    at_target = [r for r in rows if r["links"] == TARGET_LINKS]
    met = None if not at_target else bool(at_target[0]["speedup"] >= TARGET_SPEEDUP)
    result = {
        "benchmark": "serial_vs_parallel",
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "settings": {
            "population": a.population,
            "parallel_generations": a.generations,
            "serial_epochs": a.serial_epochs,
            "repeats": a.repeats,
            "seed": a.seed,
            "quick": a.quick,
            "problem": "deik.chain(n), Position('tip', FK of a random pose)",
            "limits": "reflect (Problem default)",
        },
        "environment": {**environment(), "load_average_before": load_before},
        "target": {"links": TARGET_LINKS, "speedup": TARGET_SPEEDUP, "met": met},
        "rows": rows,
    }
    write_atomic(
        a.out / "serial_vs_parallel.json", lambda tmp: Path(tmp).write_text(json.dumps(result, indent=2) + "\n")
    )
    plot(rows, a.population, a.out / "serial_vs_parallel.png")

    env = result["environment"]
    print()
    print(
        f"population {a.population}; {env['numba_threads']} Numba threads on {env['cpu_count']} CPUs; "
        f"{env['platform']}; numpy {env['numpy']}, numba {env['numba']}"
    )
    if load_before and load_before[0] > 0.5 * (env["cpu_affinity"] or env["cpu_count"]):
        print(
            f"warning: load average {load_before[0]:.1f} on {env['cpu_count']} CPUs before the run: other "
            "processes compete and the parallel timings (threads waiting at each generation) are noisy"
        )
    print()
    print(table(rows))
    print()
    if met is None:
        print(f"Target (>= {TARGET_SPEEDUP:.0f}x at {TARGET_LINKS} links): not measured (add --links {TARGET_LINKS})")
    else:
        print(
            f"Target (>= {TARGET_SPEEDUP:.0f}x at {TARGET_LINKS} links): {'MET' if met else 'NOT MET'} "
            f"({at_target[0]['speedup']:.0f}x)"
        )
    print(f"wrote {a.out / 'serial_vs_parallel.json'} and {a.out / 'serial_vs_parallel.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

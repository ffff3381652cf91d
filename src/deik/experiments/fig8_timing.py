"""Fig. 8: wall time vs number of generations, population 500, for several joint counts, CPU and GPU.

The parallel engine runs the paper's chain problem (`deik.experiments.timing.make_problem`)
with the paper's settings and every generation forced to run; for each checkpoint G the time of
one `Engine.run(state, G)` from a warmed-up state is measured (`timing.time_parallel`, which
excludes compilation), so on the GPU each point is one kernel launch doing G generations. The
GPU part runs only where numba.cuda sees a GPU; elsewhere the report says it is pending.
"""

from __future__ import annotations

import os

import numpy as np

from deik.experiments.shared import Section, command, markdown_table, save_figure, write_csv
from deik.experiments.timing import cpu_model, gpu_plan, gpu_status, load_line, make_problem, time_parallel
from deik.viz.plot import require_matplotlib

NAME = "fig8"
SEED = 0


def sizes(quick: bool) -> dict:
    """Joint counts, population, generation checkpoints and repeats of the full or quick run."""
    if quick:
        return {"links": [5, 10], "population": 50, "checkpoints": [5, 20], "repeats": 1}
    return {"links": [10, 20, 50, 100], "population": 500, "checkpoints": [10, 100, 250, 500, 1000], "repeats": 3}


def time_curve(links: int, population: int, checkpoints: list[int], repeats: int, device: str) -> list[dict]:
    """One row per (checkpoint G, repeat): seconds for G generations on `device` ("cpu"/"gpu")."""
    problem = make_problem(links, SEED)
    rows = []
    for G in checkpoints:
        timed = time_parallel(problem, population, G, repeats, SEED, "float32", device)
        for r, per_generation in enumerate(timed["all_seconds_per_generation"]):
            rows.append(
                {
                    "device": device,
                    "links": links,
                    "population": population,
                    "generations": G,
                    "repeat": r,
                    "seconds": per_generation * G,
                }
            )
    return rows


def best_times(rows: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """(generations (K,), best-of-repeats seconds (K,)) of one device's and length's rows."""
    g = np.array(sorted({r["generations"] for r in rows}), float)
    return g, np.array([min(r["seconds"] for r in rows if r["generations"] == G) for G in g])


def linear_fit(rows: list[dict]) -> tuple[float, float]:
    """(seconds per generation, R^2) of a least-squares line through the best-of-repeats
    times vs generations of `rows`."""
    g, t = best_times(rows)
    if len(g) < 2:
        return float(t[0] / g[0]), 1.0
    a, b = np.polyfit(g, t, 1)
    residual = t - (a * g + b)
    total = ((t - t.mean()) ** 2).sum()
    return float(a), float(1.0 - (residual**2).sum() / total) if total > 0 else 1.0


def run(out_dir: str, quick: bool = False, device: str = "auto") -> Section:
    """CPU (and, when present or asked for, GPU) time curves; write fig8.{csv,png}. CSV: one row
    per (device, links, generations, repeat) with the wall time in seconds."""
    cfg = sizes(quick)
    use_gpu, note = gpu_plan(device)
    devices = ["cpu"] + (["gpu"] if use_gpu else [])
    names = {"cpu": cpu_model(), "gpu": gpu_status()[1] if use_gpu else None}
    rows = [
        dict(row, device_name=names[row["device"]])
        for d in devices
        for n in cfg["links"]
        for row in time_curve(n, cfg["population"], cfg["checkpoints"], cfg["repeats"], d)
    ]
    write_csv(os.path.join(out_dir, f"{NAME}.csv"), rows)
    _plot(out_dir, cfg, rows, devices)

    fits = {
        (d, n): linear_fit([r for r in rows if (r["device"], r["links"]) == (d, n)])
        for d in devices
        for n in cfg["links"]
    }
    per_gen = {key: fit[0] for key, fit in fits.items()}
    worst_r2 = min(fit[1] for fit in fits.values())
    G = cfg["checkpoints"][-1]
    table = []
    for n in cfg["links"]:
        at_G = {
            d: min(r["seconds"] for r in rows if (r["device"], r["links"], r["generations"]) == (d, n, G))
            for d in devices
        }
        gpu = f"{per_gen[('gpu', n)] * 1e3:.3f} ms, {at_G['gpu']:.3f} s" if use_gpu else "pending"
        table.append([n, f"{per_gen[('cpu', n)] * 1e3:.3f} ms", f"{at_G['cpu']:.3f} s", gpu])
    cpu_line = ", ".join(f"{n} joints {per_gen[('cpu', n)] * 1e3:.2f} ms" for n in cfg["links"])
    gpu_line = (
        ", ".join(f"{n} joints {per_gen[('gpu', n)] * 1e3:.2f} ms" for n in cfg["links"])
        if use_gpu
        else "pending (no GPU in this run)"
    )
    shape = "linearly" if worst_r2 > 0.99 else "not quite linearly"
    headline = (
        f"Population {cfg['population']}: time grows {shape} with generations (least-squares R^2 >= "
        f"{worst_r2:.3f}); seconds per generation on the CPU ({names['cpu']}): {cpu_line}. GPU: {gpu_line}."
    )
    if use_gpu:
        ratios = [per_gen[("gpu", n)] / per_gen[("cpu", n)] for n in cfg["links"]]
        below = sum(r < 1 for r in ratios)
        headline += (
            f" The GPU's line lies below the CPU's at {below} of {len(ratios)} joint counts "
            f"(GPU / CPU time per generation {min(ratios):.2f}-{max(ratios):.2f}x)."
        )
    measurement = markdown_table(
        [
            "joints",
            "CPU per generation (slope)",
            f"CPU, {G} generations (best of {cfg['repeats']})",
            f"GPU per generation, {G} generations",
        ],
        table,
    ) + (
        f"\n\nCPU: {names['cpu']}. GPU: {names['gpu'] or 'none in this run'}. Compilation is excluded (warm-up "
        f"run); every point is the best of {cfg['repeats']} repeats (the CSV has all). {load_line()}"
    )
    return Section(
        name=NAME,
        title="Fig. 8: time vs generations, CPU and GPU",
        claim="With population 500, the time to run a given number of generations grows linearly with "
        "the generations for every joint count, and the GPU implementation's lines lie below the "
        "CPU's.",
        headline=headline,
        measurement=measurement,
        differences="The paper's CPU line is its serial implementation; ours is deik's parallel CPU engine "
        "(Numba threads on every core); the serial algorithm is timed in Fig. 9. The paper names "
        "neither its CPU nor its GPU. On the GPU deik runs one problem per thread block, so one "
        "problem uses one multiprocessor; the paper's kernel layout is not described.",
        command=command(NAME, quick),
        notes=[note] if note else [],
    )


def _plot(out_dir: str, cfg: dict, rows: list[dict], devices: list[str]) -> None:
    plt = require_matplotlib()
    figure, ax = plt.subplots(figsize=(7.5, 5))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, n in enumerate(cfg["links"]):
        for d in devices:
            sel = [r for r in rows if (r["device"], r["links"]) == (d, n)]
            g, best = best_times(sel)
            ax.plot(
                g,
                best,
                "o-" if d == "cpu" else "s--",
                color=colours[k % len(colours)],
                label=f"{n} joints, {d.upper()}",
            )
    ax.set_xlabel("generations")
    ax.set_ylabel(f"seconds (best of {cfg['repeats']})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    gpu = "" if "gpu" in devices else " (GPU pending)"
    ax.set_title(f"Fig. 8: parallel DE, population {cfg['population']}{gpu}")
    figure.tight_layout()
    save_figure(figure, os.path.join(out_dir, f"{NAME}.png"))

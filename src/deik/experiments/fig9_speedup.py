"""Fig. 9: serial CPU vs parallel timing per generation, and the speed-up at population 500.

Same problem and timing code as `benchmarks/serial_vs_parallel.py` (`deik.experiments.timing`):
the serial Algorithm 1 (`SerialDE`, NumPy, one candidate at a time) against deik's parallel
engine on the CPU with every Numba thread, with one thread (which separates compiled code
from parallelism), and on the GPU where numba.cuda sees one. The paper's headline is 12x for
its GPU over its serial CPU at population 500 and 100 links.
"""

from __future__ import annotations

import os

import numba

from deik.experiments.shared import Section, command, log_time_axes, markdown_table, save_figure, write_csv
from deik.experiments.timing import cpu_model, gpu_plan, gpu_status, load_line, make_problem, time_parallel, time_serial
from deik.viz.plot import require_matplotlib

NAME = "fig9"
SEED = 0
PAPER_SPEEDUP, PAPER_LINKS, PAPER_POPULATION = 12.0, 100, 500


def sizes(quick: bool) -> dict:
    """Chain lengths, population, serial epochs, parallel generations and repeats."""
    if quick:
        return {"links": [5, 10], "population": 50, "serial_epochs": 1, "generations": 20, "repeats": 2}
    return {
        "links": [10, 20, 50, 100],
        "population": PAPER_POPULATION,
        "serial_epochs": 3,
        "generations": 200,
        "repeats": 5,
    }


def time_all(links: int, cfg: dict, use_gpu: bool) -> list[dict]:
    """Rows for one chain length: serial (one row, averaged over its epochs) and one row per
    repeat of each parallel implementation, each with seconds per generation."""
    problem = make_problem(links, SEED)
    serial = time_serial(problem, cfg["population"], cfg["serial_epochs"], SEED)
    rows = [
        {
            "links": links,
            "implementation": "serial CPU (Algorithm 1, NumPy)",
            "device": "cpu",
            "threads": 1,
            "repeat": 0,
            "seconds_per_generation": serial["seconds_per_generation"],
        }
    ]
    threads = numba.get_num_threads()
    variants = [("parallel CPU, all threads", "cpu", threads), ("parallel CPU, 1 thread", "cpu", 1)]
    variants += [("parallel GPU", "gpu", None)] if use_gpu else []
    for name, device, n_threads in variants:
        if n_threads:
            numba.set_num_threads(n_threads)
        try:
            timed = time_parallel(
                problem, cfg["population"], cfg["generations"], cfg["repeats"], SEED, "float32", device
            )
        finally:
            numba.set_num_threads(threads)
        rows += [
            {
                "links": links,
                "implementation": name,
                "device": device,
                "threads": n_threads,
                "repeat": r,
                "seconds_per_generation": s,
            }
            for r, s in enumerate(timed["all_seconds_per_generation"])
        ]
    return rows


def run(out_dir: str, quick: bool = False, device: str = "auto") -> Section:
    """Time every implementation at every chain length; write fig9.{csv,png}. CSV: one row per
    (links, implementation, repeat). Parallel times are the best of repeats in the report."""
    cfg = sizes(quick)
    use_gpu, note = gpu_plan(device)
    rows = [row for n in cfg["links"] for row in time_all(n, cfg, use_gpu)]
    write_csv(os.path.join(out_dir, f"{NAME}.csv"), rows)
    implementations = list(dict.fromkeys(r["implementation"] for r in rows))
    keys = {(x["links"], x["implementation"]) for x in rows}
    med = {
        k: min(x["seconds_per_generation"] for x in rows if (x["links"], x["implementation"]) == k) for k in keys
    }  # best of repeats, as the benchmark
    _plot(out_dir, cfg, med, implementations)

    serial, par, one, gpu = implementations[0], implementations[1], implementations[2], "parallel GPU"
    table = []
    for n in cfg["links"]:
        cells = [
            n,
            f"{med[(n, serial)]:.4f}",
            f"{med[(n, par)] * 1e3:.3f} ms",
            f"{med[(n, one)] * 1e3:.3f} ms",
            f"{med[(n, serial)] / med[(n, par)]:.0f}x",
            f"{med[(n, one)] / med[(n, par)]:.2f}x",
        ]
        if use_gpu:
            cells += [f"{med[(n, gpu)] * 1e3:.3f} ms", f"{med[(n, serial)] / med[(n, gpu)]:.0f}x"]
        else:
            cells += ["pending"] * 2
        table.append(cells)
    n = PAPER_LINKS if PAPER_LINKS in cfg["links"] else cfg["links"][-1]
    p = cfg["population"]
    gpu_ratio = (
        f"serial/parallel-GPU {med[(n, serial)] / med[(n, gpu)]:.0f}x on {gpu_status()[1]}"
        if use_gpu
        else "serial/parallel-GPU pending (it needs an NVIDIA GPU: H100, H200)"
    )
    headline = (
        f"At population {p} and {n} links: serial/parallel-CPU {med[(n, serial)] / med[(n, par)]:.0f}x "
        f"({numba.get_num_threads()} threads on {cpu_model()}), of which the threads give "
        f"{med[(n, one)] / med[(n, par)]:.2f}x; {gpu_ratio}. The paper: 12x (its GPU vs its serial CPU)."
    )
    measurement = markdown_table(
        [
            "links",
            "serial s/gen",
            "parallel CPU s/gen",
            "parallel CPU, 1 thread",
            "serial / parallel CPU",
            "1 thread / all threads",
            "parallel GPU s/gen",
            "serial / parallel GPU",
        ],
        table,
    ) + (
        f"\n\nSerial: mean of {cfg['serial_epochs']} epochs; parallel: best of {cfg['repeats']} runs of "
        f"{cfg['generations']} generations (the CSV has all), compilation excluded. CPU: {cpu_model()}. "
        f"{load_line()}"
    )
    return Section(
        name=NAME,
        title="Fig. 9: serial CPU vs parallel",
        claim=f"Averaged over 100 iterations, the parallel CUDA implementation is {PAPER_SPEEDUP:.0f}x faster than "
        f"the serial CPU version at population {PAPER_POPULATION} with {PAPER_LINKS} links.",
        headline=headline,
        measurement=measurement,
        differences="The ratio is not the paper's quantity: our serial baseline is interpreted NumPy (one "
        "Python-level fitness call per candidate), the parallel engine is compiled (Numba), so "
        "most of the CPU ratio is compiled vs interpreted code; the 1-thread column isolates it, and "
        f"the 1 thread / all threads column is the parallel part on this CPU's {numba.get_num_threads()} "
        "threads. The paper compared two compiled implementations (C++ and CUDA) and names neither device. "
        "Timings are taken on a shared machine; the CSV keeps every repeat.",
        command=command(NAME, quick),
        notes=[note] if note else [],
    )


def _plot(out_dir: str, cfg: dict, med: dict, implementations: list[str]) -> None:
    plt = require_matplotlib()
    figure, ax = plt.subplots(figsize=(7.5, 5))
    links = cfg["links"]
    for name, style in zip(implementations, ("o-", "s-", "^--", "D-")):
        ax.plot(links, [med[(n, name)] for n in links], style, label=name)
    serial, parallel = implementations[0], implementations[1]
    for n in links:
        ax.annotate(
            f"{med[(n, serial)] / med[(n, parallel)]:.0f}x",
            (n, med[(n, parallel)]),
            textcoords="offset points",
            xytext=(0, -14),
            ha="center",
            fontsize=8,
        )
    gpu = "" if any("GPU" in i for i in implementations) else " (GPU pending)"
    log_time_axes(ax, links, f"Fig. 9: population {cfg['population']}; labels: serial / parallel CPU{gpu}")
    ax.legend(fontsize="small")
    figure.tight_layout()
    save_figure(figure, os.path.join(out_dir, f"{NAME}.png"))

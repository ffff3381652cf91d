"""Plumbing shared by the throughput, headline, batch and memory benchmarks.

Command line (--device, --quick, --out, --threads, --dtype, --seed), machine facts, the
batched chain problem, timing of Engine.run over a calibrated number of generations, and the
atomic JSON + PNG outputs (deik.io.atomic, deik.experiments.shared). Units: seconds, bytes.
"""

from __future__ import annotations

import argparse
import os
import time
from contextlib import contextmanager
from importlib import metadata
from pathlib import Path

import numba
import numpy as np

import deik
from benchmarks.serial_vs_parallel import RESULTS
from deik.experiments.shared import markdown_table, save_figure
from deik.experiments.timing import cpu_model, environment, gpu_status
from deik.io.atomic import write_json_atomically
from deik.viz.plot import require_matplotlib

MAX_GENERATIONS = 1_000_000  # cap of the calibrated generation count of one Engine.run


def parser(doc: str) -> argparse.ArgumentParser:
    """Options every benchmark takes; `doc` is the module docstring (first paragraph used)."""
    p = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    p.add_argument("--device", default="cpu", choices=("cpu", "gpu"), help="engine device (default cpu)")
    p.add_argument("--quick", action="store_true", help="tiny sizes: a smoke run of seconds")
    p.add_argument("--out", type=Path, default=RESULTS, help="results folder (default benchmarks/results)")
    p.add_argument("--threads", type=int, help="Numba CPU threads (default: all)")
    p.add_argument("--dtype", default="float32", choices=("float32", "float64"))
    p.add_argument("--seed", type=int, default=0)
    return p


def start(args, sizes: dict | None = None) -> dict:
    """Fill every option left unset from `sizes`, one repeat with --quick; apply --threads,
    fail early when --device gpu has no GPU; returns the run's opening facts (wall clock start,
    load average before)."""
    for key, value in (sizes or {}).items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    if args.quick and hasattr(args, "repeats"):
        args.repeats = 1
    if args.threads:
        numba.set_num_threads(args.threads)
    if args.device == "gpu":
        available, why = gpu_status()
        if not available:
            raise SystemExit(f"--device gpu: {why}")
    return {"t0": time.perf_counter(), "load_before": list(os.getloadavg())}


def thread_counts(device: str) -> list[int]:
    """Numba thread counts to time side by side: all threads and 1 on the CPU (on a shared
    machine a descheduled thread stalls every generation's parallel region), [all] on the GPU."""
    n = numba.get_num_threads()
    return [n] if device == "gpu" or n == 1 else [n, 1]


@contextmanager
def threads(n: int):
    """Run the body with `n` Numba threads, then restore the count."""
    before = numba.get_num_threads()
    numba.set_num_threads(n)
    try:
        yield
    finally:
        numba.set_num_threads(before)


def machine(device: str, opening: dict) -> dict:
    """CPU model and count, Numba threads and threading layer, load average before and now,
    versions, and for --device gpu the GPU's name, memory and multiprocessor count."""
    env = {**environment(), "cpu_model": cpu_model(), "load_average_before": opening["load_before"], "device": device}
    if device == "gpu":
        from numba import cuda

        gpu = cuda.get_current_device()
        env.update(
            gpu_name=gpu_status()[1],
            gpu_multiprocessors=getattr(gpu, "MULTIPROCESSOR_COUNT", None),
            gpu_memory_bytes=float(cuda.current_context().get_memory_info()[1]),
            gpu_compute_capability=list(getattr(gpu, "compute_capability", ())),
        )
        try:
            env["numba_cuda"] = metadata.version("numba-cuda")
        except metadata.PackageNotFoundError:
            env["numba_cuda"] = None
    return env


def chain_problem(links: int, batch: int, seed: int, tolerance: float | None = None) -> deik.Problem:
    """deik.chain(links) with a Position goal on "tip": targets (batch, 3) are the FK of random
    in-limit poses (length units); `tolerance` in length units or None."""
    sk = deik.chain(links)
    poses = np.random.default_rng((seed, links, batch)).uniform(sk.lower, sk.upper, (batch, sk.n_dofs))
    targets = deik.forward_kinematics(sk, poses).position("tip")
    return deik.Problem(sk, [deik.Position("tip", targets, tolerance=tolerance)])


def evaluation_settings(
    population: int, device: str, dtype: str, seed: int, generations: int = MAX_GENERATIONS
) -> deik.Settings:
    """Default settings with only DE evaluation left: no polish, no restarts, no stopping; a
    budget of `generations` (the memory check counts the history of the whole budget)."""
    return deik.Settings(
        population=population,
        generations=generations,
        polish=0,
        restarts=0,
        stop_on_converged=False,
        patience=10**9,
        seed=seed,
        device=device,
        dtype=dtype,
    )


def timed_run(engine: deik.Engine, state, generations: int) -> float:
    """Seconds of engine.run(state, generations); raises if the engine stopped early."""
    t = time.perf_counter()
    out = engine.run(state, generations)
    seconds = time.perf_counter() - t
    if out.generation != state.generation + generations:
        raise RuntimeError(f"engine stopped after {out.generation - state.generation} of {generations} generations")
    return seconds


def time_engine(engine: deik.Engine, seconds: float, repeats: int) -> dict:
    """Warm up (compile or cache load excluded), then find a generation count G whose run takes
    about `seconds` and time `repeats` runs of G generations from the same state. Returns G,
    every run's seconds, the best seconds per generation and the seconds of a 1-generation run
    (copies and launch: the fixed overhead of a call)."""
    state = engine.run(engine.init(), 2)
    one = min(timed_run(engine, state, 1) for _ in range(3))
    g, t = 1, one
    while t < seconds and g < MAX_GENERATIONS:
        g = min(MAX_GENERATIONS, max(2 * g, int(1.2 * g * seconds / max(t, 1e-9))))
        t = timed_run(engine, state, g)
    times = [t] + [timed_run(engine, state, g) for _ in range(repeats - 1)]
    return {"generations": g, "seconds": times, "seconds_per_generation": min(times) / g, "one_generation_seconds": one}


def finish(name: str, args, opening: dict, result: dict, figure) -> dict:
    """Add the machine facts and wall time to `result`, write NAME.json and NAME.png (the
    matplotlib `figure`) into args.out atomically; returns the completed result."""
    result = {
        "benchmark": name,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "command": command(name, args),
        **result,
        "environment": machine(args.device, opening),
        "seconds": time.perf_counter() - opening["t0"],
    }
    args.out.mkdir(parents=True, exist_ok=True)
    write_json_atomically(args.out / f"{name}.json", result, missing_as_null=True)
    save_figure(figure, str(args.out / f"{name}.png"))
    return result


def command(name: str, args) -> str:
    """The command that reruns benchmark `name` with these options."""
    flags = f" --device {args.device}" + (" --quick" if args.quick else "")
    return f"PYTHONPATH=src python -m benchmarks.{name}{flags} --out {args.out}"


def print_report(result: dict, header: list[str], rows: list[list]) -> None:
    """Machine line, markdown table and the targets of a finished benchmark."""
    env = result["environment"]
    where = env.get("gpu_name") or (
        f"{env['cpu_model']}, {env['numba_threads']} Numba threads ({env['numba_threading_layer']})"
    )
    print(
        f"\n{result['benchmark']} on {where}, {env['cpu_count']} CPUs; load average before "
        f"{env['load_average_before'][0]:.2f}, after {env['load_average_1_5_15'][0]:.2f}; "
        f"numpy {env['numpy']}, numba {env['numba']}; {result['seconds']:.1f} s\n"
    )
    print(markdown_table(header, rows))
    for t in result["targets"]:
        verdict = "not measured here" if t["met"] is None else ("MET" if t["met"] else "NOT MET")
        print(f"Target: {t['what']} {t['comparison']} {t['goal']:.3g} {t['unit']}: {verdict} ({t['reached']:.3g})")
    print(f"wrote {result['command'].split('--out ')[-1]}/{result['benchmark']}.{{json,png}}")


def target(what: str, goal: float, reached: float, unit: str, applies: bool, at_most: bool = False) -> dict:
    """One target, reached >= goal (or <= goal when `at_most`): met is None where it does not
    apply to this run (device, quick sizes)."""
    met = reached <= goal if at_most else reached >= goal
    return {
        "what": what,
        "goal": goal,
        "reached": reached,
        "unit": unit,
        "comparison": "<=" if at_most else ">=",
        "met": bool(met) if applies else None,
    }


def style_axes(ax, xlabel: str, ylabel: str, title: str, ylog: bool = True) -> None:
    """Log x (and y) axes, labels, title, a light grid and a small legend."""
    ax.set_xscale("log")
    if ylog:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)


def figure(ncols: int = 1):
    """A matplotlib (figure, axes) pair on the Agg backend."""
    plt = require_matplotlib()
    return plt.subplots(1, ncols, figsize=(6.4 * ncols, 4.4), squeeze=False)

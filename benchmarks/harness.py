"""The one harness every benchmark runs on: its command line, the environment record, programs
taking turns on chunks, and the JSON + Markdown + PNG results written in one place.

A benchmark is one module with `main(argv=None)`: `start` parses its options, `Run.target`
records its targets, `Run.finish` adds the command, the commit of the deik it measured and the
environment (CPU model and SIMD flags, Numba threads, load average before and after, versions,
the GPU), writes NAME.json, NAME.md and NAME.png into --out atomically, prints the Markdown and
returns the record (benchmarks/README.md has an example). `figures` (label -> number) are what
benchmarks.compare sets side by side for two commits. The plumbing uses the standard library,
NumPy, Numba, matplotlib, deik.experiments.timing and deik.io.atomic (in every deik since
2026-11-21), never deik's other internals, so that a benchmark runs unchanged against an
earlier deik.
"""

from __future__ import annotations

import argparse
import os
import platform
import shlex
import subprocess
import sys
import time
from contextlib import contextmanager
from importlib import metadata
from pathlib import Path

import numba
import numpy as np

from deik.experiments.timing import gpu_status, threading_layer
from deik.io.atomic import save_atomically, write_json_atomically, write_text_atomically

RESULTS = Path(__file__).resolve().parent / "results"
MAX_GENERATIONS = 1_000_000  # cap of the calibrated generation count of one Engine.run
SIMD_FLAGS = ("sse", "avx", "fma", "amx", "neon", "asimd", "sve")  # the /proc/cpuinfo flags recorded


def parser(doc: str) -> argparse.ArgumentParser:
    """The options every benchmark takes; `doc` is its module docstring (first paragraph used)."""
    p = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    p.add_argument("--device", default="cpu", choices=("cpu", "gpu"), help="engine device (default cpu)")
    p.add_argument("--quick", action="store_true", help="tiny sizes: a smoke run of seconds")
    p.add_argument("--out", type=Path, default=RESULTS, help="results folder (default benchmarks/results)")
    p.add_argument("--threads", type=int, help="Numba CPU threads (default: all)")
    p.add_argument("--dtype", default="float32", choices=("float32", "float64"))
    p.add_argument("--seed", type=int, default=0)
    return p


def start(name: str, p: argparse.ArgumentParser, argv=None, full: dict | None = None, quick: dict | None = None):
    """Parse `argv` (default sys.argv), fill every option left None from `quick` (with --quick)
    or `full`, apply --threads, stop early when --device gpu has no GPU; returns the Run."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = p.parse_args(argv)
    for key, value in ((quick if args.quick else full) or {}).items():
        if getattr(args, key, None) is None:
            setattr(args, key, value)
    if args.threads:
        numba.set_num_threads(args.threads)
    if args.device == "gpu":
        available, why = gpu_status()
        if not available:
            raise SystemExit(f"--device gpu: {why}")
    return Run(name, args, argv)


class Run:
    """One run of benchmarks.NAME: its arguments, its targets, and `finish`, which writes the
    results under `name` (NAME unless the benchmark renames its record, e.g. wheel_install_view)."""

    def __init__(self, name: str, args: argparse.Namespace, argv: list[str]):
        self.module = self.name = name
        self.args, self.argv = args, argv
        self.targets: list[dict] = []
        self.began, self.load_before = time.perf_counter(), list(os.getloadavg())

    def target(self, what: str, goal: float, reached: float, unit: str, applies: bool = True, at_most=False):
        """Record a target: reached >= goal (<= with at_most); met is None where it does not
        apply to this run (another device, the quick sizes)."""
        met = reached is not None and (reached <= goal if at_most else reached >= goal)
        self.targets.append(
            {
                "what": what,
                "goal": goal,
                "reached": reached,
                "unit": unit,
                "comparison": "<=" if at_most else ">=",
                "met": bool(met) if applies else None,
            }
        )

    def finish(self, result: dict, body: str = "", figure=None, figures: dict | None = None) -> dict:
        """Write NAME.json (the record: `result` with the command, commit, targets, figures and
        environment), NAME.md (`body` and the targets) and NAME.png (`figure`, a matplotlib
        figure, if any) into --out; print the Markdown; return the record."""
        figures = figures if figures is not None else {t["what"]: t["reached"] for t in self.targets}
        record = {
            "benchmark": self.name,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "command": f"python -m benchmarks.{self.module} {shlex.join(self.argv)}".strip(),
            "commit": deik_commit(),
            **result,
            "targets": self.targets,
            "figures": figures,
            "environment": environment(self.args.device, self.load_before),
            "seconds": time.perf_counter() - self.began,
        }
        text = markdown(record, body)
        folder = Path(self.args.out)
        folder.mkdir(parents=True, exist_ok=True)
        write_json_atomically(folder / f"{self.name}.json", record, missing_as_null=True)
        write_text_atomically(folder / f"{self.name}.md", text)
        if figure is not None:
            save_figure(figure, folder / f"{self.name}.png")
        print(text)
        return record


def markdown(record: dict, body: str) -> str:
    """A record's Markdown: how it was measured (command, commit, machine, load), `body`, targets."""
    env = record["environment"]
    where = env.get("gpu_name") or f"{env['cpu_model']}, {env['cpu_count']} CPUs, {env['numba_threads']} Numba threads"
    lines = [
        f"# {record['benchmark']}",
        "",
        f"`{record['command']}` at {record['commit']}; {where}; load average {env['load_average_before'][0]:.2f} "
        f"before, {env['load_average_after'][0]:.2f} after; {record['seconds']:.0f} s.",
        "",
        body.strip(),
        "",
    ]
    for t in record["targets"]:
        verdict = "not judged here" if t["met"] is None else ("met" if t["met"] else "NOT met")
        reached = "-" if t["reached"] is None else f"{t['reached']:.3g}"
        lines.append(f"- Target: {t['what']} {t['comparison']} {t['goal']:.3g} {t['unit']}: {reached}, {verdict}")
    return "\n".join(lines).rstrip() + "\n"


def md_table(header: list[str], rows: list[list], title: str | None = None) -> str:
    """A Markdown table (a "|" in a cell escaped), under a `### title` when given."""
    lines = [f"### {title}", ""] if title else []
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


# --- the environment record -------------------------------------------------------------------


def cpu_info() -> tuple[str, list[str]]:
    """(the CPU's model name, its SIMD and FMA flags) from /proc/cpuinfo, else platform's."""
    model, flags = platform.processor() or platform.machine(), []
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as file:
            for line in file:
                key, _, value = line.partition(":")
                if key.strip() == "model name" and model == (platform.processor() or platform.machine()):
                    model = value.strip()
                elif key.strip() in ("flags", "Features") and not flags:
                    flags = sorted(f for f in value.split() if f.startswith(SIMD_FLAGS))
    except OSError:
        pass
    return model, flags


def _host_cpu_name() -> str:
    """LLVM's name of this CPU (e.g. "znver4"), the target Numba compiles for by default."""
    import llvmlite.binding as llvm

    llvm.initialize_native_target()
    return llvm.get_host_cpu_name()


def environment(device: str, load_before: list[float]) -> dict:
    """What the figures depend on: CPU model and SIMD flags, CPU and Numba thread counts and
    threading layer, load average before and after, platform and versions; with --device gpu the
    GPU's name, memory, multiprocessors and compute capability."""
    import deik

    model, flags = cpu_info()
    env = {
        "device": device,
        "cpu_model": model,
        "cpu_flags": flags,
        "cpu_count": os.cpu_count(),
        "cpu_affinity": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "numba_threads": numba.get_num_threads(),
        "numba_threading_layer": threading_layer(),
        # what Numba compiles the kernels for: this CPU unless NUMBA_CPU_NAME / NUMBA_CPU_FEATURES say otherwise
        "numba_cpu_name": numba.config.CPU_NAME or _host_cpu_name(),
        "numba_cpu_features_set": numba.config.CPU_FEATURES is not None,
        "load_average_before": load_before,
        "load_average_after": list(os.getloadavg()),
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "numba": numba.__version__,
        "deik": deik.__version__,
        "deik_source": str(Path(deik.__file__).parent),
    }
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


def deik_commit() -> str:
    """The commit of the deik being measured (short hash, "+changes" when its src/ differs from
    it), or "unknown" outside a git checkout."""
    import deik

    folder = Path(deik.__file__).resolve().parent
    git = ["git", "-C", str(folder)]
    try:
        head = subprocess.run([*git, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
        dirty = subprocess.run([*git, "status", "--porcelain", "--untracked-files=no", "--", "."], capture_output=True)
    except OSError:
        return "unknown"
    return head.stdout.strip() + ("+changes" if dirty.stdout.strip() else "") if head.returncode == 0 else "unknown"


# --- writing ------------------------------------------------------------------------------------


def figure(ncols: int = 1, nrows: int = 1, width: float = 6.4, height: float = 4.4):
    """A matplotlib (figure, axes (nrows, ncols)) pair on the file-only Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(nrows, ncols, figsize=(width * ncols, height * nrows), squeeze=False)


def save_figure(fig, path: Path) -> None:
    """Save a matplotlib figure as PNG atomically and close it."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    save_atomically(path, lambda temporary: fig.savefig(temporary, format="png", dpi=110))
    plt.close(fig)


def style_axes(ax, xlabel: str, ylabel: str, title: str, xlog: bool = True, ylog: bool = True) -> None:
    """Labels, title, log axes where asked, a light grid and a small legend."""
    if xlog:
        ax.set_xscale("log")
    if ylog:
        ax.set_yscale("log")
    ax.set(xlabel=xlabel, ylabel=ylabel, title=title)
    ax.grid(True, which="both", alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)


def bars(ax, labels: list[str], values: list[float], horizontal: bool = False) -> None:
    """One bar per label, horizontal ones top to bottom."""
    if horizontal:
        ax.barh(labels[::-1], values[::-1])
    else:
        ax.bar(labels, values)
        ax.tick_params(axis="x", labelrotation=30, labelsize=7)


# --- programs taking turns on chunks --------------------------------------------------------------


class Dropped(RuntimeError):
    """Raised by a runner that cannot go on (a peer that died): it drops out of the later turns."""


def chunk_bounds(n: int, chunks: int) -> list[tuple[int, int]]:
    """range(n) in `chunks` consecutive (start, stop) pieces whose sizes differ by at most 1
    (fewer when n < chunks; none empty)."""
    edges = np.linspace(0, n, min(chunks, n) + 1).round().astype(int) if n else [0]
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def turn_order(n: int, chunks: int, names: list[str]) -> list[tuple[str, int, int]]:
    """The turns (name, start, stop): chunk by chunk, each program once per chunk, in the orders
    of a balanced Latin square (Williams), so that over a full cycle of orders (k chunks for k
    programs, 2k for odd k) every program follows every other equally often. What ran before a
    turn matters: a deik solve after a peer's turn meets cold caches and sleeping threads (0.33
    ms, then 0.14, against 0.094 warm), and in one fixed order the same program always took it."""
    k = len(names)
    first = [0] + [(j + 1) // 2 if j % 2 else k - j // 2 for j in range(1, k)]  # 0, 1, k-1, 2, k-2, ...
    orders = [[names[(i + shift) % k] for i in first] for shift in range(k)]
    orders += [order[::-1] for order in orders] if k % 2 else []
    bounds = chunk_bounds(n, chunks)
    return [(name, a, b) for chunk, (a, b) in enumerate(bounds) for name in orders[chunk % len(orders)]]


def take_turns(runners: dict, n: int, chunks: int, label: str = "") -> dict[str, dict]:
    """Run every runner (start, stop) -> {key: list} on every chunk of range(n), taking turns
    chunk by chunk, so that drifting load on a shared machine hits all alike. Returns per runner
    its lists joined in order, or {"skipped": reason} for one that raised Dropped."""
    outputs: dict[str, dict] = {name: {} for name in runners}
    for turn, (name, a, b) in enumerate(turn_order(n, chunks, list(runners))):
        if "skipped" in outputs[name]:
            continue
        try:
            out = runners[name](a, b)
        except Dropped as error:
            outputs[name] = {"skipped": str(error)}
            continue
        for key, values in out.items():
            outputs[name].setdefault(key, []).extend(values)
        if (turn + 1) % len(runners) == 0:
            print(f"{label} chunk {b}/{n} done", file=sys.stderr, flush=True)
    return outputs


# --- the DE engine, timed ------------------------------------------------------------------------


def thread_counts(device: str) -> list[int]:
    """Numba thread counts to time side by side: all and 1 on the CPU (on a shared machine a
    descheduled thread stalls every generation's parallel region), [all] on the GPU."""
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


def chain_problem(links: int, batch: int, seed: int, tolerance: float | None = None):
    """deik.chain(links) with a Position goal on "tip": targets (batch, 3) are the FK of random
    in-limit poses (length units); `tolerance` in length units or None."""
    import deik

    sk = deik.chain(links)
    poses = np.random.default_rng((seed, links, batch)).uniform(sk.lower, sk.upper, (batch, sk.n_dofs))
    targets = deik.forward_kinematics(sk, poses).position("tip")
    return deik.Problem(sk, [deik.Position("tip", targets, tolerance=tolerance)])


def evaluation_settings(population: int, device: str, dtype: str, seed: int, generations: int = MAX_GENERATIONS):
    """Default settings with only DE evaluation left: no polish, no restarts, no stopping."""
    import deik

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


def timed_run(engine, state, generations: int) -> tuple[float, float]:
    """(wall seconds, the calling thread's CPU seconds) of engine.run(state, generations);
    raises if the engine stopped early."""
    wall, cpu = time.perf_counter(), time.thread_time()
    out = engine.run(state, generations)
    wall, cpu = time.perf_counter() - wall, time.thread_time() - cpu
    if out.generation != state.generation + generations:
        raise RuntimeError(f"engine stopped after {out.generation - state.generation} of {generations} generations")
    return wall, cpu


def time_engine(engine, seconds: float, repeats: int) -> dict:
    """Warm up (compilation excluded), find a generation count G whose run takes about
    `seconds`, and time `repeats` runs of G generations from one state: G, every run's wall and
    CPU seconds (the calling thread's: a one-thread run's own, whatever else the machine runs),
    the best seconds per generation, and the seconds of a 1-generation run (copies, launch)."""
    state = engine.run(engine.init(), 2)
    one = min(timed_run(engine, state, 1)[0] for _ in range(3))
    g, t = 1, one
    while t < seconds and g < MAX_GENERATIONS:
        g = min(MAX_GENERATIONS, max(2 * g, int(1.2 * g * seconds / max(t, 1e-9))))
        t = timed_run(engine, state, g)[0]
    runs = [timed_run(engine, state, g) for _ in range(repeats)]
    walls = [wall for wall, _ in runs]
    return {
        "generations": g,
        "seconds": walls,
        "cpu_seconds": [cpu for _, cpu in runs],
        "seconds_per_generation": min(walls) / g,
        "one_generation_seconds": one,
    }

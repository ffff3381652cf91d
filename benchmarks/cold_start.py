"""What a user waits for: the first solve after an install, `deik warmup`, and every later call,
each in a fresh process, two checkouts of deik taking turns.

    PYTHONPATH=src python -m benchmarks.cold_start --before ../before-cold [--repeats 2] [--out DIR]

--before is a checkout of an earlier commit (`git worktree add ../before-cold COMMIT`). Every
measurement runs `python` in a fresh process on one checkout (its src/ first on PYTHONPATH) and
times it from outside: wall seconds and the child's CPU seconds (user + system, getrusage), which
other processes on a shared machine inflate less than the wall. Cases:
- first solve, float32 or float64, with the LM polish or without (`--polish 0 --generations 20`):
  `deik solve chain:20 --reach tip 12 8 0` with an empty NUMBA_CACHE_DIR, as after an install;
  then the same command twice on the cache it filled: "compile" is the first run's wall minus
  the median of those (and, where the checkout records them, each kernel's compile seconds);
- warmup: `deik warmup --quiet` with an empty cache;
- warm solve: `deik solve chain:20 --reach tip 12 8 0` on a filled cache (every call);
- import deik: `python -c "import deik"`; version: `deik --version`;
- python: `python -c pass`, the interpreter's own start, for scale.
Cases take turns between the checkouts, the order swapped every repeat, so load drift hits both.
Bytecode is compiled first and kept, as in an installed package. Writes cold_start.json,
cold_start.md and cold_start.png into --out (default benchmarks/results/cold_start).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SOLVE = ["-m", "deik", "solve", "chain:20", "--reach", "tip", "12", "8", "0"]
# without the polish DE alone runs 2000 generations on this target, seconds that vary with the
# machine's load: 20 generations keep the compile what the first run waits for
FIRST_SOLVES = {
    "first solve float32": [],
    "first solve float32, no polish": ["--polish", "0", "--generations", "20"],
    "first solve float64": ["--dtype", "float64"],
    "first solve float64, no polish": ["--dtype", "float64", "--polish", "0", "--generations", "20"],
}
CALLS = {
    "warm solve": SOLVE,
    "import deik": ["-c", "import deik"],
    "deik --version": ["-m", "deik", "--version"],
    "python -c pass": ["-c", "pass"],
}
CALL_REPEATS = 5  # runs of each cheap call per turn (median kept)


def _run(tree: Path, args: list[str], cache: Path) -> dict:
    """Wall and CPU seconds of `python ARGS` on checkout `tree` with NUMBA_CACHE_DIR=cache."""
    env = {key: value for key, value in os.environ.items() if key != "PYTHONDONTWRITEBYTECODE"}
    env.update(PYTHONPATH=str(tree / "src"), NUMBA_CACHE_DIR=str(cache))
    before = os.times()
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, *args], cwd=tree, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = os.times()
    if done.returncode != 0:
        raise RuntimeError(f"{tree}: python {' '.join(args)} failed: {done.stderr[-2000:]}")
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    return {"wall": wall, "cpu": cpu, "stderr": done.stderr.strip().splitlines()[:1]}


def _first_solve(tree: Path, flags: list[str]) -> dict:
    """A cold solve on an empty cache, then two warm ones on what it compiled."""
    with tempfile.TemporaryDirectory(prefix="deik-cold-") as cache:
        cold = _run(tree, SOLVE + flags, Path(cache))
        warm = [_run(tree, SOLVE + flags, Path(cache))["wall"] for _ in range(2)]
        records = _records(Path(cache))
    compile_wall = cold["wall"] - float(np.median(warm))
    return {**cold, "warm_wall": float(np.median(warm)), "compile_wall": compile_wall, "kernels": records}


def _records(cache: Path) -> list[dict]:
    """What each kernel's compile took, as deik records it beside the cache (solver/readiness.py;
    none before it did)."""
    return [json.loads(path.read_text()) for path in cache.rglob("deik-compile-seconds.json")]


def _warmup(tree: Path) -> dict:
    with tempfile.TemporaryDirectory(prefix="deik-cold-") as cache:
        return {**_run(tree, ["-m", "deik", "warmup", "--quiet"], Path(cache)), "kernels": _records(Path(cache))}


def _call(tree: Path, args: list[str], cache: Path) -> dict:
    runs = [_run(tree, args, cache) for _ in range(CALL_REPEATS)]
    return {"wall": float(np.median([r["wall"] for r in runs])), "cpu": float(np.median([r["cpu"] for r in runs]))}


def _commit(tree: Path) -> str:
    done = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    return done.stdout.strip() or str(tree)


def _summary(runs: list[dict]) -> dict:
    """Median and every run of each number the runs of one case hold."""
    keys = [k for k in runs[0] if isinstance(runs[0][k], float)]
    return {**{k: float(np.median([r[k] for r in runs])) for k in keys}, "runs": runs}


def markdown(result: dict) -> str:
    names = list(result["trees"])
    lines = [
        f"Fresh processes, {result['repeats']} turns per case, before ({result['trees']['before']}) and after "
        f"({result['trees']['after']}) taking turns; CPU {result['cpu_model']} ({result['cpu_count']} cores, "
        f"shared; load average {result['load_average_before'][0]:.1f} before, "
        f"{result['load_average_after'][0]:.1f} after). Median seconds, wall (CPU).",
        "",
        "| case | " + " | ".join(names) + " | after / before (wall) |",
        "|---|" + "---:|" * (len(names) + 1),
    ]
    for case, rows in result["cases"].items():
        cells = []
        for name in names:
            row = rows[name]
            extra = f", compile {row['compile_wall']:.1f}" if "compile_wall" in row else ""
            cells.append(f"{row['wall']:.2f} ({row['cpu']:.2f}{extra})")
        ratio = rows["after"]["wall"] / rows["before"]["wall"]
        lines.append(f"| {case} | " + " | ".join(cells) + f" | {ratio:.2f} |")
    return "\n".join(lines) + "\n"


def figure(result: dict):
    from deik.viz.plot import require_matplotlib

    plt = require_matplotlib()
    cases = list(result["cases"])
    fig, ax = plt.subplots(figsize=(8, 0.5 * len(cases) + 1.5))
    y = np.arange(len(cases))
    for k, (name, colour) in enumerate((("before", "tab:gray"), ("after", "tab:blue"))):
        wall = [result["cases"][c][name]["wall"] for c in cases]
        cpu = [result["cases"][c][name]["cpu"] for c in cases]
        ax.barh(
            y + (0.2 if k == 0 else -0.2), wall, height=0.4, color=colour, label=f"{name} ({result['trees'][name]})"
        )
        ax.plot(cpu, y + (0.2 if k == 0 else -0.2), "k|", markersize=9)
    ax.set_yticks(y, cases)
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("seconds, median of fresh processes (bar: wall, tick: CPU)")
    ax.set_title(f"deik cold start and every call ({result['cpu_model']}, {result['cpu_count']} cores)")
    ax.legend(loc="lower right")
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--before", type=Path, required=True, help="a checkout of the earlier deik")
    p.add_argument("--repeats", type=int, default=2, help="turns per case and checkout")
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "cold_start")
    p.add_argument("--cases", nargs="+", metavar="CASE", help="only these cases (default: all), e.g. 'import deik'")
    a = p.parse_args(argv)
    if not (a.before / "src" / "deik").is_dir():
        p.error("--before DIR: give a checkout of deik (git worktree add DIR COMMIT)")
    from benchmarks.serial_vs_parallel import write_atomic
    from deik.experiments.shared import save_figure
    from deik.experiments.timing import cpu_model

    trees = {"before": a.before.resolve(), "after": ROOT}
    load_before = list(os.getloadavg())
    began = time.perf_counter()
    warm_caches = {name: Path(tempfile.mkdtemp(prefix=f"deik-warm-{name}-")) for name in trees}
    try:
        for name, tree in trees.items():  # bytecode as installed, and a filled cache for the warm calls
            subprocess.run([sys.executable, "-m", "compileall", "-q", str(tree / "src")], check=True)
            _run(tree, SOLVE, warm_caches[name])
        jobs = {
            case: (lambda name, flags=flags: _first_solve(trees[name], flags)) for case, flags in FIRST_SOLVES.items()
        }
        jobs["warmup"] = lambda name: _warmup(trees[name])
        for case, args in CALLS.items():
            jobs[case] = lambda name, args=args: _call(trees[name], args, warm_caches[name])
        jobs = {case: job for case, job in jobs.items() if not a.cases or case in a.cases}
        turns = {case: {name: [] for name in trees} for case in jobs}
        for repeat in range(a.repeats):
            order = list(trees) if repeat % 2 == 0 else list(trees)[::-1]
            for case, job in jobs.items():
                for name in order:
                    turns[case][name].append(job(name))
                    print(f"{case} [{name}]: {turns[case][name][-1]['wall']:.2f} s", file=sys.stderr, flush=True)
    finally:
        for cache in warm_caches.values():
            shutil.rmtree(cache, ignore_errors=True)
    result = {
        "benchmark": "cold_start",
        "command": "PYTHONPATH=src python -m benchmarks.cold_start " + " ".join(argv or sys.argv[1:]),
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "repeats": a.repeats,
        "trees": {name: _commit(tree) for name, tree in trees.items()},
        "solve_command": "deik solve chain:20 --reach tip 12 8 0",
        "cpu_model": cpu_model(),
        "cpu_count": os.cpu_count(),
        "load_average_before": load_before,
        "load_average_after": list(os.getloadavg()),
        "seconds": time.perf_counter() - began,
        "cases": {case: {name: _summary(runs) for name, runs in rows.items()} for case, rows in turns.items()},
    }
    text = markdown(result)
    write_atomic(a.out / "cold_start.json", lambda tmp: Path(tmp).write_text(json.dumps(result, indent=2) + "\n"))
    write_atomic(a.out / "cold_start.md", lambda tmp: Path(tmp).write_text(text))
    save_figure(figure(result), str(a.out / "cold_start.png"))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

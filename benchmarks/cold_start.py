"""What a user waits for: the first solve after an install, `deik warmup` and every later call,
each in a fresh process.

    python -m benchmarks.cold_start [--repeats 2] [--cases "import deik" ...] [--python PATH] [--out DIR]

Every case runs `python` in a fresh process against the deik this benchmark imports (its folder
first on PYTHONPATH, bytecode compiled first as in an installed package) and is timed from
outside: wall seconds and the child's CPU seconds (user + system), which other processes on a
shared machine inflate less than the wall. Cases (median of --repeats):
- first solve, float32 or float64, with the LM polish or without (`--polish 0 --generations
  20`): `deik solve chain:20 --reach tip 12 8 0` on an empty NUMBA_CACHE_DIR, as after an
  install, then twice more on the cache it filled: "compile" is the first run's wall minus the
  median of those, and deik's own record of each kernel's compile seconds is kept, with the
  seconds its compile note said the wait would take ("note_s");
- warmup: `deik warmup` on an empty cache (its note's seconds kept too); warm solve: the same
  solve on a filled cache;
- `import deik`, `deik --version`, and `python -c pass`, the interpreter's own start, for scale.
--python runs every case with another interpreter, e.g. a virtual environment holding only what
`pip install deik` brings (the development one also holds the test and GPU extras, whose
numba-cuda hooks every Python start and whose PyYAML and SciPy Numba imports when present).
Writes cold_start.{json,md,png}. Before and after: `python -m benchmarks.compare cold_start COMMIT
-- --repeats 2` (about 40 minutes on 2 shared cores, mostly compiling).
"""

from __future__ import annotations

import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import deik
from benchmarks import harness

SOURCE = Path(deik.__file__).resolve().parents[1]  # the folder holding the deik under test
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


INTERPRETER = [sys.executable]  # the `python` every case runs (--python)


def python(args: list[str], cache: Path) -> dict:
    """Wall and CPU seconds and the standard error of `python ARGS` in a fresh process with
    NUMBA_CACHE_DIR=cache; the CPU seconds include its compile workers'."""
    env = {key: value for key, value in os.environ.items() if key != "PYTHONDONTWRITEBYTECODE"}
    env.update(PYTHONPATH=str(SOURCE), NUMBA_CACHE_DIR=str(cache))
    before, began = os.times(), time.perf_counter()
    done = subprocess.run([*INTERPRETER, *args], cwd=ROOT, env=env, capture_output=True, text=True)
    wall, after = time.perf_counter() - began, os.times()
    if done.returncode != 0:
        raise RuntimeError(f"python {' '.join(args)} failed: {done.stderr[-2000:]}")
    cpu = after.children_user - before.children_user + after.children_system - before.children_system
    return {"wall": wall, "cpu": cpu, "stderr": done.stderr}


def kernel_records(cache: Path) -> list[dict]:
    """Each kernel's compile seconds as deik records them beside the cache (none before it did)."""
    return [json.loads(path.read_text()) for path in cache.rglob("deik-compile-seconds.json")]


def first_solve(flags: list[str]) -> dict:
    """A cold solve on an empty cache, then two warm ones on what it compiled."""
    with tempfile.TemporaryDirectory(prefix="deik-cold-") as cache:
        cold = python(SOLVE + flags, Path(cache))
        warm = statistics.median(python(SOLVE + flags, Path(cache))["wall"] for _ in range(2))
        kernels = kernel_records(Path(cache))
    return {
        "wall": cold["wall"],
        "cpu": cold["cpu"],
        "warm_wall": warm,
        "compile_wall": cold["wall"] - warm,
        "kernels": kernels,
        "note_s": _note_seconds(cold["stderr"]),
    }


def _note_seconds(stderr: str) -> float | None:
    """The seconds deik's compile note said the wait would take (None: no note)."""
    note = re.search(r"about (\d+) s", stderr)
    return float(note[1]) if note else None


def _timed(run: dict) -> dict:
    """A run of python() without its standard error: what the results keep."""
    return {"wall": run["wall"], "cpu": run["cpu"]}


def warmup() -> dict:
    with tempfile.TemporaryDirectory(prefix="deik-cold-") as cache:
        run = python(["-m", "deik", "warmup"], Path(cache))  # no bar: stderr is no terminal
        return _timed(run) | {"kernels": kernel_records(Path(cache)), "note_s": _note_seconds(run["stderr"])}


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--repeats", type=int, default=2, help="fresh processes per case, median kept")
    p.add_argument("--cases", nargs="+", metavar="CASE", help="only these cases (default: all)")
    p.add_argument("--python", type=Path, help="the interpreter the cases run in (default: this one)")
    run = harness.start("cold_start", p, argv)
    args = run.args
    INTERPRETER[:] = [str(args.python or sys.executable)]
    subprocess.run([*INTERPRETER, "-m", "compileall", "-q", str(SOURCE / "deik")], check=True)
    with tempfile.TemporaryDirectory(prefix="deik-warm-") as warm_cache:
        python(SOLVE, Path(warm_cache))  # a filled cache for the warm calls
        jobs = {case: (lambda flags=flags: first_solve(flags)) for case, flags in FIRST_SOLVES.items()}
        jobs["warmup"] = warmup
        jobs |= {case: (lambda a=a: _timed(python(a, Path(warm_cache)))) for case, a in CALLS.items()}
        cases = {}
        for case, job in jobs.items():
            if not args.cases or case in args.cases:
                runs = [job() for _ in range(args.repeats)]
                cases[case] = {k: statistics.median(r[k] for r in runs) for k in ("wall", "cpu")} | {"runs": runs}
                print(f"{case}: {cases[case]['wall']:.2f} s", file=sys.stderr, flush=True)
    fig, axes = harness.figure(height=0.5 * len(cases) + 1.5)
    harness.bars(axes[0, 0], list(cases), [c["wall"] for c in cases.values()], horizontal=True)
    harness.style_axes(
        axes[0, 0], "seconds, wall (median of fresh processes)", "", "deik's cold start and every call", ylog=False
    )
    cells = [[case, f"{c['wall']:.2f}", f"{c['cpu']:.2f}", ""] for case, c in cases.items()]
    for cell, c in zip(cells, cases.values()):
        if "compile_wall" in c["runs"][0]:
            cell[3] = f"{statistics.median(r['compile_wall'] for r in c['runs']):.1f}"
    figures = {f"{case}, wall s": c["wall"] for case, c in cases.items()} | {
        f"{case}, CPU s": c["cpu"] for case, c in cases.items()
    }
    body = harness.md_table(["case", "wall s", "CPU s", "compile s (wall)"], cells)
    packages = subprocess.run(
        [*INTERPRETER, "-m", "pip", "list", "--format=freeze"], capture_output=True, text=True
    ).stdout.split()
    record = {"solve": " ".join(SOLVE[2:]), "python": INTERPRETER[0], "packages": packages, "cases": cases}
    return run.finish(record, body, fig, figures)


if __name__ == "__main__":
    main()

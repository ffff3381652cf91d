"""What a user waits for: the first solve after an install, `deik warmup` and every later call,
each in a fresh process; with --profile, where the first solve's compile time goes.

    python -m benchmarks.cold_start [--repeats 2] [--cases "import deik" ...] [--out DIR]
    python -m benchmarks.cold_start --profile [--repeats 1] [--out DIR]

Every case runs `python` in a fresh process against the deik this benchmark imports (its folder
first on PYTHONPATH, bytecode compiled first as in an installed package) and is timed from
outside: wall seconds and the child's CPU seconds (user + system), which other processes on a
shared machine inflate less than the wall. Cases (median of --repeats):
- first solve, float32 or float64, with the LM polish or without (`--polish 0 --generations
  20`): `deik solve chain:20 --reach tip 12 8 0` on an empty NUMBA_CACHE_DIR, as after an
  install, then twice more on the cache it filled: "compile" is the first run's wall minus the
  median of those, and deik's own record of each kernel's compile seconds is kept;
- warmup: `deik warmup --quiet` on an empty cache; warm solve: the same solve on a filled cache;
- `import deik`, `deik --version`, and `python -c pass`, the interpreter's own start, for scale.
--profile runs the float32 first solve in a worker that wraps Numba's compiler passes and LLVM
steps in CPU-time counters keeping self time (a compile nested in another's typing is counted
once): CPU seconds in Numba's front end (bytecode to typed IR, parfors, lowering to LLVM IR), in
LLVM's function passes, module optimisation (-O3) and machine code generation, and in cache
writes; the libraries optimised and code-generated; the overloads compiled (and how many for
literal arguments). Writes cold_start.{json,md,png}, or compile_profile.{json,md}. Before and
after: `python -m benchmarks.compare cold_start COMMIT -- --repeats 2` (about 40 minutes on 2
shared cores, mostly compiling).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter
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
LLVM_STEPS = {
    "_optimize_functions": "LLVM function passes",
    "_optimize_final_module": "LLVM module optimisation (-O3)",
    "_finalize_specific": "machine code generation",
}


def python(args: list[str], cache: Path, path: str = str(SOURCE)) -> dict:
    """Wall and CPU seconds of `python ARGS` in a fresh process with NUMBA_CACHE_DIR=cache."""
    env = {key: value for key, value in os.environ.items() if key != "PYTHONDONTWRITEBYTECODE"}
    env.update(PYTHONPATH=path, NUMBA_CACHE_DIR=str(cache))
    before, began = os.times(), time.perf_counter()
    done = subprocess.run([sys.executable, *args], cwd=ROOT, env=env, capture_output=True, text=True)
    wall, after = time.perf_counter() - began, os.times()
    if done.returncode != 0:
        raise RuntimeError(f"python {' '.join(args)} failed: {done.stderr[-2000:]}")
    cpu = after.children_user - before.children_user + after.children_system - before.children_system
    return {"wall": wall, "cpu": cpu, "stdout": done.stdout}


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
    }


def warmup() -> dict:
    with tempfile.TemporaryDirectory(prefix="deik-cold-") as cache:
        run = python(["-m", "deik", "warmup", "--quiet"], Path(cache))
        return {"wall": run["wall"], "cpu": run["cpu"], "kernels": kernel_records(Path(cache))}


def profile_worker() -> None:
    """Profile one cold CLI solve in this process (module docstring, --profile); print one JSON line."""
    from numba.core import caching, codegen
    from numba.core import compiler_machinery as machinery
    from numba.core.dispatcher import Dispatcher

    seconds, calls, stack = Counter(), Counter(), []

    def timed(key, function):
        def run(*args, **kwargs):
            began = time.process_time()
            stack.append(0.0)
            try:
                return function(*args, **kwargs)
            finally:
                spent, nested = time.process_time() - began, stack.pop()
                seconds[key] += spent - nested
                calls[key] += 1
                if stack:
                    stack[-1] += spent

        return run

    run_pass = machinery.PassManager._runPass
    machinery.PassManager._runPass = lambda self, i, p, state: timed(f"pass {p.name()}", run_pass)(self, i, p, state)
    for name, key in LLVM_STEPS.items():
        owner = codegen.JITCodeLibrary if name == "_finalize_specific" else codegen.CPUCodeLibrary
        setattr(owner, name, timed(key, getattr(owner, name)))
    caching.Cache.save_overload = timed("cache writes", caching.Cache.save_overload)
    from deik.cli import main

    began = time.process_time()
    with contextlib.redirect_stdout(io.StringIO()):
        main(SOLVE[2:])
    total = time.process_time() - began
    dispatchers = {
        id(v): v
        for name, m in list(sys.modules.items())
        if name.startswith("deik.")
        for v in vars(m).values()
        if isinstance(v, Dispatcher)
    }
    overloads = [sig for d in dispatchers.values() for sig in d.overloads]
    front = sum(v for k, v in seconds.items() if k.startswith("pass "))
    record = {"CPU seconds of the first solve": total, "Numba front end (typing, lowering, parfors)": front}
    record |= {key: seconds[key] for key in (*LLVM_STEPS.values(), "cache writes")}
    record |= {
        "libraries optimised": calls[LLVM_STEPS["_optimize_final_module"]],
        "libraries code-generated": calls[LLVM_STEPS["_finalize_specific"]],
        "overloads compiled": len(overloads),
        "of them for literal arguments": sum("Literal" in str(sig) for sig in overloads),
    }
    print(json.dumps(record))


def main(argv=None) -> dict:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv == ["--worker"]:
        return profile_worker()
    p = harness.parser(__doc__)
    p.add_argument("--repeats", type=int, help="fresh processes per case, median kept (default 2; 1 with --profile)")
    p.add_argument("--cases", nargs="+", metavar="CASE", help="only these cases (default: all)")
    p.add_argument("--profile", action="store_true", help="where the first solve's compile goes (see above)")
    run = harness.start("cold_start", p, argv, {"repeats": 1 if "--profile" in argv else 2})
    if run.args.profile:
        run.name = "compile_profile"
    args = run.args
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(SOURCE / "deik")], check=True)
    if args.profile:
        profiles = []
        for _ in range(args.repeats):
            with tempfile.TemporaryDirectory(prefix="deik-profile-") as cache:
                done = python(["-m", "benchmarks.cold_start", "--worker"], Path(cache), f"{SOURCE}{os.pathsep}{ROOT}")
            profiles.append({**json.loads(done["stdout"].splitlines()[-1]), "wall seconds": done["wall"]})
        figures = {k: statistics.median(p[k] for p in profiles) for k in profiles[0]}
        body = harness.md_table(
            ["first float32 solve, median of runs", "value"], [[k, f"{v:.4g}"] for k, v in figures.items()]
        )
        return run.finish({"solve": " ".join(SOLVE[2:]), "runs": profiles}, body, figures=figures)

    with tempfile.TemporaryDirectory(prefix="deik-warm-") as warm_cache:
        python(SOLVE, Path(warm_cache))  # a filled cache for the warm calls
        jobs = {case: (lambda flags=flags: first_solve(flags)) for case, flags in FIRST_SOLVES.items()}
        jobs["warmup"] = warmup
        jobs |= {case: (lambda a=a: python(a, Path(warm_cache))) for case, a in CALLS.items()}
        cases = {}
        for case, job in jobs.items():
            if not args.cases or case in args.cases:
                runs = [{k: v for k, v in job().items() if k != "stdout"} for _ in range(args.repeats)]
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
    return run.finish({"solve": " ".join(SOLVE[2:]), "cases": cases}, body, fig, figures)


if __name__ == "__main__":
    main()

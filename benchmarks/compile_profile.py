"""Where a cold compile's time goes: a first solve in a fresh process with an empty kernel
cache, for two checkouts of deik taking turns, its compile timed phase by phase.

    PYTHONPATH=src python -m benchmarks.compile_profile --before ../before-cold [--repeats 1] [--out DIR]

A worker (this module with --worker; the checkout's src/ first on the path; NUMBA_CACHE_DIR an
empty folder) wraps Numba's compiler passes and its LLVM steps in CPU-time counters that keep
self time (a compile nested in another's type inference is not counted twice), then runs
`deik solve chain:20 --reach tip 12 8 0` (float32, polish on: the first thing a user runs)
through the CLI and reports: CPU seconds in total, in Numba's front end (bytecode to typed IR,
lowering to LLVM IR, parfors), in LLVM function passes, module optimisation (-O3) and machine
code generation, and in cache writes; how many libraries were optimised and code-generated;
how many overloads were compiled (and how many for literal arguments); the slowest passes.
Writes compile_profile.json and compile_profile.md into --out (default
benchmarks/results/cold_start).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMAND = ["solve", "chain:20", "--reach", "tip", "12", "8", "0"]
LLVM_STEPS = {
    "_optimize_functions": "LLVM function passes",
    "_optimize_final_module": "LLVM module optimisation (-O3)",
    "_finalize_specific": "machine code generation",
}


def _worker() -> int:
    """Profile one cold CLI solve in this process; print one JSON line."""
    from numba.core import caching, codegen
    from numba.core import compiler_machinery as machinery

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
    machinery.PassManager._runPass = lambda self, index, p, state: timed(f"pass {p.name()}", run_pass)(
        self, index, p, state
    )
    for name, key in LLVM_STEPS.items():
        owner = codegen.JITCodeLibrary if name == "_finalize_specific" else codegen.CPUCodeLibrary
        setattr(owner, name, timed(key, getattr(owner, name)))
    caching.Cache.save_overload = timed("cache writes", caching.Cache.save_overload)

    from deik.cli.app import main

    began = time.process_time()
    with contextlib.redirect_stdout(io.StringIO()):
        status = main(COMMAND)
    total = time.process_time() - began
    from numba.core.dispatcher import Dispatcher

    overloads = literal = 0
    for name in ("deik.backends.cpu_kernels", "deik.backends._device_cpu"):
        for value in vars(sys.modules[name]).values():
            if isinstance(value, Dispatcher):
                overloads += len(value.overloads)
                literal += sum("Literal" in str(signature) for signature in value.overloads)
    passes = {k[5:]: v for k, v in seconds.items() if k.startswith("pass ")}
    llvm = {key: seconds[key] for key in LLVM_STEPS.values()}
    print(
        json.dumps(
            {
                "status": status,
                "cpu_seconds": total,
                "numba_front_end_seconds": sum(passes.values()),
                **{f"{key} seconds": value for key, value in llvm.items()},
                "cache_write_seconds": seconds["cache writes"],
                "libraries_optimised": calls["LLVM module optimisation (-O3)"],
                "libraries_code_generated": calls["machine code generation"],
                "overloads_compiled": overloads,
                "overloads_for_literal_arguments": literal,
                "slowest_passes": dict(sorted(passes.items(), key=lambda kv: -kv[1])[:8]),
            }
        )
    )
    return 0


def _profile(tree: Path) -> dict:
    """One worker run on checkout `tree` with an empty cache."""
    with tempfile.TemporaryDirectory(prefix="deik-profile-") as cache:
        env = {key: value for key, value in os.environ.items() if key != "PYTHONDONTWRITEBYTECODE"}
        env.update(PYTHONPATH=os.pathsep.join((str(tree / "src"), str(ROOT))), NUMBA_CACHE_DIR=cache)
        command = [sys.executable, "-m", "benchmarks.compile_profile", "--worker"]
        began = time.perf_counter()
        done = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - began
    if done.returncode != 0:
        raise RuntimeError(f"{tree}: {done.stderr[-2000:]}")
    return {**json.loads(done.stdout.strip().splitlines()[-1]), "wall_seconds": wall}


def markdown(result: dict) -> str:
    rows = [
        ("CPU seconds of the first solve", "cpu_seconds", ".1f"),
        ("Numba front end (typing, lowering, parfors)", "numba_front_end_seconds", ".1f"),
        *((key, f"{key} seconds", ".1f") for key in LLVM_STEPS.values()),
        ("cache writes", "cache_write_seconds", ".1f"),
        ("libraries optimised", "libraries_optimised", "d"),
        ("libraries code-generated", "libraries_code_generated", "d"),
        ("overloads compiled", "overloads_compiled", "d"),
        ("of them for literal arguments", "overloads_for_literal_arguments", "d"),
        ("wall seconds (shared machine)", "wall_seconds", ".1f"),
    ]
    names = list(result["trees"])
    lines = [
        f"`deik solve {' '.join(COMMAND[1:])}` in a fresh process with an empty cache, before "
        f"({result['trees']['before']}) and after ({result['trees']['after']}); CPU {result['cpu_model']}; "
        f"first of {result['repeats']} run(s) each.",
        "",
        "| | " + " | ".join(names) + " |",
        "|---|" + "---:|" * len(names),
    ]
    for label, key, form in rows:
        lines.append(f"| {label} | " + " | ".join(format(result["runs"][n][0][key], form) for n in names) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--before", type=Path, help="a checkout of the earlier deik")
    p.add_argument("--repeats", type=int, default=1)
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "cold_start")
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.worker:
        return _worker()
    if a.before is None or not (a.before / "src" / "deik").is_dir():
        p.error("--before DIR: give a checkout of deik (git worktree add DIR COMMIT)")
    from benchmarks.before_after import _commit
    from benchmarks.serial_vs_parallel import write_atomic
    from deik.experiments.timing import cpu_model

    trees = {"before": a.before.resolve(), "after": ROOT}
    runs = {name: [] for name in trees}
    for repeat in range(a.repeats):
        for name in list(trees) if repeat % 2 == 0 else list(trees)[::-1]:
            runs[name].append(_profile(trees[name]))
            print(f"{name}: {runs[name][-1]['cpu_seconds']:.1f} s CPU", file=sys.stderr, flush=True)
    result = {
        "benchmark": "compile_profile",
        "command": "PYTHONPATH=src python -m benchmarks.compile_profile " + " ".join(argv or sys.argv[1:]),
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "repeats": a.repeats,
        "trees": {name: _commit(tree) for name, tree in trees.items()},
        "cpu_model": cpu_model(),
        "load_average_after": list(os.getloadavg()),
        "runs": runs,
    }
    text = markdown(result)
    write_atomic(a.out / "compile_profile.json", lambda tmp: Path(tmp).write_text(json.dumps(result, indent=2) + "\n"))
    write_atomic(a.out / "compile_profile.md", lambda tmp: Path(tmp).write_text(text))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

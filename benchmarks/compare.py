"""Before and after: one benchmark run on two commits of deik, taking turns, its figures side by side.

    python -m benchmarks.compare BENCHMARK BEFORE [AFTER] [--rounds 3] [--out DIR] [-- ARGS...]

BEFORE and AFTER are git revisions (a commit, a branch, HEAD~3); AFTER defaults to this working
tree as it is. Each revision is checked out into a temporary worktree, and in every round the
benchmark module of this checkout (`benchmarks/BENCHMARK.py`, with ARGS) runs once against each
deik, each in a fresh process with that tree's `src/` first on the path, the order swapped every
round so that drifting load on a shared machine hits both alike. A revision's first round also
compiles its kernels (into its worktree's cache); the benchmarks keep compilation out of their
timings. The benchmark's `figures` (label -> number) of every round are set side by side:
median and range per side and the ratio of the medians, after / before. Writes
BENCHMARK_BEFORE_AFTER.json (every round's record) and .md into --out (default
benchmarks/results/compare), named by the commits measured.

--after-env KEY=VALUE ... runs the after side with those environment variables: the same commit
twice compares two settings of one deik. `NUMBA_CPU_NAME=znver3 NUMBA_CPU_FEATURES=no-avx512`
compiles the after side's kernels for a CPU without AVX-512 (`no-avx512`: this CPU's LLVM
features with every AVX-512 one off), each side on its own kernel cache:

    python -m benchmarks.compare robots HEAD HEAD --after-env NUMBA_CPU_NAME=znver3 \
        NUMBA_CPU_FEATURES=no-avx512 -- --targets 300 --chunks 5 --cases panda --peers rtb
A benchmark runs against an older deik only where that deik has what it uses (the public API
always; `deik.cleanup` since e1c08f6).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.harness import RESULTS, cpu_info, md_table
from deik.io.atomic import write_json_atomically, write_text_atomically

ROOT = Path(__file__).resolve().parents[1]


def worktree(revision: str, folder: Path) -> Path:
    """`revision` checked out (detached) into `folder`, a worktree of this repository."""
    done = subprocess.run(
        ["git", "-C", str(ROOT), "worktree", "add", "--detach", str(folder), revision], capture_output=True, text=True
    )
    if done.returncode != 0:
        raise SystemExit(f"cannot check out {revision!r}: {done.stderr.strip().splitlines()[-1]}")
    return folder


def features_without_avx512() -> str:
    """This CPU's LLVM feature string ("+sse4.2,+avx2,...") with every AVX-512 feature off."""
    import llvmlite.binding as llvm

    llvm.initialize_native_target()
    features = llvm.get_host_cpu_features()
    return ",".join(("-" if name.startswith("avx512") else "+" if on else "-") + name for name, on in features.items())


def environment(pairs: list[str], cache: Path) -> dict[str, str]:
    """The KEY=VALUE `pairs` of --after-env (NUMBA_CPU_FEATURES=no-avx512 expanded), with a
    kernel cache of their own when any is given."""
    env = dict(pair.partition("=")[::2] for pair in pairs)
    if env.get("NUMBA_CPU_FEATURES") == "no-avx512":
        env["NUMBA_CPU_FEATURES"] = features_without_avx512()
    return env | {"NUMBA_CACHE_DIR": str(cache)} if env else {}


def run_once(tree: Path, benchmark: str, args: list[str], out: Path, extra: dict) -> dict:
    """The record of one run of benchmarks.BENCHMARK with ARGS against the deik of `tree`, with
    the environment variables `extra`."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join((str(tree / "src"), str(ROOT))), **extra}
    command = [sys.executable, "-m", f"benchmarks.{benchmark}", *args, "--out", str(out)]
    done = subprocess.run(command, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{benchmark} against {tree} failed (exit {done.returncode}): {done.stderr.strip()[-1500:]}")
    (record,) = [json.loads(path.read_text()) for path in out.glob("*.json")]
    return record


def side_by_side(runs: dict[str, list[dict]]) -> list[dict]:
    """Per figure of the first record: each side's values over the rounds, median and range,
    and after / before of the medians."""
    rows = []
    for label in runs["before"][0]["figures"]:
        row = {"figure": label}
        for side, records in runs.items():
            values = [r["figures"].get(label) for r in records if r["figures"].get(label) is not None]
            row[side] = {"values": values, "median": statistics.median(values) if values else None}
        before, after = row["before"]["median"], row["after"]["median"]
        row["ratio"] = after / before if before and after is not None else None
        rows.append(row)
    return rows


def markdown(result: dict) -> str:
    def cell(side: dict) -> str:
        v = side["values"]
        return "-" if not v else f"{side['median']:.4g}" + (f" ({min(v):.4g}-{max(v):.4g})" if len(v) > 1 else "")

    trees = result["trees"]
    lines = [
        f"# {result['benchmark']}: {trees['before']} (before) against {trees['after']} (after"
        + "".join(f", {key}={value}" for key, value in result["after_env"].items())
        + ")",
        "",
        f"`{result['command']}`; {result['rounds']} rounds, the two taking turns, the order swapped every round; "
        f"{result['cpu_model']}; load average {result['load_average_before'][0]:.2f} before, "
        f"{result['load_average_after'][0]:.2f} after; {result['seconds']:.0f} s. Median (range) over the rounds.",
        "",
    ]
    header = ["figure", "before", "after", "after / before"]
    cells = [
        [r["figure"], cell(r["before"]), cell(r["after"]), "-" if r["ratio"] is None else f"{r['ratio']:.3g}"]
        for r in result["figures"]
    ]
    return "\n".join(lines) + "\n" + md_table(header, cells)


def main(argv=None) -> dict:
    argv = list(sys.argv[1:] if argv is None else argv)
    own, passed = (argv[: argv.index("--")], argv[argv.index("--") + 1 :]) if "--" in argv else (argv, [])
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("benchmark", help="a module of benchmarks/, e.g. throughput")
    p.add_argument("before", help="the earlier git revision")
    p.add_argument("after", nargs="?", help="the later revision (default: this working tree as it is)")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--out", type=Path, default=RESULTS / "compare", help="results folder")
    p.add_argument("--after-env", nargs="+", default=[], metavar="KEY=VALUE", help="the after side's environment")
    a = p.parse_args(own)
    if any("=" not in pair for pair in a.after_env):
        p.error("--after-env takes KEY=VALUE pairs")
    if not (ROOT / "benchmarks" / f"{a.benchmark}.py").is_file():
        p.error(f"no benchmark benchmarks/{a.benchmark}.py")
    began, load_before = time.perf_counter(), list(os.getloadavg())
    with tempfile.TemporaryDirectory(prefix="deik-compare-") as scratch:
        scratch = Path(scratch)
        trees = {"before": worktree(a.before, scratch / "before")}
        trees["after"] = worktree(a.after, scratch / "after") if a.after else ROOT
        runs: dict[str, list[dict]] = {"before": [], "after": []}
        envs = {"before": {}, "after": environment(a.after_env, scratch / "after-cache")}
        try:
            for r in range(a.rounds):
                for side in ("before", "after") if r % 2 == 0 else ("after", "before"):
                    out = scratch / "out" / side / str(r)
                    runs[side].append(run_once(trees[side], a.benchmark, passed, out, envs[side]))
                    print(f"round {r + 1}/{a.rounds}: {side} done", file=sys.stderr, flush=True)
        finally:
            for tree in trees.values():
                if tree != ROOT:
                    subprocess.run(
                        ["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)], capture_output=True
                    )
    result = {
        "benchmark": a.benchmark,
        "command": "python -m benchmarks.compare " + shlex.join(argv),
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "rounds": a.rounds,
        "after_env": dict(pair.partition("=")[::2] for pair in a.after_env),
        "trees": {side: records[0]["commit"] for side, records in runs.items()},
        "cpu_model": cpu_info()[0],
        "load_average_before": load_before,
        "load_average_after": list(os.getloadavg()),
        "seconds": time.perf_counter() - began,
        "figures": side_by_side(runs),
        "runs": runs,
    }
    text = markdown(result)
    values = [re.sub(r"\W", "", value) for value in result["after_env"].values()]
    name = "_".join((runs["before"][0]["benchmark"], *result["trees"].values(), *values))
    a.out.mkdir(parents=True, exist_ok=True)
    write_json_atomically(a.out / f"{name}.json", result, missing_as_null=True)
    write_text_atomically(a.out / f"{name}.md", text)
    print(text)
    return result


if __name__ == "__main__":
    main()

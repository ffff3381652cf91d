"""Single solves with the kernels compiled for this CPU and for one without AVX-512, taking turns.

    python -m benchmarks.simd_targets [--targets 300] [--rounds 3] [--cases panda]
                                      [--peers rtb] [--without-avx512 znver3] [--out benchmarks/results]

Numba compiles the kernels for the CPU it runs on; a figure measured on a CPU with AVX-512 is
not what a CPU without it gets. In each round benchmarks.robots (the TRAC-IK protocol, the peers
taking turns with deik in the same run) runs once as compiled for this CPU and once as compiled
for `--without-avx512` (NUMBA_CPU_NAME, and NUMBA_CPU_FEATURES = this CPU's features with every
AVX-512 one turned off), each in a fresh process on its own kernel cache, the order swapped every
round. Per case and target: the medians over the rounds of deik's reused Solver and plain
deik.solve (median, p95, mean ms, strict success) and of each peer's median and p95 in the same
runs, and the ratios to the peer, which the machine's load moves less than the times.
Writes simd_targets.{json,md}.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks import harness

ROOT = Path(__file__).resolve().parents[1]


def features_without_avx512() -> str:
    """This CPU's LLVM feature string ("+sse4.2,+avx2,...") with every AVX-512 feature off."""
    import llvmlite.binding as llvm

    llvm.initialize_native_target()
    features = llvm.get_host_cpu_features()
    return ",".join(("-" if name.startswith("avx512") else "+" if on else "-") + name for name, on in features.items())


def targets(without: str) -> dict[str, dict]:
    """{label: environment overrides} of the two Numba targets."""
    import llvmlite.binding as llvm

    llvm.initialize_native_target()
    host = llvm.get_host_cpu_name()
    return {
        f"this CPU ({host})": {},
        f"{without}, no AVX-512": {"NUMBA_CPU_NAME": without, "NUMBA_CPU_FEATURES": features_without_avx512()},
    }


def run_robots(env: dict, args, cache: Path) -> dict:
    """One benchmarks.robots run in a fresh process with `env`; its cases' solver rows."""
    with tempfile.TemporaryDirectory(prefix="deik-simd-") as out:
        command = [sys.executable, "-m", "benchmarks.robots", "--targets", str(args.targets), "--chunks", "5"]
        command += ["--cases", *args.cases, "--peers", args.peers, "--out", out]
        environment = {**os.environ, "NUMBA_CACHE_DIR": str(cache), **env}
        done = subprocess.run(command, cwd=ROOT, env=environment, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"benchmarks.robots failed: {done.stderr[-2000:]}")
        return json.loads((Path(out) / "robots.json").read_text())["cases"]


def rows(case: dict) -> dict[str, dict]:
    """{row name: its figures} of one case of a robots run: deik's reused Solver, deik.solve, peers."""
    out = {}
    for name, row in case["solvers"].items():
        if "skipped" in row:
            continue
        keys = ("median_ms", "p95_ms", "mean_ms", "success_strict")
        if name == "deik":
            out["deik reused Solver"] = {k: row["solver"][k] for k in keys}
            out["deik.solve"] = {k: row[k] for k in keys}
        else:
            out[name] = {k: row.get(k) for k in keys}
    return out


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--targets", type=int, default=300, help="targets per case and run")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--cases", nargs="+", default=["panda"])
    p.add_argument("--peers", default="rtb", help="peers of benchmarks.robots in the same runs")
    p.add_argument("--without-avx512", default="znver3", help="LLVM CPU name of the target without AVX-512")
    run = harness.start("simd_targets", p, argv)
    args = run.args
    envs = targets(args.without_avx512)
    runs = {label: [] for label in envs}
    with tempfile.TemporaryDirectory(prefix="deik-simd-cache-") as cache:
        for r in range(args.rounds):
            order = list(envs) if r % 2 == 0 else list(reversed(envs))
            for label in order:
                cases = run_robots(envs[label], args, Path(cache))
                runs[label].append({case: rows(data) for case, data in cases.items()})
                print(f"round {r + 1}/{args.rounds}: {label} done", file=sys.stderr, flush=True)
    summary, cells, figures = {}, [], {}
    for label, rounds in runs.items():
        for case in args.cases:
            names = rounds[0][case]
            med = {n: {k: statistics.median(rd[case][n][k] for rd in rounds) for k in names[n]} for n in names}
            summary.setdefault(label, {})[case] = med
            peer = next((n for n in med if not n.startswith("deik")), None)
            for name, m in med.items():
                ratio = f"{m['median_ms'] / med[peer]['median_ms']:.2f}" if peer and name != peer else ""
                cells.append([label, case, name, f"{m['median_ms']:.3f}", f"{m['p95_ms']:.3f}"])
                cells[-1] += [f"{m['mean_ms']:.3f}", f"{m['success_strict']:.1%}", ratio]
                figures[f"{label} {case} {name} median ms"] = m["median_ms"]
    header = ["Numba target", "case", "solver", "median ms", "p95 ms", "mean ms", "strict", "median / peer's"]
    body = harness.md_table(header, cells, f"medians over {args.rounds} rounds, the targets taking turns")
    record = {"targets": envs, "summary": summary, "runs": runs}
    return run.finish(record, body, None, figures)


if __name__ == "__main__":
    main()

"""DE throughput of two checkouts taking turns: joint evaluations per second before and after.

    PYTHONPATH=src python -m benchmarks.throughput_before_after --before ../before [--rounds 5]
        [--seconds 0.4] [--cases chain100 chain100x64 chain20 humanoid] [--dtypes float32 float64]

--before is a checkout of an earlier commit (`git archive COMMIT | tar -x -C ../before`). Each
checkout runs in its own long-lived worker process (this module with --worker, its src/ first
on the path) that builds the engines, compiles or loads its kernels and calibrates a generation
count per configuration (about --seconds a run) before any timing. Then, round by round, every
configuration runs once in each worker, the two taking turns in an order swapped every round,
so load drift on the shared machine hits both alike. Configurations: case x dtype x threads
(all Numba threads and 1). Cases, DE evaluation only (harness.evaluation_settings: no polish,
no restarts, no stopping), targets the FK of random in-limit poses:
- chain100: deik.chain(100), one Position goal on its tip, 1 problem, population 500;
- chain100x64: the same, a batch of 64 problems: enough work per generation (3.2 million joint
  evaluations) that a parallel region waiting for a descheduled thread costs little;
- chain20: deik.chain(20), the same goal, a batch of 8 problems, population 500;
- humanoid: deik.humanoid(), Position goals on both hands and both heels, 8 problems, 500.
Rate = problems x population x joints x generations / seconds of one Engine.run: wall clock,
best of the rounds (and median), and with one thread also the calling thread's CPU time (median
of the rounds), which a loaded machine inflates far less. Writes throughput_before_after.{json,png,md} into --out.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import harness
from deik.experiments.shared import save_figure
from deik.io.atomic import write_json_atomically, write_text_atomically

ROOT = Path(__file__).resolve().parents[1]
# (links, or None for the humanoid; problems)
CASES = {"chain100": (100, 1), "chain100x64": (100, 64), "chain20": (20, 8), "humanoid": (None, 8)}
POPULATION = 500
HANDS_AND_FEET = ("left_hand", "right_hand", "left_heel", "right_heel")


def case_problem(case: str, seed: int):
    """The case's deik.Problem and its joint count (kernel joints)."""
    import deik

    links, problems = CASES[case]
    if links is not None:
        return harness.chain_problem(links, problems, seed), links
    h = deik.humanoid()
    poses = np.random.default_rng((seed, problems)).uniform(h.lower, h.upper, (problems, h.n_dofs))
    kin = deik.forward_kinematics(h, poses)
    return deik.Problem(h, [deik.Position(name, kin.position(name)) for name in HANDS_AND_FEET]), len(h.joint_names)


def _worker(seconds: float, seed: int) -> int:
    """Serve requests, one JSON line each: {"case", "dtype", "threads"} with "generations" (a
    timed run: answers {"seconds", "cpu_seconds"}, the wall clock and the calling thread's CPU
    time, which with one thread is the run's own, whatever else the machine runs) or without
    (warm up and calibrate: answers {"generations", "work"}, work = evaluations of joints per
    generation)."""
    import deik

    engines: dict = {}
    for line in sys.stdin:
        ask = json.loads(line)
        key = (ask["case"], ask["dtype"])
        if key not in engines:
            problem, joints = case_problem(ask["case"], seed)
            engine = deik.Engine(problem, harness.evaluation_settings(POPULATION, "cpu", ask["dtype"], seed))
            engines[key] = (engine, engine.run(engine.init(), 2), problem.batch_size * POPULATION * joints)
        engine, state, work = engines[key]
        with harness.threads(ask["threads"]):
            if "generations" in ask:
                cpu = time.thread_time()
                seconds = harness.timed_run(engine, state, ask["generations"])
                answer = {"seconds": seconds, "cpu_seconds": time.thread_time() - cpu}
            else:
                timed = harness.time_engine(engine, seconds, 1)
                answer = {"generations": timed["generations"], "work": work}
        print(json.dumps(answer), flush=True)
    return 0


def _start(tree: Path, seconds: float, seed: int) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join((str(tree / "src"), str(ROOT)))}
    module = "benchmarks.throughput_before_after"
    command = [sys.executable, "-m", module, "--worker", "--seconds", str(seconds), "--seed", str(seed)]
    return subprocess.Popen(command, cwd=ROOT, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)


def _ask(worker: subprocess.Popen, request: dict) -> dict:
    worker.stdin.write(json.dumps(request) + "\n")
    worker.stdin.flush()
    return json.loads(worker.stdout.readline())


def _label(tree: Path) -> str:
    done = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    return done.stdout.strip() if done.returncode == 0 else str(tree)


def measure(args, trees: dict) -> list[dict]:
    """Every configuration's rows: per tree its generations, every round's seconds and rates."""
    workers = {name: _start(tree, args.seconds, args.seed) for name, tree in trees.items()}
    threads = harness.thread_counts("cpu")
    configs = [{"case": c, "dtype": d, "threads": t} for c in args.cases for d in args.dtypes for t in threads]
    rows = []
    try:
        for config in configs:  # compile or load, warm up, calibrate: untimed
            row = {**config}
            for name, worker in workers.items():
                row[name] = {**_ask(worker, config), "seconds": [], "cpu_seconds": []}
            rows.append(row)
            print(f"ready: {config}", file=sys.stderr, flush=True)
        for r in range(args.rounds):
            for row in rows:
                config = {k: row[k] for k in ("case", "dtype", "threads")}
                for name in list(workers)[:: 1 if r % 2 == 0 else -1]:
                    answer = _ask(workers[name], {**config, "generations": row[name]["generations"]})
                    row[name]["seconds"].append(answer["seconds"])
                    row[name]["cpu_seconds"].append(answer["cpu_seconds"])
            print(f"round {r + 1}/{args.rounds} done", file=sys.stderr, flush=True)
    finally:
        for worker in workers.values():
            worker.stdin.close()
            worker.wait()
    for row in rows:
        for name in workers:
            side = row[name]
            rates = [side["work"] * side["generations"] / s for s in side["seconds"]]
            side.update(rates=rates, best=max(rates), median=float(np.median(rates)))
            if row["threads"] == 1:  # CPU time is the run's own only on the calling thread
                side["cpu_rate"] = side["work"] * side["generations"] / float(np.median(side["cpu_seconds"]))
        row["speedup_best"] = row["after"]["best"] / row["before"]["best"]
        row["speedup_median"] = row["after"]["median"] / row["before"]["median"]
        if row["threads"] == 1:
            row["speedup_cpu"] = row["after"]["cpu_rate"] / row["before"]["cpu_rate"]
    return rows


def markdown(result: dict) -> str:
    trees, env = result["trees"], result["environment"]
    lines = [
        f"DE joint evaluations per second, before ({trees['before']}) and after ({trees['after']}) taking "
        f"turns, {result['rounds']} rounds, population {POPULATION}; {env['cpu_model']}, shared and noisy.",
        "",
        "Wall clock: best and median of the rounds. CPU time (1 thread only): the median run's rate in the calling",
        "thread's own CPU time, what the run costs whatever else the machine runs.",
        "",
        "| case | dtype | threads | before (best) | after (best) | after / before (best) | (median) "
        "| before (CPU time) | after (CPU time) | after / before (CPU time) |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in result["rows"]:
        cpu = (
            f"{r['before']['cpu_rate']:.3g} | {r['after']['cpu_rate']:.3g} | {r['speedup_cpu']:.2f}x"
            if r["threads"] == 1
            else "| |"
        )
        lines.append(
            f"| {r['case']} | {r['dtype']} | {r['threads']} | {r['before']['best']:.3g} | {r['after']['best']:.3g} "
            f"| {r['speedup_best']:.2f}x | {r['speedup_median']:.2f}x | {cpu} |"
        )
    return "\n".join(lines) + "\n"


def plot(rows: list[dict]):
    """Before and after per configuration: one thread's CPU-time rate (left), the wall clock's best
    round with 1 and all threads (right)."""
    fig, axes = harness.figure(2)
    one = [r for r in rows if r["threads"] == 1]
    panels = (
        (axes[0, 0], one, "cpu_rate", "one thread, CPU time (median round)", lambda r: f"{r['case']} {r['dtype'][5:]}"),
        (
            axes[0, 1],
            rows,
            "best",
            "wall clock (best round)",
            lambda r: f"{r['case']} {r['dtype'][5:]} {r['threads']}t",
        ),
    )
    for ax, subset, key, title, label in panels:
        x = np.arange(len(subset))
        for k, name in enumerate(("before", "after")):
            ax.bar(x + (k - 0.5) * 0.4, [r[name][key] for r in subset], 0.4, label=name, color=f"C{k}")
        ax.axhline(1.5e8, color="k", linestyle="--", linewidth=1, label="1.5e8/s")
        ax.set_xticks(x, [label(r) for r in subset], fontsize=6, rotation=60, ha="right")
        ax.set_yscale("log")
        ax.set_ylabel("joint evaluations per second")
        ax.set_title(f"DE throughput before and after: {title}", fontsize=9)
        ax.grid(True, which="both", axis="y", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    p = harness.parser(__doc__)
    p.add_argument("--before", type=Path, help="a checkout of the earlier deik")
    p.add_argument("--before-label", help="what --before is (default: its git commit, else its path)")
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--seconds", type=float, default=0.4, help="target seconds of one timed run")
    p.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    p.add_argument("--dtypes", nargs="+", default=["float32", "float64"], choices=["float32", "float64"])
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        return _worker(args.seconds, args.seed)
    if args.before is None or not (args.before / "src" / "deik").is_dir():
        p.error("--before DIR: give a checkout of deik (git archive COMMIT | tar -x -C DIR)")
    if args.quick:
        args.rounds, args.seconds = 1, 0.05
    opening = harness.start(args)
    trees = {"before": args.before.resolve(), "after": ROOT}
    rows = measure(args, trees)
    result = {
        "trees": {"before": args.before_label or _label(trees["before"]), "after": _label(ROOT)},
        "rounds": args.rounds,
        "population": POPULATION,
        "cases": {c: {"links_or_humanoid": CASES[c][0], "problems": CASES[c][1]} for c in args.cases},
        "rows": rows,
        "targets": [
            harness.target(
                "chain100 (population 500, 1 or 64 problems) float32 joint evaluations per second, 2 threads (after)",
                1.5e8,
                max(
                    (
                        r["after"]["best"]
                        for r in rows
                        if r["case"].startswith("chain100") and r["dtype"] == "float32" and r["threads"] > 1
                    ),
                    default=0,
                ),
                "/s",
                not args.quick,
            ),
            harness.target(
                "chain100 float32 after / before, same run, 1 thread, CPU time",
                4.0,
                max(
                    (
                        r["speedup_cpu"]
                        for r in rows
                        if r["case"] == "chain100" and r["dtype"] == "float32" and r["threads"] == 1
                    ),
                    default=0.0,
                ),
                "x",
                not args.quick,
            ),
        ],
    }
    result = {
        "benchmark": "throughput_before_after",
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "command": "PYTHONPATH=src python -m benchmarks.throughput_before_after " + " ".join(argv or sys.argv[1:]),
        **result,
        "environment": harness.machine("cpu", opening),
        "seconds": time.perf_counter() - opening["t0"],
    }
    args.out.mkdir(parents=True, exist_ok=True)
    text = markdown(result)
    write_json_atomically(args.out / "throughput_before_after.json", result, missing_as_null=True)
    write_text_atomically(args.out / "throughput_before_after.md", text)
    save_figure(plot(rows), str(args.out / "throughput_before_after.png"))
    print(text)
    for t in result["targets"]:
        print(f"Target: {t['what']} {t['comparison']} {t['goal']:.3g}{t['unit']}: reached {t['reached']:.3g}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Run the benchmarks of issue 5 item 4 in sequence and summarise their targets (`make bench`).

    PYTHONPATH=src python -m benchmarks.run_all [--device cpu|gpu] [--quick] [--out DIR]

a. serial_vs_parallel (CPU), b. throughput, c. headline, d. batch, f. memory, all in one process
(kernels compiled once), each writing its JSON and PNG into --out. A benchmark that
fails is reported and the others still run (exit status 1). Writes run_all.json and run_all.md
(every target with the figure reached, the device and the command, and each stage's seconds).
The GPU's own check, issue 25's targets table with the CPU beside it, is
benchmarks/gpu_check.py (docs/gpu.md).
"""

from __future__ import annotations

import argparse
import json
import time
import traceback
from pathlib import Path

from benchmarks import batch, headline, memory, serial_vs_parallel, throughput
from benchmarks.serial_vs_parallel import RESULTS
from deik.experiments.shared import markdown_table
from deik.experiments.timing import machine_line
from deik.io.atomic import write_json_atomically, write_text_atomically

STAGES = (
    ("a", "serial_vs_parallel", serial_vs_parallel),
    ("b", "throughput", throughput),
    ("c", "headline", headline),
    ("d", "batch", batch),
    ("f", "memory", memory),
)
SPEEDUP_GOAL = 100.0  # issue 5 item 4a: >= 100x at 100 links, population 500


def stage_argv(name: str, args) -> list[str]:
    """Command-line arguments of one benchmark (serial_vs_parallel is CPU only)."""
    argv = ["--out", str(args.out)] + (["--quick"] if args.quick else [])
    return argv if name == "serial_vs_parallel" else argv + ["--device", args.device]


def targets_of(name: str, result: dict) -> list[dict]:
    """A benchmark's targets; serial_vs_parallel's is rebuilt from its 100-link row."""
    if name != "serial_vs_parallel":
        return result["targets"]
    rows = [r for r in result["rows"] if r["links"] == 100]
    if not rows:
        return [
            {
                "what": "serial vs parallel CPU speed-up, 100 links",
                "goal": SPEEDUP_GOAL,
                "reached": None,
                "unit": "x",
                "comparison": ">=",
                "met": None,
            }
        ]
    population = result["settings"]["population"]
    return [
        {
            "what": f"serial vs parallel CPU speed-up, 100 links, population {population}",
            "goal": SPEEDUP_GOAL,
            "reached": rows[0]["speedup"],
            "unit": "x",
            "comparison": ">=",
            "met": bool(rows[0]["speedup"] >= SPEEDUP_GOAL) if population == 500 else None,
        }
    ]


def summary(stages: list[dict], args, seconds: float) -> str:
    """The markdown summary: one row per target, then the stages' wall times."""
    rows = []
    for s in stages:
        for t in s.get("targets", []):
            reached = "-" if t["reached"] is None else f"{t['reached']:.3g}"
            verdict = "n/a here" if t["met"] is None else ("met" if t["met"] else "NOT met")
            rows.append(
                [
                    f"{s['item']}. {s['name']}",
                    t["what"],
                    f"{t['comparison']} {t['goal']:.3g} {t['unit']}",
                    reached,
                    verdict,
                ]
            )
    quick = " --quick" if args.quick else ""
    lines = [
        f"# Benchmarks ({args.device}{', quick sizes' if args.quick else ''})",
        "",
        machine_line(),
        "",
        markdown_table(["benchmark", "target", "goal", "reached", "verdict"], rows),
        "",
        markdown_table(
            ["benchmark", "seconds", "status"],
            [[f"{s['item']}. {s['name']}", f"{s['seconds']:.1f}", s["status"]] for s in stages],
        ),
        "",
        f"Total {seconds:.0f} s. Command:",
        "",
        "```sh",
        f"PYTHONPATH=src python -m benchmarks.run_all --device {args.device}{quick} --out {args.out}",
        "```",
        "",
    ]
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--device", default="cpu", choices=("cpu", "gpu"))
    p.add_argument("--quick", action="store_true", help="every benchmark at its smoke-test sizes")
    p.add_argument("--out", type=Path, default=RESULTS, help="results folder (default benchmarks/results)")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    stages = []
    for item, name, module in STAGES:
        print(f"\n=== {item}. {name} ===", flush=True)
        start = time.perf_counter()
        stage = {"item": item, "name": name}
        try:
            module.main(stage_argv(name, args))
            result = json.loads((args.out / f"{name}.json").read_text())
            stage.update(status="ok", targets=targets_of(name, result))
        except (Exception, SystemExit) as error:  # one failing benchmark must not stop the others
            traceback.print_exc()
            stage.update(status=f"failed: {type(error).__name__}: {error}")
        stage["seconds"] = time.perf_counter() - start
        stages.append(stage)
    seconds = time.perf_counter() - t0
    text = summary(stages, args, seconds)
    write_json_atomically(
        args.out / "run_all.json",
        {"device": args.device, "quick": args.quick, "seconds": seconds, "machine": machine_line(), "stages": stages},
        missing_as_null=True,
    )
    write_text_atomically(args.out / "run_all.md", text)
    print("\n" + text)
    return 0 if all(s["status"] == "ok" for s in stages) else 1


if __name__ == "__main__":
    raise SystemExit(main())

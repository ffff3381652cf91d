"""The benchmarks of issue 5 item 4 in one go, with their targets summarised (`make bench`).

    python -m benchmarks.run_all [--device cpu|gpu] [--quick] [--out DIR]

serial_vs_parallel (items a and c), throughput (b), batch (d) and memory (f), in one process
(kernels compiled once), each writing its results into --out. A benchmark that fails is reported and the others
still run (exit status 1). Writes run_all.json and run_all.md: every target with the figure
reached and its verdict, and each stage's seconds. On a GPU machine the same stages run with
--device gpu; the GPU's own check, issue 25's targets table with the CPU beside it, the kernels'
resources included, is benchmarks/gpu_check.py (docs/gpu.md).
"""

from __future__ import annotations

import time
import traceback

from benchmarks import batch, harness, memory, serial_vs_parallel, throughput

STAGES = {"a, c": serial_vs_parallel, "b": throughput, "d": batch, "f": memory}


def main(argv=None) -> int:
    p = harness.parser(__doc__)
    run = harness.start("run_all", p, argv)
    args = run.args
    flags = ["--out", str(args.out), "--device", args.device] + (["--quick"] if args.quick else [])
    stages, rows = [], []
    for item, module in STAGES.items():
        name = module.__name__.split(".")[-1]
        print(f"\n=== {item}. {name} ===", flush=True)
        began = time.perf_counter()
        try:
            record, status = module.main(flags), "ok"
        except (Exception, SystemExit) as error:  # one failing benchmark must not stop the others
            traceback.print_exc()
            record, status = {"targets": []}, f"failed: {type(error).__name__}: {error}"
        seconds = time.perf_counter() - began
        stages.append({"item": item, "name": name, "status": status, "seconds": seconds, "targets": record["targets"]})
        for t in record["targets"]:
            verdict = "n/a here" if t["met"] is None else ("met" if t["met"] else "NOT met")
            reached = "-" if t["reached"] is None else f"{t['reached']:.3g}"
            rows.append(
                [f"{item}. {name}", t["what"], f"{t['comparison']} {t['goal']:.3g} {t['unit']}", reached, verdict]
            )
    body = harness.md_table(["benchmark", "target", "goal", "reached", "verdict"], rows) + "\n"
    body += harness.md_table(
        ["benchmark", "seconds", "status"], [[s["name"], f"{s['seconds']:.1f}", s["status"]] for s in stages]
    )
    figures = {f"{s['name']}: {t['what']}": t["reached"] for s in stages for t in s["targets"]}
    run.finish({"stages": stages}, body, figures=figures)
    return 0 if all(s["status"] == "ok" for s in stages) else 1


if __name__ == "__main__":
    raise SystemExit(main())

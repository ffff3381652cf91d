"""Libraries of clips: throughput of `deik clip DIR` on 1 and 2 local workers and on Ray, and the
retargeting quality of every shared clip onto human.urdf and deik.humanoid().

    python -m benchmarks.library [--rounds 2] [--part both|throughput|quality]

Throughput: the folder of shared clips (the shared data's humanoid/, every *.bvh; the segment tables
beside them are skipped) fixed as `deik clip DIR --out OUTDIR` fixes it (contacts detected and
planted, the floor kept) and retargeted onto deik.humanoid(), into a fresh folder each time,
through deik.library exactly as the commands run it. Three ways take turns in each round, in a
rotated order: 1 local worker of 2 Numba threads, 2 local workers of 1 thread, and Ray with 2
CPUs (the Ray instance is started once before the rounds and its start-up timed apart; local
workers are spawned by every run, Ray's are reused). Clips per second and frames per second of
wall time, the clips' own seconds summed, and each round's ratios to 1 worker.

Quality: `deik retarget DIR --map examples/maps/... --to TARGET --out OUTDIR` for both targets,
2 local workers; per clip the report's summary (retargeting/measures.py): key-point error mean and
worst (mm), contact sliding max (mm/frame), joint-limit violations (count, must be 0),
penetration max (mm, deepest joint or site below the floor), self-penetration max (mm, deepest
overlap of two of the target's bone capsules), the key points' speed and acceleration peaks
over their targets' (clips.dynamics) and time per frame (ms, one core).

`--part throughput` or `--part quality` measures one part and keeps the other as the JSON in
--out holds it (the quality part took 70 s on the 2-core machine; the throughput part runs
both jobs 7 times over), each part with its own command, commit and machine.
"""

from __future__ import annotations

import json
import statistics
import tempfile
import time
from pathlib import Path

from benchmarks import harness
from benchmarks.data import shared_data
from deik.cli.app import build_parser
from deik.cli.folder_command import do_clip, library_jobs
from deik.library.run import run_library

ROOT = Path(__file__).resolve().parents[1]
CLIPS = shared_data("humanoid")
TARGETS = {
    "human.urdf": (str(shared_data("robots", "human.urdf")), str(ROOT / "examples/maps/shared_bvh_to_human_urdf.toml")),
    "deik.humanoid()": ("humanoid", str(ROOT / "examples/maps/shared_bvh_to_humanoid.toml")),
}
JOBS = ("deik clip", "deik retarget onto deik.humanoid()")
WAYS = {
    "1 local worker x 2 threads": ("local", 1),
    "2 local workers x 1 thread": ("local", 2),
    "Ray, 2 CPUs": ("ray", None),
}
QUALITY = (
    ("keypoint_error_mean_mm", "key points mean mm"),
    ("keypoint_worst_max_mm", "key points worst mm"),
    ("contact_sliding_max_mm_per_frame", "sliding max mm/frame"),
    ("limit_violations_count", "limit violations"),
    ("penetration_max_mm", "penetration max mm"),
    ("self_penetration_max_mm", "self-penetration max mm"),
    ("keypoint_velocity_peak_ratio", "speed peak / targets'"),
    ("keypoint_acceleration_peak_ratio", "acceleration peak / targets'"),
    ("time_per_frame_ms", "ms/frame"),
)


def _jobs(argv: list[str]):
    """The library jobs of a `deik ...` command line over a folder."""
    args = build_parser().parse_args(argv)
    return library_jobs(args)[0]


def _library(argv: list[str], executor: str, workers) -> dict:
    """One run of the library command `argv` (into its fresh --out): wall s, clips, frames, and
    the clips' own seconds summed (in the workers, without their start)."""
    run = run_library(_jobs(argv), do_clip, executor=executor, workers=workers, quiet=True)
    failed = [f"{o.job.name}: {o.reason}" for o in run.outcomes if o.status != "done"]
    if failed:
        raise RuntimeError(f"clips not done: {failed}")
    work = sum(o.seconds for o in run.outcomes)
    return {"seconds": run.wall_time, "clips": len(run.outcomes), "frames": run.frames_done(), "clip_seconds": work}


def _job(name: str, out: str) -> list[str]:
    """The command line of job `name` (JOBS) into `out`."""
    if name == "deik clip":
        return ["clip", str(CLIPS), "--out", out, "--quiet"]
    target, mapping = TARGETS["deik.humanoid()"]
    return ["retarget", str(CLIPS), "--map", mapping, "--to", target, "--out", out, "--quiet"]


def _summary(runs: dict) -> dict:
    """Per way: medians over the rounds and each round's speed-up over the first way."""
    first = next(iter(runs.values()))
    return {
        way: {
            "clips_per_s_median": statistics.median(m["clips"] / m["seconds"] for m in measured),
            "frames_per_s_median": statistics.median(m["frames"] / m["seconds"] for m in measured),
            "clip_seconds_summed_median": statistics.median(m["clip_seconds"] for m in measured),
            "speedup_vs_1_worker_per_round": [first[k]["seconds"] / m["seconds"] for k, m in enumerate(measured)],
        }
        for way, measured in runs.items()
    }


def throughput(rounds: int) -> dict:
    """Per job (JOBS): each way's runs (rotated turns per round), medians and ratios to 1 worker."""
    import ray

    began = time.perf_counter()
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    ray_start = time.perf_counter() - began
    jobs = {}
    names = list(WAYS)
    with tempfile.TemporaryDirectory() as scratch:
        for job in JOBS:
            _library(_job(job, f"{scratch}/warm-{len(jobs)}"), "local", 2)  # kernels compiled and cached
            runs = {way: [] for way in WAYS}
            for r in range(rounds):
                for way in names[r % len(names) :] + names[: r % len(names)]:
                    executor, workers = WAYS[way]
                    out = f"{scratch}/{len(jobs)}-{r}-{executor}-{workers}"
                    runs[way].append(_library(_job(job, out), executor, workers))
                    print(f"{job}, round {r}: {way}: {runs[way][-1]['seconds']:.2f} s", flush=True)
            jobs[job] = {"runs": runs, "summary": _summary(runs)}
    ray.shutdown()
    return {"ray_start_s": ray_start, "jobs": jobs}


def quality() -> dict:
    """{target: [row per clip]} of the retarget report summaries."""
    tables = {}
    with tempfile.TemporaryDirectory() as scratch:
        for name, (target, mapping) in TARGETS.items():
            argv = ["retarget", str(CLIPS), "--map", mapping, "--to", target, "--out", f"{scratch}/{len(tables)}"]
            run = run_library(_jobs(argv + ["--quiet"]), do_clip, workers=2, quiet=True)
            rows = []
            for outcome in run.outcomes:
                record = outcome.record or {}
                row = {"clip": outcome.job.name, "status": outcome.status, "reason": outcome.reason}
                row["frames"] = record.get("frames")
                row.update({key: (record.get("metrics") or {}).get(key) for key, _ in QUALITY})
                rows.append(row)
            tables[name] = rows
            print(f"{name}: {sum(r['status'] == 'done' for r in rows)}/{len(rows)} clips retargeted", flush=True)
    return tables


def _shown(value) -> str:
    return "-" if value is None else f"{value:.4g}"


def _measured_by(result: dict, part: str) -> list[str]:
    """The lines saying how `part` was measured: its command and machine."""
    run = result["runs"][part]
    cpu = run["cpu_model"] if "cpu_model" in run else run["machine"]["cpu_model"]  # records before 4dfb2c5
    return [f"`{run['command']}` at {run['commit']}, {cpu}", ""]


def markdown(result: dict) -> str:
    lines = []
    if "throughput" in result:
        t = result["throughput"]
        lines += _measured_by(result, "throughput")
        header = ["way", "clips/s (median)", "frames/s (median)", "clips' own s (median)", "speed-up vs 1 worker"]
        for job, measured in t["jobs"].items():
            lines += [f"## Throughput of `{job}` over the shared clips (8 clips, 741 frames)", ""]
            rows = [
                [way, f"{s['clips_per_s_median']:.3g}", f"{s['frames_per_s_median']:.4g}"]
                + [f"{s['clip_seconds_summed_median']:.3g}"]
                + [", ".join(f"{v:.2f}" for v in s["speedup_vs_1_worker_per_round"])]
                for way, s in measured["summary"].items()
            ]
            lines += [harness.md_table(header, rows)]
        lines += [f"Ray's start-up (once, not in the turns): {t['ray_start_s']:.1f} s", ""]
    for k, (target, rows) in enumerate(result.get("quality", {}).items()):
        lines += [f"## Retargeting every shared clip onto {target}", ""]
        lines += _measured_by(result, "quality") if k == 0 else []
        header = ["clip", "frames", "status", *(label for _, label in QUALITY)]
        cells = [[r["clip"], r["frames"], r["status"], *(_shown(r[key]) for key, _ in QUALITY)] for r in rows]
        lines += [harness.md_table(header, cells)]
    return "\n".join(lines) + "\n"


def figure(result: dict):
    """Frames per second of each way (throughput) and each clip's key-point error (quality)."""
    fig, axes = harness.figure(("throughput" in result) + bool(result.get("quality")), width=6, height=4.2)
    axes = list(axes[0])
    if "throughput" in result:
        ax = axes.pop(0)
        jobs = result["throughput"]["jobs"]
        width = 0.8 / len(jobs)
        for k, (job, measured) in enumerate(jobs.items()):
            summary = measured["summary"]
            x = [i + (k - (len(jobs) - 1) / 2) * width for i in range(len(summary))]
            ax.bar(x, [s["frames_per_s_median"] for s in summary.values()], width, label=job)
        ax.set_xticks(range(len(WAYS)), [w.replace(" x ", "\nx ") for w in WAYS], fontsize=8)
        ax.set_ylabel("frames per second (median)")
        ax.set_title("a folder of the shared clips")
        ax.legend(fontsize=8)
    if result.get("quality"):
        ax = axes.pop(0)
        width = 0.4
        for k, (target, rows) in enumerate(result["quality"].items()):
            values = [r["keypoint_error_mean_mm"] or 0 for r in rows]
            ax.bar([i + (k - 0.5) * width for i in range(len(rows))], values, width, label=target)
        names = [r["clip"].removeprefix("humanoid3d_").removesuffix(".bvh") for r in rows]
        ax.set_xticks(range(len(names)), names, rotation=30, fontsize=8)
        ax.set_ylabel("key-point error, mean (mm)")
        ax.set_title("retargeting every shared clip")
        ax.legend(fontsize=8)
    return fig


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--rounds", type=int, default=2, help="turns of each way in the throughput part")
    p.add_argument("--part", choices=("both", "throughput", "quality"), default="both")
    run = harness.start("library", p, argv)
    args = run.args
    parts = ("throughput", "quality") if args.part == "both" else (args.part,)
    stored = args.out / "library.json"
    result = {}
    if args.part != "both" and stored.exists():  # the part not measured now stays as measured before
        result = {k: v for k, v in json.loads(stored.read_text()).items() if k in ("throughput", "quality", "runs")}
    result.setdefault("runs", {})
    for part in parts:
        result[part] = throughput(args.rounds) if part == "throughput" else quality()
        command = f"python -m benchmarks.library --part {part}" + (f" --rounds {args.rounds}" * (part == "throughput"))
        result["runs"][part] = {"command": command, "commit": harness.deik_commit(), "cpu_model": harness.cpu_info()[0]}
    figures = {
        f"{job}, {way}, frames/s": s["frames_per_s_median"]
        for job, m in result.get("throughput", {}).get("jobs", {}).items()
        for way, s in m["summary"].items()
    }
    figures |= {
        f"onto {target}, {r['clip']}, {key}": r[key]
        for target, rows in result.get("quality", {}).items()
        for r in rows
        for key in ("keypoint_error_mean_mm", "contact_sliding_max_mm_per_frame")
    }
    return run.finish(result, markdown(result), figure(result), figures)


if __name__ == "__main__":
    main()

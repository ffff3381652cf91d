"""`deik clip IN --out OUT` with no other flags, on clips nobody tuned it for, judged independently.

    PYTHONPATH=src python -m benchmarks.clip_targets [--clips walk run ...] [--out benchmarks/results]
        [--folder DIR] [--transforms limbs fast ...]

Cases (judging/cases.py): every shared humanoid clip as it is, on another rig family
(centimetres, a root above the hips, six channels on every joint, other joint names, 30 fps) and
with one more transform each (joints named J00.. at 120 fps, backwards, twice the speed, limbs
scaled, noise and the body 12 mm under the floor); with --folder, the humanoid3d_*.bvh clips of
another folder on the same rig (the DeepMimic family: pybullet_data's motions converted), and
with --transforms, each clip as it is and with each transform named (judging/cases.py,
TRANSFORMS) instead. Each is cleaned by the default command in
this process (deik.cli.app.main) and measured by judging/clips.py, which shares no code
with deik: its own BVH reader and kinematics, the DeepMimic collision shapes as the body, its
own contact detector, the floor at height 0.

Targets per case (TARGETS), "the capture" without the errors a transform added to its data
(the judge's notes): contact sliding at most 1 mm per frame over every point that rests in the
capture; no part of the body more than 2 mm under the floor; no joint or End Site whose
acceleration peak rises above 1.1 times its own peak in the capture; every frame that misses
one of those listed by deik as unmet; the pelvis travels as far as in the capture (within 5 %
or 2 cm); every resting run of the feet found again (lifting and landing within 0.07 s).
Writes clip_targets.json (every number, the machine) and clip_targets.md (the table, a target
not met marked) through the benchmarks' harness.
"""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.data import need
from benchmarks.harness import md_table, parser, start
from judging.cases import TRANSFORMS, cases, source_cases
from judging.clips import judge
from judging.rigs import format_rig, parse_rig

TARGETS = {"sliding_mm_per_frame": 1.0, "depth_mm": 2.0, "peak_ratio": 1.1, "travel_share": 0.05, "travel_m": 0.02}


def clean(case, folder: Path) -> tuple[dict, object, float, int]:
    """(deik's JSON report, the cleaned rig, seconds, exit status) of `deik clip` on `case`."""
    from deik.cli.app import main

    source, out, report = folder / f"{case.name}.bvh", folder / f"{case.name}_out.bvh", folder / f"{case.name}.json"
    source.write_text(format_rig(case.rig))
    began = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        status = main(["clip", str(source), "--out", str(out), "--json", str(report), "--quiet"])
    seconds = time.perf_counter() - began
    if status != 0 or not out.is_file():
        return {}, None, seconds, status
    return json.loads(report.read_text()), parse_rig(out.read_text(), case.rig.position_mode), seconds, status


def chosen_cases(folder: Path, names: list[str] | None, transforms: list[str] | None) -> list:
    """judging.cases of `folder` (its clips `names`), or with `transforms` each clip as it is and
    with each of those transforms."""
    if not transforms:
        return cases(folder, names)
    return [case for base in source_cases(folder, names) for case in [base] + [TRANSFORMS[t](base) for t in transforms]]


def verdicts(row: dict) -> dict:
    """{target: met} of one case's row."""
    if row["exit_status"] != 0:
        return {"ran": False}
    travel = abs(row["travel_m"] - row["travel_capture_m"])
    return {
        "sliding": row["sliding_mm_per_frame"] <= TARGETS["sliding_mm_per_frame"],
        "depth": row["depth_mm"] <= TARGETS["depth_mm"],
        "peaks": row["peak_ratio"] <= TARGETS["peak_ratio"],
        "listed": row["misses_listed"],
        "travel": travel <= max(TARGETS["travel_share"] * row["travel_capture_m"], TARGETS["travel_m"]),
        "steps": row["steps_matched"] == row["steps"],
    }


def run_case(case, folder: Path) -> dict:
    report, result, seconds, status = clean(case, folder)
    row = {"case": case.name, "description": case.description, "frames": len(case.rig.frames),
           "frame_time_s": case.rig.frame_time, "exit_status": status, "seconds": seconds}  # fmt: skip
    if result is not None:
        unmet = ~np.array(report["met_per_frame"], bool)
        row |= judge(case, case.rig, result, unmet, case.truth)
        row["deik_frames_met"] = report["frames_met"]
        row["deik_floor"] = report.get("floor")
    row["verdicts"] = verdicts(row)
    return row


def _cell(row: dict, key: str, target: str, digits: str = ".3g") -> str:
    if key not in row:
        return "-"
    return f"{row[key]:{digits}}" + ("" if row["verdicts"].get(target, True) else " (missed)")


def table(rows: list[dict]) -> str:
    """The markdown table, one case a row, a target not met marked "(missed)"."""
    header = ["case", "frames", "sliding mm/frame (<= 1; capture)", "under the floor mm (<= 2; capture)",
              "acceleration peak ratio (<= 1.1), point", "pelvis travel m (capture)", "foot runs found",
              "frames met (deik)", "s"]  # fmt: skip
    out = []
    for row in rows:
        if row["exit_status"] != 0:
            out.append([row["case"], row["frames"], f"exit {row['exit_status']}"] + ["-"] * 6)
            continue
        out.append([
            row["case"], row["frames"],
            _cell(row, "sliding_mm_per_frame", "sliding") + f" ({row['sliding_capture_mm_per_frame']:.3g})",
            _cell(row, "depth_mm", "depth") + f" ({row['depth_capture_mm']:.3g})",
            _cell(row, "peak_ratio", "peaks", ".3f") + f" {row['peak_point']}",
            _cell(row, "travel_m", "travel") + f" ({row['travel_capture_m']:.3g})",
            f"{row['steps_matched']}/{row['steps']}" + ("" if row["verdicts"]["steps"] else " (missed)"),
            f"{row['deik_frames_met']}/{row['frames']}" + ("" if row["verdicts"]["listed"] else " (misses unlisted)"),
            f"{row['seconds']:.1f}",
        ])  # fmt: skip
    return md_table(header, out)


def readme_table(rows: list[dict]) -> str:
    """The README's table of `rows` (clip_targets.json's "cases"): per case its sliding, depth
    under the floor, worst point's acceleration ratio and frames deik met, each with "missed"
    where its target is; tests/benchmarks/test_bench_clip.py checks the README holds it."""
    header = ["case", "sliding mm/frame", "under the floor mm", "peak ratio", "frames met", "misses listed"]
    out = []
    for row in rows:
        v = row["verdicts"]
        mark = lambda ok: "" if ok else " (missed)"  # noqa: E731
        out.append([
            row["case"],
            f"{row['sliding_mm_per_frame']:.2f}{mark(v['sliding'])}",
            f"{row['depth_mm']:.1f}{mark(v['depth'])}",
            f"{row['peak_ratio']:.3f}{mark(v['peaks'])}",
            f"{row['deik_frames_met']}/{row['frames']}",
            "yes" if v["listed"] else "no",
        ])  # fmt: skip
    return md_table(header, out)


def main(argv=None) -> dict:
    """Clean and judge every case; write the JSON and markdown; print the table."""
    p = parser(__doc__)
    p.add_argument("--clips", nargs="+", metavar="NAME", help="shared clips by name (walk, run, ...; default all)")
    p.add_argument("--folder", type=Path, help="humanoid3d_*.bvh clips of the shared rig elsewhere")
    p.add_argument("--transforms", nargs="+", choices=sorted(TRANSFORMS), help="each clip as it is and so transformed")
    run = start("clip_targets", p, argv)
    folder = run.args.folder or need("humanoid")
    if not any(folder.glob("humanoid3d_*.bvh")):
        raise SystemExit(f"--folder {folder}: no humanoid3d_*.bvh clips in it")
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for case in chosen_cases(folder, run.args.clips, run.args.transforms):
            row = run_case(case, Path(scratch))
            rows.append(row)
            print(f"{case.name}: {row['verdicts']}", flush=True)
    met = sum(all(row["verdicts"].values()) for row in rows)
    run.target("cases meeting every target", len(rows), met, "cases")
    result = {"goals": TARGETS, "cases": rows, "all_met": met == len(rows)}
    figures = {
        f"{row['case']} {key}": row.get(key)
        for row in rows
        for key in ("sliding_mm_per_frame", "depth_mm", "peak_ratio", "travel_m", "deik_frames_met")
    }
    return run.finish(result, f"{met} of {len(rows)} cases meet every target\n\n" + table(rows), figures=figures)


if __name__ == "__main__":
    main()

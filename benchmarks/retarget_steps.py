"""What each step of a joint-map retarget buys: every shared clip onto deik.humanoid() with the
whole pipeline (retargeting/rig.py) and with one step left out.

    PYTHONPATH=src python -m benchmarks.retarget_steps [--out benchmarks/results]

Ways (each a patch of module names of retargeting/rig.py or settle.py for the run, nothing else changed):
- all steps;
- no outlier repair: ik.repair_outliers returns its poses (frames that settled in another basin
  than their neighbours stay there);
- no smoothed restarts: REBASIN = 0 (each frame keeps the basin its own IK found);
- no space-time pass: settle.py's smooth_motion returns step 3's poses (no contact held, the
  capsules not kept apart; the floor only as the per-frame IK keeps it).
Per clip and way the report's summary (retargeting/measures.py): key-point error mean and worst (mm),
contact sliding max (mm/frame), floor and self-penetration max (mm), the key points' speed and
acceleration peaks over their targets', jolted frames and time per frame (ms). Writes
retarget_steps.json and retarget_steps.md into --out (atomically); prints the table.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
from pathlib import Path
from unittest import mock

from benchmarks.harness import machine
from deik.experiments.shared import markdown_table
from deik.io.atomic import write_json_atomically, write_text_atomically
from deik.retargeting.api import retarget

ROOT = Path(__file__).resolve().parents[1]
CLIPS = ROOT.parent / "shared" / "data" / "humanoid"
MAP = ROOT / "examples" / "maps" / "shared_bvh_to_humanoid.toml"
RIG, SETTLE = "deik.retargeting.rig", "deik.retargeting.settle"  # modules, not deik.retarget (the function)
WAYS = {  # way: {module: {name: patch}}
    "all steps": {},
    "no outlier repair": {RIG: {"repair_outliers": lambda goals, poses: poses}},
    "no smoothed restarts": {RIG: {"REBASIN": 0}},
    "no space-time pass": {SETTLE: {"smooth_motion": lambda goals, first: first}},
}
MEASURES = (
    ("keypoint_error_mean_mm", "key points mean mm"),
    ("keypoint_worst_max_mm", "key points worst mm"),
    ("contact_sliding_max_mm_per_frame", "sliding max mm/frame"),
    ("penetration_max_mm", "penetration max mm"),
    ("self_penetration_max_mm", "self-penetration max mm"),
    ("keypoint_velocity_peak_ratio", "speed peak / targets'"),
    ("keypoint_acceleration_peak_ratio", "acceleration peak / targets'"),
    ("jolted_frames_count", "jolted frames"),
    ("time_per_frame_ms", "ms/frame"),
)


def measure() -> dict:
    """{way: {clip: the report's summary}} over every shared clip."""
    clips = sorted(CLIPS.glob("*.bvh"))
    out = {}
    for way, modules in WAYS.items():
        with contextlib.ExitStack() as stack:
            for module, patches in modules.items():
                stack.enter_context(mock.patch.multiple(importlib.import_module(module), **patches))
            out[way] = {clip.name: retarget(clip, "humanoid", joint_map=MAP).report["summary"] for clip in clips}
        print(f"{way}: {len(clips)} clips", flush=True)
    return out


def markdown(result: dict) -> str:
    lines = ["# What each step of a joint-map retarget buys (benchmarks/retarget_steps.py)", ""]
    lines += [f"`{result['command']}`, {result['machine']['cpu_model']}, every shared clip onto deik.humanoid()", ""]
    header = ["clip", "way", *(label for _, label in MEASURES)]
    rows = []
    for clip in next(iter(result["ways"].values())):
        for way, summaries in result["ways"].items():
            rows.append([clip, way, *(f"{summaries[clip].get(key, float('nan')):.4g}" for key, _ in MEASURES)])
    return "\n".join(lines + [markdown_table(header, rows), ""])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args()
    opening = {"load_before": list(os.getloadavg())}
    result = {"command": "python -m benchmarks.retarget_steps", "ways": measure()}
    result["machine"] = machine("cpu", opening)
    args.out.mkdir(parents=True, exist_ok=True)
    write_json_atomically(args.out / "retarget_steps.json", result, missing_as_null=True)
    text = markdown(result)
    write_text_atomically(args.out / "retarget_steps.md", text)
    print(text)


if __name__ == "__main__":
    main()

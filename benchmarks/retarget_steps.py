"""What each step of a joint-map retarget buys: every shared clip onto deik.humanoid() with the
whole pipeline (retargeting/rig.py) and with one step left out.

    python -m benchmarks.retarget_steps [--out benchmarks/results]

Ways (each a patch of module names of retargeting/rig.py or settle.py for the run, nothing else changed):
- all steps;
- no outlier repair: ik.repair_outliers returns its poses (frames that settled in another basin
  than their neighbours stay there);
- no smoothed restarts: REBASIN = 0 (each frame keeps the basin its own IK found);
- no space-time pass: settle.py's smooth_motion returns step 3's poses (no contact held, the
  capsules not kept apart; the floor only as the per-frame IK keeps it).
Per clip and way the report's summary (retargeting/measures.py): key-point error mean and worst (mm),
contact sliding max (mm/frame), floor and self-penetration max (mm), the key points' speed and
acceleration peaks over their targets', jolted frames and time per frame (ms).
"""

from __future__ import annotations

import contextlib
import importlib
from pathlib import Path
from unittest import mock

from benchmarks import harness
from benchmarks.data import need
from deik.retargeting.api import retarget

ROOT = Path(__file__).resolve().parents[1]
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
    clips = sorted(need("humanoid").glob("*.bvh"))
    out = {}
    for way, modules in WAYS.items():
        with contextlib.ExitStack() as stack:
            for module, patches in modules.items():
                stack.enter_context(mock.patch.multiple(importlib.import_module(module), **patches))
            out[way] = {clip.name: retarget(clip, "humanoid", joint_map=MAP).report["summary"] for clip in clips}
        print(f"{way}: {len(clips)} clips", flush=True)
    return out


def main(argv=None) -> dict:
    run = harness.start("retarget_steps", harness.parser(__doc__), argv)
    ways = measure()
    header = ["clip", "way", *(label for _, label in MEASURES)]
    cells = [
        [clip, way, *(f"{ways[way][clip].get(key, float('nan')):.4g}" for key, _ in MEASURES)]
        for clip in next(iter(ways.values()))
        for way in ways
    ]
    body = "Every shared clip onto deik.humanoid().\n\n" + harness.md_table(header, cells)
    figures = {
        f"{clip}, {way}, {key}": summary.get(key)
        for way, clips in ways.items()
        for clip, summary in clips.items()
        for key in ("keypoint_error_mean_mm", "keypoint_acceleration_peak_ratio")
    }
    return run.finish({"ways": ways}, body, figures=figures)


if __name__ == "__main__":
    main()

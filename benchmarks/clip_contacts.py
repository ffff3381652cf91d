"""Floor and contacts after a whole-body fix of every shared clip: penetration, sliding, floating.

    PYTHONPATH=src python -m benchmarks.clip_contacts [--frames 0] [--out benchmarks/results]

Each shared humanoid clip (../shared/data/humanoid, its first --frames frames; 0: all) is fixed
as `deik clip --contact auto` fixes it: the floor detected (clips/body_contacts.detect_floor),
contacts detected on every joint and end site, every joint and site kept at or above the floor.
Measured after the fix (clips/report.clip_report): the deepest point below the floor over every
frame (mm), the largest slide of a contact point between two contact frames (mm per frame) and
the largest height of a contact point above its resting height in the capture (mm), with the
frames that meet every goal and the wall time. Writes clip_contacts.json atomically.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

from deik.clips.body_contacts import detect_body_contacts, detect_floor
from deik.clips.problem import ClipGoals
from deik.clips.report import clip_report
from deik.clips.solver import fix_clip
from deik.io.atomic import write_json_atomically
from deik.io.bvh import read_bvh

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "humanoid"
KEYS = ("penetration_max_mm", "foot_sliding_max_mm_per_frame", "floating_max_mm")


def measure(path: Path, frames: int) -> dict:
    """The fix of one clip (its first `frames`; 0: all) and its floor measures before and after."""
    clip = read_bvh(path)
    if frames:
        clip = dataclasses.replace(clip, frames=clip.frames[:frames])
    floor = detect_floor(clip)
    contacts = detect_body_contacts(clip, floor=floor)
    began = time.perf_counter()
    fix = fix_clip(clip, ClipGoals(contacts, floor=floor), seed=0)
    seconds = time.perf_counter() - began
    report = clip_report(clip, fix.clip, contacts)
    row = {"clip": path.stem, "frames": clip.n_frames, "floor_m": floor, "contact_points": list(contacts.sites)}
    for key in KEYS:
        row[key] = {"before": report[key]["before"], "after": report[key]["after"]}
    row.update(frames_met=int(fix.met.sum()), seconds=seconds)
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=0)
    parser.add_argument("--out", default="benchmarks/results")
    args = parser.parse_args()
    rows = []
    for path in sorted(DATA.glob("*.bvh")):
        row = measure(path, args.frames)
        rows.append(row)
        shown = ", ".join(f"{k} {row[k]['before']:.3g} -> {row[k]['after']:.3g}" for k in KEYS)
        print(f"{row['clip']} ({row['frames']} frames, {row['seconds']:.1f} s, {row['frames_met']} met): {shown}")
    write_json_atomically(Path(args.out) / "clip_contacts.json", {"frames": args.frames, "clips": rows})


if __name__ == "__main__":
    main()

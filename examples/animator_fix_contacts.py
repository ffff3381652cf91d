"""For animators: plant a captured clip's feet and write the fixed clip, from Python.

    python examples/animator_fix_contacts.py [IN.bvh [OUT.bvh]]

This is what `deik clip IN.bvh --plant-feet auto --out OUT.bvh` does, one step at a time: detect
when each foot touches the floor (from its height and speed), fix every frame so the feet stay
where they land while the rest of the body stays close to the performance, and compare how far
the feet slide before and after. IN defaults to the shared walk beside the clone
(../shared/data, or $DEIK_SHARED_DATA); OUT to walk_planted.bvh.
"""

import os
import sys
from pathlib import Path

import numpy as np

import deik
from deik.cleanup.clip_goals import ClipGoals
from deik.cleanup.contacts import detect_contacts, foot_sites
from deik.cleanup.fix import fix_clip
from deik.cleanup.metrics import foot_sliding

DATA = Path(os.environ.get("DEIK_SHARED_DATA") or Path(__file__).resolve().parents[2] / "shared" / "data")


def sliding_mm(clip, contacts) -> tuple[float, float]:
    """Mean and largest foot slide per frame while planted, in millimetres (the clip is in metres)."""
    steps = foot_sliding(clip, contacts) * 1000.0
    return float(np.nanmean(steps)), float(np.nanmax(steps))


def main(source: str, target: str) -> None:
    clip = deik.read_bvh(source)
    contacts = detect_contacts(clip, foot_sites(clip.skeleton))  # when each foot site is planted
    print(f"{clip.n_frames} frames; contacts found:\n{contacts.describe()}")

    fix = fix_clip(clip, ClipGoals(contacts), seed=0)  # same seed, same clip
    deik.write_bvh(target, fix.clip)  # the same channel layout, Euler angles kept continuous

    before, after = sliding_mm(clip, contacts), sliding_mm(fix.clip, contacts)
    print(f"foot sliding while planted, mean / max: {before[0]:.2f} / {before[1]:.2f} mm per frame before,")
    print(f"{after[0]:.2f} / {after[1]:.2f} mm per frame after; {int(fix.met.sum())}/{clip.n_frames} frames")
    print(f"meet every contact goal; {fix.wall_time:.2f} s; wrote {target}")


if __name__ == "__main__":
    arguments = sys.argv[1:]
    main(
        arguments[0] if arguments else str(DATA / "humanoid" / "humanoid3d_walk.bvh"),
        arguments[1] if len(arguments) > 1 else "walk_planted.bvh",
    )

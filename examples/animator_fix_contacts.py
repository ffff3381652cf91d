"""For animators: plant a captured clip's feet and write the fixed clip, from Python.

    python examples/animator_fix_contacts.py [IN.bvh [OUT.bvh]]

This is what `deik clip IN.bvh --plant-feet auto --out OUT.bvh` does: detect when each foot
touches the floor (from its height and speed), fix every frame so the feet stay where they land
while the rest of the body stays close to the performance, and compare how far the feet slide
before and after. IN defaults to the shared walk beside the clone (../shared/data, or
$DEIK_SHARED_DATA); OUT to walk_planted.bvh.
"""

import os
import sys
from pathlib import Path

import deik

DATA = Path(os.environ.get("DEIK_SHARED_DATA") or Path(__file__).resolve().parents[2] / "shared" / "data")


def main(source: str, target: str) -> None:
    options = deik.CleanOptions(plant_feet="auto", seed=0)  # same seed, same clip
    cleaned = deik.clean_clip(deik.read_bvh(source), options)
    print(f"{cleaned.original.n_frames} frames; contacts found:\n{cleaned.contacts.describe()}")
    deik.write_bvh(target, cleaned.clip)  # the same channel layout, Euler angles kept continuous

    metrics = cleaned.report["metrics"]  # every measure before and after (what `deik clip --json` writes)
    mean, peak = metrics["sliding_mean_mm_per_frame"], metrics["sliding_max_mm_per_frame"]
    print(f"foot sliding while planted, mean / max: {mean['before']:.2f} / {peak['before']:.2f} mm per frame before,")
    met = cleaned.original.n_frames - len(cleaned.unmet_frames)
    print(f"{mean['after']:.2f} / {peak['after']:.2f} mm per frame after; {met}/{cleaned.original.n_frames} frames")
    print(f"meet every contact goal; {cleaned.fix.wall_time:.2f} s; wrote {target}")


if __name__ == "__main__":
    arguments = sys.argv[1:]
    main(
        arguments[0] if arguments else str(DATA / "humanoid" / "humanoid3d_walk.bvh"),
        arguments[1] if len(arguments) > 1 else "walk_planted.bvh",
    )

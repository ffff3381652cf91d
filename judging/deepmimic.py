"""DeepMimic motions as BVH clips of the shared rig, without deik: the other clips of the family
the shared ones come from, for benchmarks/clip_targets.py --folder (clips nobody tuned for).

    python -m judging.deepmimic MOTIONS_DIR OUT_DIR --rig ../shared/data/humanoid/humanoid3d_walk.bvh

MOTIONS_DIR holds DeepMimic's humanoid3d_*.txt (pybullet 3.2.7's pybullet_data/data/motions:
`pip download pybullet==3.2.7 --no-deps`, then unzip); each becomes OUT_DIR/humanoid3d_*.bvh
with the hierarchy of `--rig` (a shared clip: the DeepMimic humanoid at pybullet's 0.25 scale).
A motion frame is its duration, the root's position, then the root's and each joint's rotation
as a quaternion (w, x, y, z), a knee's and an elbow's as one angle about Z (JOINTS, in the
file's order); written as the shared clips are: Z, X, Y intrinsic Euler angles in degrees,
unwrapped over the frames, the frame time the first frame's duration. Five of the eight shared
clips (the crawl, the first dance, the get-up face down, the jump, the kick) are their
motions so converted, byte for byte; the walk, the run and the punch were edited after
(tests/benchmarks/test_bench_clip_targets.py turns a shared clip back into a motion and
through this).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

# after the root: each joint of a DeepMimic frame and how many numbers it takes (4: a quaternion)
JOINTS = (("Chest", 4), ("Neck", 4), ("RightHip", 4), ("RightKnee", 1), ("RightAnkle", 4), ("RightShoulder", 4),
          ("RightElbow", 1), ("LeftHip", 4), ("LeftKnee", 1), ("LeftAnkle", 4), ("LeftShoulder", 4),
          ("LeftElbow", 1))  # fmt: skip
ROOT = 8  # duration, position (3), rotation (4)


def _degrees(quaternions: np.ndarray) -> np.ndarray:
    """(N, 3) Z, X, Y intrinsic Euler angles in degrees, unwrapped over the frames, of (N, 4) w, x, y, z."""
    turns = Rotation.from_quat(np.c_[quaternions[:, 1:], quaternions[:, :1]])
    return np.degrees(np.unwrap(turns.as_euler("ZXY"), axis=0))


def bvh_text(motion: dict, hierarchy: str, order: list[str]) -> str:
    """The BVH file of a DeepMimic `motion` (its JSON: "Frames") with `hierarchy` (the text up to
    MOTION), its joints below the root in file `order`."""
    frames = np.asarray(motion["Frames"], float)
    columns, k = {}, ROOT
    for name, count in JOINTS:
        values = frames[:, k : k + count]
        k += count
        columns[name] = _degrees(values) if count == 4 else np.c_[np.degrees(values[:, 0]), np.zeros((len(values), 2))]
    data = np.hstack([frames[:, 1:4], _degrees(frames[:, 4:8])] + [columns[name] for name in order])
    rows = "\n".join(" ".join(f"{x:.6f}" for x in row) for row in data)
    return f"{hierarchy}MOTION\nFrames: {len(data)}\nFrame Time: {frames[0, 0]:.6f}\n{rows}\n"


def main(argv=None) -> None:
    """Convert every humanoid3d_*.txt of a folder (module notes)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("motions", type=Path, help="folder of DeepMimic humanoid3d_*.txt")
    p.add_argument("out", type=Path, help="folder for the BVH clips (created)")
    p.add_argument("--rig", type=Path, required=True, help="a shared clip whose hierarchy the clips take")
    args = p.parse_args(argv)
    hierarchy = args.rig.read_text().split("MOTION")[0]
    order = [line.split()[1] for line in hierarchy.splitlines() if line.strip().startswith("JOINT")]
    args.out.mkdir(parents=True, exist_ok=True)
    for path in sorted(args.motions.glob("humanoid3d_*.txt")):
        (args.out / f"{path.stem}.bvh").write_text(bvh_text(json.loads(path.read_text()), hierarchy, order))
        print(path.stem)


if __name__ == "__main__":
    main()

"""A joint trajectory of any skeleton (a robot's included) and its CSV and JSON files.

`Trajectory` is a clip without a BVH layout: `frames` (N, D) DOF values in skeleton order,
radians for rotations and length units for translations, `frame_time` seconds. It offers what
a clip fix reads from a Clip (`poses`, `with_frames`, `with_continuous_channels`), so robots
whose joints BVH cannot carry (rest rotations, mimics) go through the same clip machinery.

Files, one row per frame (written atomically):
- CSV: a header `frame,time_s,<DOF name>,...` (URDF joint names for a robot), then the frame
  index, its time in seconds and the DOF values (radians / metres), each in the fewest digits
  that read back as the same float64 (9 digits put a value at a joint limit up to 5e-9 past it).
- JSON: {"dof_names": [...], "dof_units": ["rad" | "m", ...], "frame_time_s": t,
  "frames": [[...], ...]} with the same numbers.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.io.atomic import write_json_atomically, write_text_atomically
from deik.io.euler import continuous_angles, continuous_frames
from deik.io.files import FilePath
from deik.io.motion import Clip, KinematicsOnce
from deik.model.joints import ROTATE
from deik.model.rotations import wrap_rotations
from deik.model.skeleton import Skeleton


@dataclass(frozen=True, eq=False)
class Trajectory(KinematicsOnce):
    """N frames of a skeleton's DOF values: `frames` (N, D) float64 (radians / length units),
    `frame_time` seconds, `source` where it came from."""

    skeleton: Skeleton
    frames: np.ndarray
    frame_time: float
    source: str = ""

    def __post_init__(self):
        frames = self.skeleton.check_angles(np.atleast_2d(self.frames), "frames").copy()
        if frames.ndim != 2:
            raise InputError(f"frames must have shape (N, {self.skeleton.n_dofs}), got {frames.shape}")
        if not (math.isfinite(self.frame_time) and self.frame_time > 0):
            raise InputError(f"frame_time must be a positive number of seconds, got {self.frame_time}")
        frames.setflags(write=False)
        object.__setattr__(self, "frames", frames)
        object.__setattr__(self, "frame_time", float(self.frame_time))

    @property
    def n_frames(self) -> int:
        return self.frames.shape[0]

    def poses(self) -> np.ndarray:
        """Every frame (N, D) with rotations wrapped into [-pi, pi)."""
        return wrap_rotations(self.frames, self.skeleton.dof_kind == ROTATE)

    def with_frames(self, frames: ArrayLike) -> Trajectory:
        """A new trajectory of `frames` (N, D), each nearest (whole turns) the frame it replaces."""
        frames = self.skeleton.check_angles(frames, "frames")
        if frames.shape != self.frames.shape:
            raise InputError(f"frames must have shape {self.frames.shape}, got {frames.shape}")
        return replace(self, frames=continuous_angles(self.skeleton, frames, self.frames))

    def with_continuous_channels(self) -> Trajectory:
        """The same motion with each frame's angles nearest the frame before (deik.io.euler)."""
        return replace(self, frames=continuous_frames(self.skeleton, self.frames))

    def dof_units(self) -> list[str]:
        """ "rad" or "m" (the length unit) per DOF."""
        return ["rad" if kind == ROTATE else "m" for kind in self.skeleton.dof_kind]


def format_trajectory_csv(trajectory: Trajectory) -> str:
    """The CSV text of `trajectory` (see the module notes)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")  # a DOF named with a comma or a quote is quoted
    writer.writerow(["frame", "time_s", *trajectory.skeleton.dof_names])
    for n, values in enumerate(trajectory.frames):
        writer.writerow([n, f"{n * trajectory.frame_time:.9g}", *(repr(float(v)) for v in values)])
    return out.getvalue()


# what the clip machinery reads frames from: a BVH clip or any skeleton's joint trajectory
Motion = Clip | Trajectory


def write_trajectory(path: FilePath, trajectory: Trajectory) -> None:
    """Write `trajectory` to `path` as CSV (`.csv`) or JSON (`.json`), atomically; ValueError
    for another ending."""
    suffix = str(path).lower().rsplit(".", 1)[-1]
    if suffix == "csv":
        write_text_atomically(path, format_trajectory_csv(trajectory))
    elif suffix == "json":
        document = {
            "dof_names": list(trajectory.skeleton.dof_names),
            "dof_units": trajectory.dof_units(),
            "frame_time_s": trajectory.frame_time,
            "frames": trajectory.frames.tolist(),
        }
        write_json_atomically(path, document)
    else:
        raise InputError(f"{path}: a trajectory is written as .csv or .json")

"""`pose_goals`: one 4x4 homogeneous pose as the two goals it sets, a Position and an Orientation."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from deik.model.orientations import pose_rotation
from deik.objectives.goal_values import vector
from deik.objectives.goals import Orientation, Position


def pose_goals(
    frame: str,
    pose: ArrayLike,
    *,
    tolerance: float | None = None,
    angle_tolerance: float | None = None,
    **common: object,
) -> tuple[Position, Orientation]:
    """Place `frame` at the translation of `pose` (4, 4) or (B, 4, 4) (length units) and turn it
    to its rotation part: (Position, Orientation), met within `tolerance` (length units) and
    `angle_tolerance` (radians; defaults as for each goal). `common` (weight, mu, level, active)
    goes to both. Solver.solve swaps them as {"position F": T[..., :3, 3], "orientation F": T}."""
    T = np.asarray(pose, dtype=np.float64)
    vector(T, (4, 4), f"{frame} pose")  # shape and finiteness
    pose_rotation(T, f"pose target for {frame!r}")
    position = Position(frame, T[..., :3, 3], tolerance=tolerance, **common)
    return position, Orientation(frame, T, tolerance=angle_tolerance, **common)

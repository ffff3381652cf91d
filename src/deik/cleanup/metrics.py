"""Numbers animators read about a clip, computed the same way before and after it is fixed.

Lengths come out in the clip's length units (cleanup/summary.py converts them to mm), angles in
degrees. Per-frame values are NaN where a metric does not apply to a frame.

- sliding: how far a site moves along the ground between two consecutive frames that are both
  in its contact (mm per frame); a planted foot should not move. Rising or settling, along up,
  is not sliding (a heel lifting as the foot rolls onto its toes).
- COM outside support: how far the centre of mass, projected on the ground, lies outside the
  convex support polygon of the sites in contact (mm; 0 inside, NaN with no contact).
- joint deviation: per joint with rotation DOFs, the angle of R_original^T R_fixed of its
  rotation relative to its parent (degrees), so two Euler triples of one rotation count as 0.
- joint position deviation: per joint, the distance between its world positions in the
  original and the fixed clip.
- jitter: jerk, the third difference of each joint's world position over dt^3 (length units
  per s^3), row n at frame n + 2 (between the four frames n..n+3 it spans).
- velocity spikes: a pop is a one-frame spike of the second difference. Rotation DOFs are
  differenced as stored (continuous Euler angles): velocity (q[n+1] - q[n]) / dt between
  frames, acceleration (q[n+1] - 2 q[n] + q[n-1]) / dt^2 at frame n. World positions of every
  joint and site are differenced the same way; they do not depend on the Euler
  parameterisation (no false spikes near gimbal lock), so the largest position acceleration is
  the pop detector to trust, the DOF one says which channel popped.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from deik.cleanup.contacts import Contacts
from deik.errors import InputError
from deik.io.trajectory import Motion
from deik.model.geometry import ground_frame, polygon_distance
from deik.model.joints import ROTATE
from deik.model.kinematics import Kinematics
from deik.model.rotations import rotation_angle
from deik.model.skeleton import Skeleton


def _kinematics(clip) -> Kinematics:
    return clip.kinematics


def _site_index(clip, sites) -> list[int]:
    return [clip.skeleton.frame_index(name) for name in sites]


def sliding_steps(kin: Kinematics, index: Sequence[int], mask: np.ndarray, up: np.ndarray | None = None) -> np.ndarray:
    """(N-1, S) displacement of frames `index` (S,) from frame n to n+1 where `mask` (N, S) holds
    in both, along the ground (perpendicular to `up`) or, without `up`, in space; NaN elsewhere;
    length units."""
    return point_steps(kin.p_world_frame[:, index], mask, up)


def point_steps(p: np.ndarray, mask: np.ndarray, up: np.ndarray | None = None) -> np.ndarray:
    """sliding_steps of points at p (N, S, 3)."""
    step = np.linalg.norm(np.diff(p if up is None else p @ ground_frame(np.asarray(up, float))[:2].T, axis=0), axis=-1)
    return np.where(mask[1:] & mask[:-1], step, np.nan)


def foot_sliding(clip: Motion, contacts: Contacts) -> np.ndarray:
    """(N-1, S) displacement along the ground of each contact site from frame n to n+1 in length
    units per frame (x 1000 for mm in metres), where the site is in contact in both frames; NaN
    elsewhere."""
    return sliding_steps(_kinematics(clip), _site_index(clip, contacts.sites), contacts.mask, clip.skeleton.up)


def outside_support(kin: Kinematics, index: Sequence[int], mask: np.ndarray, up: np.ndarray) -> np.ndarray:
    """(N,) distance of the projected centre of mass outside the support of frames `index`
    (S,) where `mask` (N, S); 0 inside, NaN without support; length units."""
    plane = ground_frame(up)[:2].T
    com = kin.p_world_com @ plane
    feet = kin.p_world_frame[:, index] @ plane
    out = np.full(len(com), np.nan)
    patterns, inverse = np.unique(mask, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    for k, pattern in enumerate(patterns):
        if pattern.any():
            rows = inverse == k
            out[rows] = polygon_distance(com[rows], feet[rows][:, pattern])
    return out


def com_outside_support(clip: Motion, contacts: Contacts) -> np.ndarray:
    """(N,) distance in length units of the centre of mass, projected on the ground, outside
    the convex support polygon of the sites in contact in each frame: 0 inside, NaN when no
    site is in contact (or the skeleton has no mass)."""
    return outside_support(_kinematics(clip), _site_index(clip, contacts.sites), contacts.mask, clip.skeleton.up)


def _turning_joints(sk) -> list[int]:
    """Indices of the joints with rotation DOFs."""
    m = sk.motions
    return [k for k in range(sk.n_joints) if (m.kind[m.joint_start[k] : m.joint_start[k + 1]] == ROTATE).any()]


def turning_joint_names(skeleton: Skeleton) -> list[str]:
    """Names of the joints with rotation DOFs: joint_angles' columns."""
    return [skeleton.joint_names[k] for k in _turning_joints(skeleton)]


def joint_angles(original: Motion, fixed: Motion) -> np.ndarray:
    """(N, K) angle in degrees between the local rotations of each joint with rotation DOFs
    (turning_joint_names) in `original` and in `fixed`."""
    sk = original.skeleton
    turning = _turning_joints(sk)
    parents = sk.parents[turning]
    rotations = []
    for clip in (original, fixed):
        R = _kinematics(clip).R_world_frame
        parent = np.where(parents[None, :, None, None] >= 0, R[:, np.maximum(parents, 0)], np.eye(3))
        rotations.append(np.swapaxes(parent, -1, -2) @ R[:, turning])
    return np.degrees(rotation_angle(*rotations))


def joint_deviation(original: Motion, fixed: Motion) -> tuple[np.ndarray, np.ndarray]:
    """Per frame (mean (N,), max (N,)) over the joints with rotation DOFs of the angle between
    the joint's rotation in `original` and in `fixed` (relative to its parent), degrees."""
    if fixed.frames.shape != original.frames.shape:
        raise InputError(f"the clips differ: {original.frames.shape} and {fixed.frames.shape} frames x DOFs")
    angles = joint_angles(original, fixed)
    if angles.shape[1] == 0:
        return np.zeros(len(angles)), np.zeros(len(angles))
    return angles.mean(axis=1), angles.max(axis=1)


def position_deviation(original: Motion, fixed: Motion) -> np.ndarray:
    """(N, J) distance between each joint's world position in `original` and in `fixed`,
    length units."""
    J = original.skeleton.n_joints
    before, after = (_kinematics(clip).p_world_frame[:, :J] for clip in (original, fixed))
    return np.linalg.norm(after - before, axis=-1)


def jerk(kin: Kinematics, n_joints: int, frame_time: float) -> np.ndarray:
    """(N-3, J) size of each joint's jerk, |third difference of its world position| /
    frame_time^3 (length units per s^3), row n at frame n + 2; `kin` of N frames."""
    return np.linalg.norm(np.diff(kin.p_world_frame[:, :n_joints], 3, axis=0), axis=-1) / frame_time**3


def large_deviations(original: Motion, fixed: Motion, degrees: float = 30.0) -> list[dict]:
    """Every (frame, joint) whose rotation relative to its parent is more than `degrees` away
    from the capture's, in frame order: [{"frame", "joint", "deviation_deg"}]."""
    angles = joint_angles(original, fixed)
    names = turning_joint_names(original.skeleton)
    frames, joints = np.nonzero(angles > degrees)
    return [{"frame": int(f), "joint": names[j], "deviation_deg": float(angles[f, j])} for f, j in zip(frames, joints)]


def _largest(values: np.ndarray, labels, offset: int) -> tuple[float, int | None, str | None]:
    """(largest |value|, its frame = row + offset, its label) of (M, K); NaN/None when empty."""
    if values.size == 0:
        return math.nan, None, None
    row, column = np.unravel_index(np.argmax(np.abs(values)), values.shape)
    return float(abs(values[row, column])), int(row) + offset, labels[column]


def velocity_spikes(clip: Motion) -> dict:
    """Finite-difference velocities and accelerations of a clip (see the module notes).

    Keys: "dof_names" (R,) rotation DOFs; "dof_velocity" (N-1, R) deg/s, row n from frame n to
    n+1; "dof_acceleration" (N-2, R) deg/s^2, row n at frame n+1; "max_dof_velocity" deg/s;
    "max_dof_acceleration" deg/s^2 with its "max_dof_acceleration_frame" and
    "max_dof_acceleration_dof"; "frame_names" (F,) joints and sites; "position_acceleration"
    (N-2, F) length units/s^2, row n at frame n+1; "max_position_acceleration" with its
    "max_position_acceleration_frame" and "max_position_acceleration_site". Maxima are NaN
    (frames and names None) for clips of fewer than 3 frames (2 for velocities).
    """
    return spikes(clip, _kinematics(clip))


def point_motion(points: np.ndarray, frame_time: float) -> tuple[np.ndarray, np.ndarray]:
    """(speed (N-1, K), acceleration (N-2, K)) of points (N, K, 3) over frames `frame_time` s
    apart: |first difference| / dt between frames (row n from frame n to n+1) and |second
    difference| / dt^2 (row n at frame n+1), length units per s and per s^2."""
    speed = np.linalg.norm(np.diff(points, axis=0), axis=-1) / frame_time
    return speed, np.linalg.norm(np.diff(points, 2, axis=0), axis=-1) / frame_time**2


def spikes(clip: Motion, kin: Kinematics) -> dict:
    """velocity_spikes of `clip` from its kinematics `kin`."""
    sk = clip.skeleton
    dt = clip.frame_time
    rotation = np.flatnonzero(sk.dof_kind == ROTATE)
    names = tuple(sk.dof_names[d] for d in rotation)
    q = np.degrees(clip.frames[:, rotation])
    velocity = np.diff(q, axis=0) / dt
    acceleration = np.diff(q, 2, axis=0) / dt**2
    speed, position = point_motion(kin.p_world_frame, dt)
    top_velocity = _largest(velocity, names, 0)[0]
    top_dof = _largest(acceleration, names, 1)
    top_position = _largest(position, sk.frame_names, 1)
    return {
        "dof_names": names,
        "dof_velocity": velocity,
        "dof_acceleration": acceleration,
        "max_dof_velocity": top_velocity,
        "max_dof_acceleration": top_dof[0],
        "max_dof_acceleration_frame": top_dof[1],
        "max_dof_acceleration_dof": top_dof[2],
        "frame_names": sk.frame_names,
        "position_velocity": speed,
        "max_position_velocity": _largest(speed, sk.frame_names, 0)[0],
        "position_acceleration": position,
        "max_position_acceleration": top_position[0],
        "max_position_acceleration_frame": top_position[1],
        "max_position_acceleration_site": top_position[2],
    }

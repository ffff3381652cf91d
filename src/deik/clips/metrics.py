"""Numbers animators read about a clip, computed the same way before and after it is fixed.

Lengths come out in mm, i.e. length units x 1000 (the clips are taken to be in metres);
angles in degrees. Per-frame values are NaN where a metric does not apply to a frame.

- foot sliding: how far a site moves between two consecutive frames that are both in its
  contact (mm per frame); a planted foot should not move.
- COM outside support: how far the centre of mass, projected on the ground, lies outside the
  convex support polygon of the sites in contact (mm; 0 inside, NaN with no contact).
- joint deviation: per joint with rotation DOFs, the angle of R_original^T R_fixed of its
  rotation relative to its parent (degrees), so two Euler triples of one rotation count as 0.
- velocity spikes: a pop is a one-frame spike of the second difference. Rotation DOFs are
  differenced as stored (continuous Euler angles): velocity (q[n+1] - q[n]) / dt between
  frames, acceleration (q[n+1] - 2 q[n] + q[n-1]) / dt^2 at frame n. World positions of every
  joint and site are differenced the same way; they do not depend on the Euler
  parameterisation (no false spikes near gimbal lock), so the largest position acceleration is
  the pop detector to trust, the DOF one says which channel popped.
"""

from __future__ import annotations

import math

import numpy as np

from deik.model.geometry import ground_frame, polygon_distance
from deik.model.joints import ROTATE
from deik.model.kinematics import Kinematics, forward_kinematics
from deik.model.rotations import rotation_angle

MM = 1000.0  # mm per length unit (metres)


def _kinematics(clip) -> Kinematics:
    return forward_kinematics(clip.skeleton, clip.frames)


def _site_index(clip, sites) -> list[int]:
    return [clip.skeleton.frame_index(name) for name in sites]


def _stats(values: np.ndarray) -> tuple[float, float]:
    """(mean, max) of the finite values, NaN when there are none."""
    finite = values[np.isfinite(values)]
    return (float(finite.mean()), float(finite.max())) if finite.size else (math.nan, math.nan)


def _row_max(values: np.ndarray) -> np.ndarray:
    """(M,) largest finite value of each row of (M, K), NaN for rows without one."""
    filled = np.where(np.isfinite(values), values, -np.inf)
    best = filled.max(axis=1, initial=-np.inf)
    return np.where(np.isfinite(best), best, np.nan)


def _sliding(kin: Kinematics, index, mask: np.ndarray) -> np.ndarray:
    step = np.linalg.norm(np.diff(kin.p_world_frame[:, index], axis=0), axis=-1)
    return np.where(mask[1:] & mask[:-1], step, np.nan)


def foot_sliding(clip, contacts) -> np.ndarray:
    """(N-1, S) displacement of each contact site from frame n to n+1 in length units per
    frame (x 1000 for mm in metres), where the site is in contact in both frames; NaN elsewhere."""
    return _sliding(_kinematics(clip), _site_index(clip, contacts.sites), contacts.mask)


def _outside(kin: Kinematics, index, mask: np.ndarray, up: np.ndarray) -> np.ndarray:
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


def com_outside_support(clip, contacts) -> np.ndarray:
    """(N,) distance in length units of the centre of mass, projected on the ground, outside
    the convex support polygon of the sites in contact in each frame: 0 inside, NaN when no
    site is in contact (or the skeleton has no mass)."""
    return _outside(_kinematics(clip), _site_index(clip, contacts.sites), contacts.mask, clip.skeleton.up)


def _turning_joints(sk) -> list[int]:
    """Indices of the joints with rotation DOFs."""
    m = sk.motions
    return [k for k in range(sk.n_joints) if (m.kind[m.joint_start[k] : m.joint_start[k + 1]] == ROTATE).any()]


def _joint_angles(original, fixed) -> np.ndarray:
    """(N, K) angle in radians between the local rotations of each joint with rotation DOFs."""
    sk = original.skeleton
    turning = _turning_joints(sk)
    parents = sk.parents[turning]
    rotations = []
    for clip in (original, fixed):
        R = _kinematics(clip).R_world_frame
        parent = np.where(parents[None, :, None, None] >= 0, R[:, np.maximum(parents, 0)], np.eye(3))
        rotations.append(np.swapaxes(parent, -1, -2) @ R[:, turning])
    return rotation_angle(*rotations)


def joint_deviation(original, fixed) -> tuple[np.ndarray, np.ndarray]:
    """Per frame (mean (N,), max (N,)) over the joints with rotation DOFs of the angle between
    the joint's rotation in `original` and in `fixed` (relative to its parent), degrees."""
    if fixed.frames.shape != original.frames.shape:
        raise ValueError(f"the clips differ: {original.frames.shape} and {fixed.frames.shape} frames x DOFs")
    angles = np.degrees(_joint_angles(original, fixed))
    if angles.shape[1] == 0:
        return np.zeros(len(angles)), np.zeros(len(angles))
    return angles.mean(axis=1), angles.max(axis=1)


def large_deviations(original, fixed, degrees: float = 30.0) -> list[dict]:
    """Every (frame, joint) whose rotation relative to its parent is more than `degrees` away
    from the capture's, in frame order: [{"frame", "joint", "degrees"}]."""
    angles = np.degrees(_joint_angles(original, fixed))
    names = [original.skeleton.joint_names[k] for k in _turning_joints(original.skeleton)]
    frames, joints = np.nonzero(angles > degrees)
    return [{"frame": int(f), "joint": names[j], "degrees": float(angles[f, j])} for f, j in zip(frames, joints)]


def _largest(values: np.ndarray, labels, offset: int) -> tuple[float, int | None, str | None]:
    """(largest |value|, its frame = row + offset, its label) of (M, K); NaN/None when empty."""
    if values.size == 0:
        return math.nan, None, None
    row, column = np.unravel_index(np.argmax(np.abs(values)), values.shape)
    return float(abs(values[row, column])), int(row) + offset, labels[column]


def velocity_spikes(clip) -> dict:
    """Finite-difference velocities and accelerations of a clip (see the module notes).

    Keys: "dof_names" (R,) rotation DOFs; "dof_velocity" (N-1, R) deg/s, row n from frame n to
    n+1; "dof_acceleration" (N-2, R) deg/s^2, row n at frame n+1; "max_dof_velocity" deg/s;
    "max_dof_acceleration" deg/s^2 with its "max_dof_acceleration_frame" and
    "max_dof_acceleration_dof"; "frame_names" (F,) joints and sites; "position_acceleration"
    (N-2, F) length units/s^2, row n at frame n+1; "max_position_acceleration" with its
    "max_position_acceleration_frame" and "max_position_acceleration_site". Maxima are NaN
    (frames and names None) for clips of fewer than 3 frames (2 for velocities).
    """
    return _spikes(clip, _kinematics(clip))


def _spikes(clip, kin: Kinematics) -> dict:
    sk = clip.skeleton
    dt = clip.frame_time
    rotation = np.flatnonzero(sk.dof_kind == ROTATE)
    names = tuple(sk.dof_names[d] for d in rotation)
    q = np.degrees(clip.frames[:, rotation])
    velocity = np.diff(q, axis=0) / dt
    acceleration = np.diff(q, 2, axis=0) / dt**2
    position = np.linalg.norm(np.diff(kin.p_world_frame, 2, axis=0), axis=-1) / dt**2
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
        "position_acceleration": position,
        "max_position_acceleration": top_position[0],
        "max_position_acceleration_frame": top_position[1],
        "max_position_acceleration_site": top_position[2],
    }


def _reach_names(reach) -> list[str]:
    names = []
    for site, _, _ in reach:
        name = f"reach {site}"
        names.append(name if name not in names else f"{name} #{names.count(name) + 1}")
    return names


def _measure(clip, contacts, reach) -> dict:
    """Raw per-frame measurements of one clip: sliding (N-1, S), outside (N,), spikes, reach."""
    kin = _kinematics(clip)
    out = {"spikes": _spikes(clip, kin), "reach": []}
    if contacts is not None:
        index = _site_index(clip, contacts.sites)
        out["sliding"] = _sliding(kin, index, contacts.mask)
        out["outside"] = _outside(kin, index, contacts.mask, clip.skeleton.up)
    for site, mask, targets in reach:
        distance = np.linalg.norm(kin.position(site) - targets, axis=-1)
        out["reach"].append(np.where(mask, distance, np.nan))
    return out


def clip_report(original, fixed, contacts=None, reach=None) -> dict:
    """{metric: {"before": value for original, "after": value for fixed}} for the CLI table.

    Metrics (names carry the units): foot sliding mean/max (mm/frame) and COM outside support
    mean/max (mm) when `contacts` are given; joint deviation mean/max (deg; before is 0);
    max joint velocity (deg/s), max joint acceleration (deg/s^2), max position acceleration
    (m/s^2); per reach track (site, mask (N,), targets (N, 3)) the distance mean/max (mm).
    """
    reach = list(reach or ())
    before, after = _measure(original, contacts, reach), _measure(fixed, contacts, reach)
    report = {}

    def add(name, pick):
        report[name] = {"before": pick(before), "after": pick(after)}

    if contacts is not None:
        for k, word in enumerate(("mean", "max")):
            add(f"foot sliding {word} (mm/frame)", lambda m, k=k: MM * _stats(m["sliding"])[k])
        for k, word in enumerate(("mean", "max")):
            add(f"COM outside support {word} (mm)", lambda m, k=k: MM * _stats(m["outside"])[k])
    mean, top = joint_deviation(original, fixed)
    report["joint deviation mean (deg)"] = {"before": 0.0, "after": _stats(mean)[0]}
    report["joint deviation max (deg)"] = {"before": 0.0, "after": _stats(top)[1]}
    add("max joint velocity (deg/s)", lambda m: m["spikes"]["max_dof_velocity"])
    add("max joint acceleration (deg/s^2)", lambda m: m["spikes"]["max_dof_acceleration"])
    add("max position acceleration (m/s^2)", lambda m: m["spikes"]["max_position_acceleration"])
    for k, name in enumerate(_reach_names(reach)):
        for j, word in enumerate(("mean", "max")):
            add(f"{name} {word} (mm)", lambda m, k=k, j=j: MM * _stats(m["reach"][k])[j])
    return report


def per_frame_errors(original, fixed, contacts=None, reach=None) -> dict:
    """{series name (with units): (before (N,), after (N,))} for the report plot: foot sliding
    into each frame, largest over the sites (mm/frame) and COM outside support (mm) when
    `contacts` are given; joint deviation, largest over the joints (deg); largest |joint
    acceleration| (deg/s^2) and position acceleration (m/s^2) at each frame; distance to each
    reach track (mm). NaN where a series does not apply."""
    reach = list(reach or ())
    N = original.n_frames
    runs = (_measure(original, contacts, reach), _measure(fixed, contacts, reach))

    def padded(values, front):
        out = np.full(N, np.nan)
        out[front : front + len(values)] = values
        return out

    series = {}
    if contacts is not None:
        series["foot sliding (mm/frame)"] = tuple(MM * padded(_row_max(m["sliding"]), 1) for m in runs)
        series["COM outside support (mm)"] = tuple(MM * m["outside"] for m in runs)
    series["joint deviation max (deg)"] = (np.zeros(N), joint_deviation(original, fixed)[1])
    series["joint acceleration (deg/s^2)"] = tuple(
        padded(_row_max(np.abs(m["spikes"]["dof_acceleration"])), 1) for m in runs
    )
    series["position acceleration (m/s^2)"] = tuple(
        padded(_row_max(m["spikes"]["position_acceleration"]), 1) for m in runs
    )
    for k, name in enumerate(_reach_names(reach)):
        series[f"{name} (mm)"] = tuple(MM * m["reach"][k] for m in runs)
    return series

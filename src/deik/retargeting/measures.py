"""The numbers of a retarget, per frame and in summary, under keys that end in their unit.

- key-point error: distance of each key point of the target from where the source put it
  (scaled), per frame the mean (keypoint_error) and the largest (keypoint_worst) over the
  key points (mm);
- contact sliding: the largest step from frame n to n+1 of a contact site in contact in both,
  at frame n+1 (mm/frame; clips.metrics.sliding_steps);
- penetration: depth of the deepest joint or site below the floor (mm; clips.floor), a rig's
  helper bones (Skeleton.helpers) left out;
- floating: the highest contact site in contact above floor + its clearance (mm; clips.floor);
- limit violations: DOFs outside their limits (count; a rotation counts by its angle modulo a
  turn), which must be 0;
- self-penetration: how deep the deepest pair of the target's bone capsules overlaps
  (deik.SelfCollision's capsules and pairs, collision.py; mm);
- jolts: whether a key point moves faster or accelerates more than 1.1 x the fastest of the
  key points' targets (and that plus a slack: clips.dynamics.jolted_points), per frame 1 or 0
  (count), and in the summary the key points' velocity and acceleration peaks over their
  targets' (keypoint_velocity_peak_ratio, keypoint_acceleration_peak_ratio);
- joint angle deviation (same skeleton only): mean angle between each joint's rotation in the
  retarget and in the source with its bones scaled (deg; clips.metrics.joint_angles);
- time per frame: the retarget's wall time over the frames (ms);
- per point (`points`): each key point's speed and acceleration peaks over its target's
  (point_peaks), and each contact site's largest sliding step (mm/frame), so a local pop
  is not hidden by a clip-wide ratio;
- velocity violations: each (frame, DOF) whose step to the next frame goes past the DOF's
  velocity limit times the frame time (velocity_violations; settle.py adds them).
Lengths come in the target's length unit and are converted with `metres` per unit.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from deik.cleanup import floor
from deik.cleanup.contacts import Contacts
from deik.cleanup.dynamics import jolted_points, point_peak_ratios
from deik.cleanup.metrics import joint_angles, sliding_steps
from deik.io.trajectory import Motion
from deik.model.capsules import on_joints
from deik.model.joints import ROTATE
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.retargeting.capsule_overlaps import BonePairs, body_pairs, penetration_depths

LIMIT_SLACK = 1e-9  # radians or length units: rounding is no violation


def limit_violations(skeleton: Skeleton, frames: np.ndarray) -> np.ndarray:
    """(N, D) bool: DOF values outside their limits; a rotation by its angle modulo 2 pi."""
    lower, upper = skeleton.lower - LIMIT_SLACK, skeleton.upper + LIMIT_SLACK
    rotation = skeleton.dof_kind == ROTATE
    shifted = np.where(rotation, lower + np.mod(frames - lower, 2 * math.pi), frames)
    return (shifted < lower) | (shifted > upper)


def velocity_violations(motion: Motion, largest: np.ndarray) -> list[dict]:
    """[{"frame": n, "dof": name, "step": |q[n+1] - q[n]|, "largest": allowed}] for every DOF
    whose step from frame n to n+1 of `motion` goes past its `largest` (D,) (a velocity limit
    times the frame time; inf for none) by more than LIMIT_SLACK, in frame order; radians or
    length units."""
    frames = np.asarray(motion.frames, float)
    step = np.abs(np.diff(frames, axis=0))
    rows, dofs = np.nonzero(step > np.asarray(largest) + LIMIT_SLACK)
    names = motion.skeleton.dof_names
    return [
        {"frame": int(n), "dof": names[d], "step": float(step[n, d]), "largest": float(largest[d])}
        for n, d in zip(rows, dofs)
    ]


def point_peaks(names: Sequence[str], targets: np.ndarray, points: np.ndarray, frame_time: float) -> dict:
    """{name: {"speed_peak_ratio", "acceleration_peak_ratio"}}: each point of `points` (N, K, 3)
    against its target in `targets` (N, K, 3) (cleanup.dynamics.point_peak_ratios); NaN where
    the target never moves."""
    out = {}
    for k, name in enumerate(names):
        ratios = point_peak_ratios(targets[:, k : k + 1], points[:, k : k + 1], frame_time)
        out[name] = {
            "speed_peak_ratio": ratios["position_velocity"],
            "acceleration_peak_ratio": ratios["position_acceleration"],
        }
    return out


def _series(values: np.ndarray) -> list:
    return [None if not np.isfinite(v) else float(v) for v in values]


def _row_stat(values: np.ndarray, pick) -> np.ndarray:
    """pick (np.nanmean, np.nanmax) per row of (N, K), NaN for rows without a finite value."""
    finite = np.isfinite(values).any(axis=1)
    out = np.full(len(values), np.nan)
    if finite.any():
        out[finite] = pick(values[finite], axis=1)
    return out


def retarget_report(
    motion: Motion,
    names: Sequence[str],
    targets: np.ndarray,
    contacts: Contacts | None,
    metres: float,
    wall_time: float,
    scaled: Motion | None = None,
    pairs: BonePairs | None = None,
) -> dict:
    """{"summary": {key: number}, "per_frame": {key: [N values, null where none]}} of the target
    `motion` (a Clip or Trajectory): key points `names` (K,) against `targets` (N, K, 3);
    `contacts` of target sites (or None), each planted at its clearance (cleanup.floor.clearance);
    `scaled` the source on the
    target skeleton (joint angle deviation) or None; `pairs` the bone capsules tested for
    self-penetration (default every SelfCollision pair of the skeleton). See the module notes."""
    sk, mm = motion.skeleton, 1000.0 * metres
    N = motion.n_frames
    kin = forward_kinematics(sk, motion.poses())
    per_frame = {}
    peaks = {}
    per_point = {}
    if len(names):
        index = [sk.frame_index(name) for name in names]
        error = np.linalg.norm(kin.p_world_frame[:, index] - targets, axis=-1) * mm
        per_frame["keypoint_error_mm"] = error.mean(axis=1)
        per_frame["keypoint_worst_mm"] = error.max(axis=1)
        points, dt = kin.p_world_frame[:, index], motion.frame_time
        per_frame["jolted_count"] = jolted_points(targets, points, dt, sk.reach).astype(float)
        peaks = point_peak_ratios(targets, points, dt)
        per_point = point_peaks(names, targets, points, dt)
    if contacts is not None:
        index = [sk.frame_index(name) for name in contacts.sites]
        steps = sliding_steps(kin, index, contacts.mask) * mm  # in space, as a robot's planted foot is judged
        for s, site in enumerate(contacts.sites):
            finite = steps[:, s][np.isfinite(steps[:, s])]
            per_point.setdefault(site, {})["sliding_max_mm_per_frame"] = float(finite.max()) if finite.size else None
        per_frame["contact_sliding_mm_per_frame"] = np.concatenate([[np.nan], _row_stat(steps, np.nanmax)])
        clearance = floor.clearance(kin, sk, contacts)
        per_frame["floating_mm"] = _row_stat(floor.floating(kin, sk, contacts, clearance) * mm, np.nanmax)
    ground = 0.0 if contacts is None else contacts.ground  # a retarget without contacts: its world's floor
    helpers = on_joints(sk, sk.helpers)  # a rig's helper bones: no body to sink
    per_frame["penetration_mm"] = floor.penetration(kin, sk, ground, np.where(helpers, np.nan, 0.0)) * mm
    per_frame["limit_violations_count"] = limit_violations(sk, motion.frames).sum(axis=1).astype(float)
    pairs = body_pairs(sk, sk.frame_names) if pairs is None else pairs
    per_frame["self_penetration_mm"] = penetration_depths(sk, motion.poses(), pairs).max(axis=1, initial=0.0) * mm
    if scaled is not None:
        angles = joint_angles(scaled, motion)
        per_frame["joint_angle_deviation_deg"] = angles.mean(axis=1) if angles.size else np.zeros(N)
    summary = {"frames_count": N, "wall_time_s": wall_time, "time_per_frame_ms": 1000.0 * wall_time / max(N, 1)}
    for key, values in per_frame.items():
        stem, unit = _split(key)
        finite = values[np.isfinite(values)]
        summary[f"{stem}_mean_{unit}"] = float(finite.mean()) if finite.size else math.nan
        summary[f"{stem}_max_{unit}"] = float(finite.max()) if finite.size else math.nan
    summary["limit_violations_count"] = int(per_frame["limit_violations_count"].sum())
    if peaks:
        summary["jolted_frames_count"] = int(per_frame["jolted_count"].sum())
        summary["keypoint_velocity_peak_ratio"] = peaks["position_velocity"]
        summary["keypoint_acceleration_peak_ratio"] = peaks["position_acceleration"]
    series = {key: _series(values) for key, values in per_frame.items()}
    return {"summary": summary, "per_frame": series, "points": per_point}


def _split(key: str) -> tuple[str, str]:
    """("keypoint_error", "mm") of "keypoint_error_mm"; units: mm, mm_per_frame, count, deg."""
    for unit in ("mm_per_frame", "mm", "count", "deg"):
        if key.endswith("_" + unit):
            return key[: -len(unit) - 1], unit
    raise ValueError(f"report key {key!r} has no unit")

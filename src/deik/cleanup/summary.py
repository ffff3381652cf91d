"""The before/after numbers of a clip fix under machine keys: the summary and per-frame series.

Every key ends in its unit (mm, deg, m_per_s3, ...; "share" for a fraction 0-1, "count" for
sites) and every entry carries its `label` for people and its `unit`. Lengths are converted
from the clip's length unit with `metres` (metres per length unit, cleanup/units.py). The
metrics are defined in cleanup/metrics.py (sliding, COM outside support, deviations, jerk,
velocity spikes), cleanup/balance.py (ZMP outside support, with gravity 9.81 m/s^2) and
cleanup/floor.py (skating, penetration, floating); docs/clips.md defines each. Support and
floating metrics need contacts (the ones planted); with a Grounding, sliding counts every point
that rests in the capture, planted or not, the points along the bones included, skating the
resting joints and sites, and penetration the body's surface below the floor stated; without
one, the planted contacts and the joints and sites themselves.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from deik.cleanup import floor
from deik.cleanup.balance import zmp_outside_support
from deik.cleanup.bone_points import BonePoints
from deik.cleanup.clip_goals import GRAVITY, reach_names
from deik.cleanup.contacts import Contacts
from deik.cleanup.metrics import (
    jerk,
    joint_angles,
    outside_support,
    point_steps,
    position_deviation,
    sliding_steps,
    spikes,
)
from deik.io.trajectory import Motion
from deik.model.kinematics import Kinematics
from deik.model.skeleton import Skeleton


def _stats(values: np.ndarray) -> tuple[float, float]:
    """(mean, max) of the finite values, NaN when there are none."""
    finite = values[np.isfinite(values)]
    return (float(finite.mean()), float(finite.max())) if finite.size else (math.nan, math.nan)


def row_max(values: np.ndarray) -> np.ndarray:
    """(M,) largest finite value of each row of (M, K), NaN for rows without one."""
    filled = np.where(np.isfinite(values), values, -np.inf)
    best = filled.max(axis=1, initial=-np.inf)
    return np.where(np.isfinite(best), best, np.nan)


def _padded(values: np.ndarray, front: int, n: int) -> np.ndarray:
    """(n,) `values` placed from frame `front`, NaN around."""
    out = np.full(n, np.nan)
    out[front : front + len(values)] = values
    return out


# per-frame series: key -> (stem, unit suffix, label, unit); key = stem_suffix
SERIES = {
    f"{stem}_{suffix}": (stem, suffix, label, unit)
    for stem, suffix, label, unit in (
        ("sliding", "mm_per_frame", "sliding of the resting points", "mm/frame"),
        ("com_outside_support", "mm", "COM outside support", "mm"),
        ("zmp_outside_support", "mm", "ZMP outside support (soles included)", "mm"),
        ("penetration", "mm", "penetration below the floor", "mm"),
        ("floating", "mm", "floating in contact", "mm"),
        ("joint_angle_deviation", "deg", "joint angle from the capture", "deg"),
        ("joint_position_deviation", "mm", "joint position from the capture", "mm"),
        ("jerk", "m_per_s3", "jerk", "m/s^3"),
        ("joint_velocity", "deg_per_s", "joint velocity", "deg/s"),
        ("joint_acceleration", "deg_per_s2", "joint acceleration", "deg/s^2"),
        ("position_velocity", "m_per_s", "position velocity", "m/s"),
        ("position_acceleration", "m_per_s2", "position acceleration", "m/s^2"),
    )
}


@dataclass(frozen=True, eq=False)
class Grounding:
    """The floor the measures use: its `height` (length units along up), each joint and site's
    `clearance` (F,) (how far the body's surface lies below it; NaN: not counted), the points
    `resting` in the capture (Contacts: sliding and skating are measured over them) and the
    points `along` the bones and when they rest (cleanup/bone_points.py: sliding counts them
    too; None: none)."""

    height: float
    clearance: np.ndarray
    resting: Contacts
    along: BonePoints | None = None


def resting_steps(kin: Kinematics, skeleton: Skeleton, resting: Contacts, along: BonePoints | None) -> np.ndarray:
    """(N-1, K) how far each point resting in frames n and n+1 of the capture moves along the
    ground between them in the clip of kinematics `kin` (NaN where it does not rest in both, and
    over a seam of `resting`, where the capture's pose jumps): the `resting` joints and sites,
    then the points `along` the bones; length units."""
    index = [skeleton.frame_index(name) for name in resting.sites]
    steps = sliding_steps(kin, index, resting.mask, skeleton.up)
    if along is not None:
        steps = np.concatenate(
            [steps, point_steps(along.positions(kin.p_world_frame), along.rest, skeleton.up)], axis=1
        )
    steps[[n for n in resting.seams if n < len(steps)]] = np.nan
    return steps


def _reach_keys(reach) -> dict:
    """SERIES-like entries of the distance to each reach track (site, mask, targets)."""
    out = {}
    for name in reach_names(site for site, _, _ in reach):
        stem = name.replace(" #", "_").replace(" ", "_")
        out[f"{stem}_mm"] = (stem, "mm", f"{name} distance", "mm")
    return out


def _measure(clip, contacts, reach, clear, metres: float, grounding: Grounding | None) -> dict:
    """{key: (values (M, K) in the key's unit, the frame of row 0)} of one clip: every joint,
    site or DOF of each SERIES entry (deviations aside) and each reach track."""
    sk, mm = clip.skeleton, 1000.0 * metres
    kin = clip.kinematics
    moves = spikes(clip, kin)
    out = {}
    if grounding is not None:
        out["sliding_mm_per_frame"] = mm * resting_steps(kin, sk, grounding.resting, grounding.along), 1
    elif contacts is not None:
        out["sliding_mm_per_frame"] = mm * resting_steps(kin, sk, contacts, None), 1
    if grounding is not None:
        depth = floor.penetration(kin, sk, grounding.height, grounding.clearance)
        out["penetration_mm"] = mm * depth[:, None], 0
    if contacts is not None:
        index = [sk.frame_index(name) for name in contacts.sites]
        out["com_outside_support_mm"] = mm * outside_support(kin, index, contacts.mask, sk.up)[:, None], 0
        zmp = zmp_outside_support(kin, sk, contacts, clip.frame_time, GRAVITY / metres)
        out["zmp_outside_support_mm"] = mm * zmp[:, None], 0
        if grounding is None:
            out["penetration_mm"] = mm * floor.penetration(kin, sk, contacts.ground)[:, None], 0
        out["floating_mm"] = mm * floor.floating(kin, sk, contacts, clear), 0
    out["jerk_m_per_s3"] = metres * jerk(kin, sk.n_joints, clip.frame_time), 2
    out["joint_velocity_deg_per_s"] = np.abs(moves["dof_velocity"]), 1
    out["joint_acceleration_deg_per_s2"] = np.abs(moves["dof_acceleration"]), 1
    out["position_velocity_m_per_s"] = metres * moves["position_velocity"], 0
    out["position_acceleration_m_per_s2"] = metres * moves["position_acceleration"], 1
    for key, (site, mask, targets) in zip(_reach_keys(reach), reach):
        distance = np.linalg.norm(kin.position(site) - targets, axis=-1)
        out[key] = mm * np.where(mask, distance, np.nan)[:, None], 0
    return out


def _both(original, fixed, contacts, reach, metres: float, grounding: Grounding | None) -> tuple[dict, dict]:
    """_measure of `original` and `fixed`, with the deviations from the capture (0 before)."""
    clear = None
    if contacts is not None:
        clear = floor.clearance(original.kinematics, original.skeleton, contacts)
    before, after = (_measure(clip, contacts, reach, clear, metres, grounding) for clip in (original, fixed))
    angles = joint_angles(original, fixed)
    positions = 1000.0 * metres * position_deviation(original, fixed)
    for key, values in (("joint_angle_deviation_deg", angles), ("joint_position_deviation_mm", positions)):
        before[key], after[key] = (np.zeros_like(values), 0), (values, 0)
    return before, after


def _keys(contacts, reach, grounding: Grounding | None) -> dict:
    planted = ("com_outside_support", "zmp_outside_support", "floating")
    grounded = ("sliding", "penetration")
    keys = {
        k: v
        for k, v in SERIES.items()
        if (v[0] not in planted or contacts is not None)
        and (v[0] not in grounded or contacts is not None or grounding is not None)
    }
    return keys | _reach_keys(reach)


# a reach track as reports take it: (site, mask (N,) bool, targets (N, 3) length units)
ReachTrack = tuple[str, np.ndarray, np.ndarray]


def per_frame_errors(
    original: Motion,
    fixed: Motion,
    contacts: Contacts | None = None,
    reach: Sequence[ReachTrack] | None = None,
    metres: float = 1.0,
    grounding: Grounding | None = None,
) -> dict:
    """{key: {"label", "unit", "before" (N,), "after" (N,)}}: per frame, the largest value
    over the joints, sites or DOFs of each SERIES entry (the floor ones with `contacts` or a
    `grounding`, module notes) and the distance to each reach track (site, mask (N,), targets
    (N, 3)), in the key's unit, and with `contacts` the number of sites in contact
    ("contacts_count", the same before and after); NaN where a series does not apply to a
    frame. `metres`: metres per length unit."""
    reach = list(reach or ())
    N = original.n_frames
    runs = _both(original, fixed, contacts, reach, metres, grounding)
    out = {}
    for key, (_, _, label, unit) in _keys(contacts, reach, grounding).items():
        sides = [_padded(row_max(run[key][0]), run[key][1], N) for run in runs]
        out[key] = {"label": label, "unit": unit, "before": sides[0], "after": sides[1]}
    if contacts is not None:
        count = contacts.mask.sum(axis=1).astype(float)
        out["contacts_count"] = {"label": "sites in contact", "unit": "count", "before": count, "after": count}
    return out


def clip_report(
    original: Motion,
    fixed: Motion,
    contacts: Contacts | None = None,
    reach: Sequence[ReachTrack] | None = None,
    metres: float = 1.0,
    grounding: Grounding | None = None,
) -> dict:
    """{key: {"label", "unit", "before", "after"}}, one number per clip for `original` and
    `fixed`: "STEM_mean_SUFFIX" and "STEM_max_SUFFIX" over every joint, site or DOF and frame
    of each per_frame_errors series, the foot-skating ratio (share of the contact steps,
    cleanup/floor.py; over the resting points of a `grounding`, else over `contacts`) and with
    `contacts` the mean number of sites in contact per frame."""
    reach = list(reach or ())
    runs = _both(original, fixed, contacts, reach, metres, grounding)
    report = {}
    for key, (stem, suffix, label, unit) in _keys(contacts, reach, grounding).items():
        stats = [_stats(run[key][0]) for run in runs]
        for k, word in enumerate(("mean", "max")):
            report[f"{stem}_{word}_{suffix}"] = {
                "label": f"{label} {word}",
                "unit": unit,
                "before": stats[0][k],
                "after": stats[1][k],
            }
    resting = contacts if grounding is None else grounding.resting
    if resting is not None:
        sk = original.skeleton
        kins = [clip.kinematics for clip in (original, fixed)]
        clear = floor.clearance(kins[0], sk, resting)
        ratios = [floor.skating_ratio(*floor.skating(kin, sk, resting, clear, metres)) for kin in kins]
        report["foot_skating_ratio_share"] = {
            "label": "foot-skating ratio",
            "unit": "share",
            "before": ratios[0],
            "after": ratios[1],
        }
    if contacts is not None:
        count = float(contacts.mask.sum(axis=1).mean()) if len(contacts.mask) else math.nan
        report["contacts_per_frame_mean_count"] = {
            "label": "sites in contact per frame, mean",
            "unit": "count",
            "before": count,
            "after": count,
        }
    return report

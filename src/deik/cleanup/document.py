"""The record of a clip fix: its goal table and the JSON document `deik clip --json` writes.

Goals are grouped by name (clips/problem.goal_names; the balance goals, one per pattern of
sites in contact, make one row). Contacts, reach and balance errors are distances in mm;
fidelity and coherence are the clip's last-level terms (GOAL_NOTES), sums over the DOFs in
degrees. The JSON's keys are snake_case and every number says its unit, in its key or beside
it; per-frame lists hold null where a value does not apply to a frame.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from deik.cleanup.balance import BalanceTrack
from deik.cleanup.contacts import Contacts
from deik.cleanup.dynamics import PEAK_RATIO, PEAK_SECONDS, jolted_frames, peak_ratios, point_acceleration_ratios
from deik.cleanup.metrics import large_deviations
from deik.cleanup.plants import planted_targets
from deik.cleanup.summary import Grounding, ReachTrack, clip_report, per_frame_errors, row_max
from deik.cleanup.verdict import capture_grounding, frame_verdict
from deik.io.trajectory import Motion

if TYPE_CHECKING:  # clips.solver loads the solver; the report needs only the type
    from deik.cleanup.fix import ClipFix

LEVEL1 = ("fidelity", "coherence")
GOAL_NOTES = {
    "fidelity": (
        "how far each frame's pose lies from the capture's, summed over the DOFs in degrees "
        "(a root translation counts as the root turn that moves the body as far); 0 for the capture"
    ),
    "coherence": (
        "how far each frame's change from the capture lies from the mean change of its two "
        "neighbours, summed likewise: 0 where the correction varies linearly over time, so it "
        "counts the pops and jitter the fix adds; 0 for the capture"
    ),
}


def goal_table(fix: ClipFix, metres: float = 1.0) -> list[dict]:
    """One row per goal name of `fix` (a ClipFix): {"key", "label", "unit", "tolerance" (in
    unit, None without one), "before" (N,), "after" (N,)} with each frame's error (NaN where
    the goal does not apply); `metres` per length unit."""
    rows = []
    for name in dict.fromkeys(fix.labels):
        columns = [t for t, label in enumerate(fix.labels) if label == name]
        scale, unit = (np.degrees(1.0), "deg") if name in LEVEL1 else (1000.0 * metres, "mm")
        tolerance = float(fix.tolerances[columns].max())
        after = scale * row_max(fix.after[:, columns])
        before = np.zeros_like(after) if name in LEVEL1 else scale * row_max(fix.before[:, columns])
        rows.append(
            {
                "key": name.replace(" #", "_").replace(" ", "_"),
                "label": name,
                "unit": unit,
                "tolerance": scale * tolerance if tolerance >= 0 else None,
                "before": before,
                "after": after,
            }
        )
    return rows


def contacts_record(original: Motion, contacts: Contacts | None) -> dict:
    """The contacts as JSON: how they were found, the floor height and thresholds (length
    units, per second for the speed), the sites in contact per frame, and per site each
    contact's first and last frame (inclusive) and plant position (length units)."""
    plants = planted_targets(original, contacts)
    return {
        "detected": contacts.detected,
        "ground_height": contacts.ground,
        "height_threshold": contacts.height,
        "speed_threshold_per_s": contacts.speed,
        "count_per_frame": contacts.mask.sum(axis=1).tolist(),
        "sites": [
            {
                "site": site,
                "contacts": [
                    {"first_frame": a, "last_frame": b - 1, "plant": plants[a, s].tolist()}
                    for a, b in contacts.intervals(s)
                ],
            }
            for s, site in enumerate(contacts.sites)
        ],
    }


def unreached(goals: list[dict]) -> dict:
    """{reach goal key: {"frames": [...], "distance_mm": [...]}}: the frames in which each reach
    goal of the goal table `goals` (goal_table rows) ends farther than its tolerance from its
    target (out of reach without moving a contact), with that distance."""
    out = {}
    for row in goals:
        if row["label"].startswith("reach "):
            after = np.asarray(row["after"], float)
            frames = np.flatnonzero(after > row["tolerance"])
            out[row["key"]] = {"frames": frames.tolist(), "distance_mm": after[frames].tolist()}
    return out


def reach_record(reach: Iterable[ReachTrack]) -> list[dict]:
    """The reach tracks as JSON: per track its site and, for each frame it applies to, the frame
    and the target (length units), so a viewer can mark them (`deik view --report`)."""
    return [
        {
            "site": site,
            "frames": np.flatnonzero(mask).tolist(),
            "targets": np.asarray(targets, float)[np.asarray(mask, bool)].tolist(),
        }
        for site, mask, targets in reach
    ]


def balance_record(track: BalanceTrack | None, metres: float) -> dict | None:
    """The balance track (clips/balance.BalanceTrack) as JSON, or None without balance: the frames
    it keeps the ZMP over the support in, those it skipped (holding them would have made the
    motion jolt or changed the performance), the acceleration budget and the longest COM shift
    allowed, and the shift per frame (mm along the two ground axes)."""
    if track is None:
        return None
    mm = 1000.0 * metres
    return {
        "balanced_frames": np.flatnonzero(track.balanced).tolist(),
        "skipped_frames": np.flatnonzero(track.skipped).tolist(),
        "acceleration_budget_m_per_s2": metres * track.budget,
        "shift_mm": (mm * track.shift).tolist(),
    }


def dynamics_record(original: Motion, fixed: Motion, points: np.ndarray | None = None) -> dict:
    """How the fix's velocity and acceleration peaks compare with the capture's (cleanup/dynamics.py):
    the ratio of each peak, each joint and site's (of `points` (F,) bool) acceleration peak over
    its own in the capture around each frame (within the window, s) and the worst of them, the
    limit, whether every one is kept, and the frames that jolt or turn a joint far."""
    ratios = peak_ratios(original, fixed)
    names = [name for name, kept in zip(original.skeleton.frame_names, points if points is not None else ()) if kept]
    per_point = point_acceleration_ratios(original, fixed, points)
    names = names or list(original.skeleton.frame_names)
    finite = np.where(np.isfinite(per_point), per_point, -np.inf)
    worst = int(np.argmax(finite)) if len(finite) and np.isfinite(finite).any() else None
    kept = all(not r > PEAK_RATIO for r in ratios.values()) and not (per_point > PEAK_RATIO).any()
    return {
        "peak_ratio_limit": PEAK_RATIO,
        "peak_window_s": PEAK_SECONDS,
        "peak_ratios": ratios,
        "point_acceleration_ratios": {name: float(r) for name, r in zip(names, per_point)},
        "worst_point": None if worst is None else {"point": names[worst], "ratio": float(per_point[worst])},
        "peaks_kept": bool(kept),
        "jolted_frames": np.flatnonzero(jolted_frames(original, fixed, points=points)).tolist(),
    }


def grounding(fix: ClipFix, height: float) -> Grounding:
    """The floor the report measures against: at `height`, each point's clearance as the fix kept
    it (its radius), and every point of the body that rests in the capture, planted or not
    (verdict.capture_grounding)."""
    return capture_grounding(fix.on_body()[0], fix.body, height)


def _far(original, fixed, degrees: float) -> dict:
    far = large_deviations(original, fixed, degrees)
    count = np.bincount([d["frame"] for d in far], minlength=original.n_frames)
    return {"threshold_deg": degrees, "count_per_frame": count.tolist(), "joint_frames": far}


def clip_document(
    fix: ClipFix,
    contacts: Contacts | None,
    reach: Sequence[ReachTrack],
    unit: str,
    metres: float,
    far_degrees: float,
    floor: dict | None = None,
) -> dict:
    """The JSON record of `fix` (a ClipFix) with `contacts` (or None) and `reach` tracks (site,
    mask, targets): length `unit` and its `metres`; the summary metrics and per-frame series
    (cleanup/summary.py), the goal table per frame with GOAL_NOTES, the frames each reach missed
    (unreached) and its targets, the contacts, the `floor` ({"height" length units, "how" it was
    found, "kept", ...} or None; the floor measures use it, cleanup/summary.Grounding), the joints
    turned more than `far_degrees` from the capture frame by frame, whether each frame is met
    (its goals met and, with a `floor`, nothing sunk under it nor sliding: cleanup/verdict.py,
    with the frames that sink or slide), the balance track
    (balance_record), the peaks against the capture's (dynamics_record), the frames whose change
    was taken back so that nothing jolts, and where the time went."""
    original, fixed = fix.on_body()
    # peaks and turns are the capture's as given, before its noise was low-passed (cleanup/noise.py)
    captured = original if fix.goals is None or fix.goals.captured is None else fix.goals.captured
    ground = None if floor is None else grounding(fix, floor["height"])
    goals = goal_table(fix, metres)
    met, sunk, sliding = fix.met, [], []
    if ground is not None:
        verdict = frame_verdict(fix.met, fixed, ground, fix.body.span)
        met, sunk, sliding = verdict.met, np.flatnonzero(verdict.sunk), np.flatnonzero(verdict.sliding)

    def listed(entry):
        return {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in entry.items()}

    return {
        "source": original.source,
        "frames": original.n_frames,
        "frame_time_s": original.frame_time,
        "length_unit": unit,
        "metres_per_length_unit": metres,
        "metrics": clip_report(original, fixed, contacts, reach, metres, ground),
        "per_frame": {
            k: listed(v) for k, v in per_frame_errors(original, fixed, contacts, reach, metres, ground).items()
        },
        "goals": [listed(row) for row in goals],
        "reach_unreached": unreached(goals),
        "reach_targets": reach_record(reach or ()),
        "floor": floor,
        "resting_points": None if ground is None else list(ground.resting.sites),
        "goal_notes": GOAL_NOTES,
        "frames_met": int(met.sum()),
        "met_per_frame": met.tolist(),
        "sunk_frames": [int(n) for n in sunk],
        "sliding_frames": [int(n) for n in sliding],
        "contacts": None if contacts is None else contacts_record(original, contacts),
        "joints_far_from_capture": _far(captured, fixed, far_degrees),
        "balance": balance_record(fix.balance, metres),
        "dynamics": dynamics_record(captured, fixed, fix.body.points),
        "calmed_frames": np.flatnonzero(fix.calmed).tolist(),
        "wall_time_s": fix.wall_time,
        "stages": list(fix.stages),
    }

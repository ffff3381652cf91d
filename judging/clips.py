"""An independent judge of a cleaned clip: its own kinematics (judging/rigs.py), its own
body model and contact detector, the floor at height 0 (up +Y). Nothing here calls deik.

Body: the DeepMimic humanoid's collision shapes (the source model of the shared clips,
`humanoid_deepmimic_source.urdf` at its 0.25 scale), attached to the canonical joints a case
names, turned with a joint whose frame the case turned (Case.turns) and scaled by its length
unit and bone scales: spheres for the pelvis, chest, head and
hands, capsules for the thighs, shins, upper arms and forearms, a box for each foot. A foot
with toes (a case whose names give a RightToe or LeftToe joint: judging/cases.py, digits) has
its box cut across at the toe joint, the part beyond it turning with the toe, as a foot bends
at its ball; a toe the rig keeps still leaves the box as one.

Contact points: every sphere's centre, both ends of every capsule's axis, and the bottom of
each foot box under its heel and under its toe; a point's clearance is how far below it the
shape's surface reaches (the radius; 0 for the foot-box points). A point rests in a frame when
its surface is at most BAND above the floor and its speed (central differences of its position
averaged over three frames) at most SPEED, in runs of at least REST_SECONDS.

Measures, in mm and the case's frames:
- sliding: the largest horizontal step of a point between two frames of one of its resting runs
  in the capture (every point that rests in the capture, whatever a cleaner detects);
- depth: the deepest any shape's surface goes below the floor (a box's corners, and where it is
  cut at a toe joint the corners of both parts there, a capsule's ends, a sphere's bottom);
- peaks: per joint and End Site, its acceleration (second difference / dt^2) in each frame over
  its largest in the capture within PEAK_SECONDS of that frame (at least STILL): the worst ratio
  and its point (a pop in a quiet stretch counts, however hard that point moves elsewhere);
- travel: how far the pelvis goes over the ground, first frame to last, against the capture;
- steps: the capture's resting runs of the foot points matched in the result (an overlapping run
  whose first and last frames are within STEP_SLACK seconds, at least one frame, of the capture's).
Where a case's transform added errors to the capture's data (noise, the body sunk under the
floor, a glitch frame: judging/cases.py, Case.truth), where points rest is taken from
the data without them: a heel the transform sank 12 mm into the band is not a step, nor is a
run the glitch frame cut in two, and a foot the noise shakes still rests. Everything else is
measured against the capture as written: sliding on its and the result's own points, depth,
travel, and the acceleration peaks (a cleaner must add no pop to what it was given).
"""

from __future__ import annotations

import numpy as np

from judging.cases import Case
from judging.rigs import Rig, world_frames

BAND = 0.02  # metres above the floor
SPEED = 0.15  # metres per second
REST_SECONDS = 0.05
STEP_SLACK = 0.07  # seconds
PEAK_SECONDS = 2.0  # each side of a frame
STILL = 0.1  # metres per second^2: a capture's point accelerating less is still
FOOT_BOX = ((0.045, -0.0225, 0.0), (0.0885, 0.0275, 0.045))  # centre, half sizes in the ankle's frame
SPHERES = (("Hips", (0, 0.07, 0), 0.09), ("Chest", (0, 0.12, 0), 0.11), ("Neck", (0, 0.175, 0), 0.1025),
           ("RightElbow", (0, -0.258947, 0), 0.04), ("LeftElbow", (0, -0.258947, 0), 0.04))  # fmt: skip
CAPSULES = tuple(
    (joint, (0, a, 0), (0, b, 0), r)
    for side in ("Right", "Left")
    for joint, a, b, r in (
        (f"{side}Hip", -0.06, -0.36, 0.055),
        (f"{side}Knee", -0.045, -0.355, 0.05),
        (f"{side}Shoulder", -0.05, -0.23, 0.045),
        (f"{side}Elbow", -0.0525, -0.1875, 0.04),
    )
)


def _world(R, p, joint: int, local) -> np.ndarray:
    """(N, 3) world position of `local` (3,) in joint `joint`'s frame."""
    return p[:, joint] + np.einsum("nij,j->ni", R[:, joint], np.asarray(local, float))


def contact_points(case: Case, rig: Rig) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(names, positions (N, K, 3) in metres, clearances (K,) metres) of the module's contact points."""
    R, p = world_frames(rig)
    s = 1.0 / case.unit
    names, points, clear = [], [], []

    def add(name, joint, local, radius):
        scale = case.bone_scale.get(joint, 1.0)
        j = rig.names.index(case.names[joint])
        names.append(name)
        local = case.turns.get(joint, np.eye(3)).T @ np.asarray(local, float)
        points.append(_world(R, p, j, local * case.unit * scale) * s)
        clear.append(radius * scale)

    for joint, centre, radius in SPHERES:
        add(f"{joint} sphere", joint, centre, radius)
    for joint, a, b, radius in CAPSULES:
        add(f"{joint} capsule top", joint, a, radius)
        add(f"{joint} capsule end", joint, b, radius)
    (cx, _, cz), (hx, _, _) = FOOT_BOX
    for side in ("Right", "Left"):
        for end, x in (("heel", cx - hx), ("toe", cx + hx)):
            names.append(f"{side} {end}")
            points.append(_sole(case, rig, (R, p), side, (x, cz)) * s)
            clear.append(0.0)
    return names, np.stack(points, axis=1), np.array(clear)


def _ball(case: Case, rig: Rig, side: str) -> tuple[int, np.ndarray] | None:
    """(the toe joint's index, its OFFSET in the foot's frame in the source's metres) of the foot
    on `side` when the case's rig has one (Case.names' {side}Toe), else None."""
    if f"{side}Toe" not in case.names:
        return None
    toe = rig.names.index(case.names[f"{side}Toe"])
    scale = case.bone_scale.get(f"{side}Ankle", 1.0) * case.unit
    return toe, case.turns.get(f"{side}Ankle", np.eye(3)) @ rig.offsets[toe] / scale


def _sole(case: Case, rig: Rig, frames: tuple, side: str, spot: tuple[float, float], on_toe: bool | None = None):
    """(N, 3) world position (length units) of the point of the foot box's bottom at `spot` (x
    forward, z across, source metres in the ankle's frame) on `side`, world `frames` (R, p) of
    `rig`: on the toe where the box reaches past the toe joint (module notes: a foot with toes),
    or as `on_toe` says (the ball's edge is on both parts)."""
    R, p = frames
    (_, cy, _), (_, hy, _) = FOOT_BOX
    local = np.array([spot[0], cy - hy, spot[1]])
    joint = f"{side}Ankle"
    scale = case.bone_scale.get(joint, 1.0) * case.unit
    turn = case.turns.get(joint, np.eye(3))
    ball = _ball(case, rig, side)
    if ball is not None and (spot[0] > ball[1][0] if on_toe is None else on_toe):
        return _world(R, p, ball[0], turn.T @ (local - ball[1]) * scale)
    return _world(R, p, rig.names.index(case.names[joint]), turn.T @ local * scale)


def deepest(case: Case, rig: Rig) -> np.ndarray:
    """(N,) how far below the floor the lowest surface of the body goes in each frame, metres
    (negative: above)."""
    names, points, clear = contact_points(case, rig)
    lowest = (points[..., 1] - clear).min(axis=1)
    frames = world_frames(rig)
    (cx, _, cz), (hx, _, hz) = FOOT_BOX
    for side in ("Right", "Left"):
        ball = _ball(case, rig, side)
        spots = [(cx - hx, None), (cx + hx, None)] + ([] if ball is None else [(ball[1][0], False), (ball[1][0], True)])
        for x, on_toe in spots:
            for z in (cz - hz, cz + hz):
                corner = _sole(case, rig, frames, side, (x, z), on_toe)
                lowest = np.minimum(lowest, corner[:, 1] / case.unit)
    return -lowest


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))


def resting(points: np.ndarray, clear: np.ndarray, frame_time: float) -> np.ndarray:
    """(N, K) bool: the module's resting rule for points (N, K, 3) metres."""
    N = len(points)
    smooth = points.copy()
    if N >= 3:
        smooth[1:-1] = (points[:-2] + points[1:-1] + points[2:]) / 3.0
    speed = np.linalg.norm(np.gradient(smooth, frame_time, axis=0), axis=-1) if N > 1 else np.zeros(points.shape[:2])
    rest = (points[..., 1] - clear <= BAND) & (speed <= SPEED)
    shortest = max(2, int(round(REST_SECONDS / frame_time)))
    for k in range(rest.shape[1]):
        for a, b in _runs(rest[:, k]):
            if b - a < shortest:
                rest[a:b, k] = False
    return rest


def _sliding(points: np.ndarray, rest: np.ndarray) -> tuple[float, str | None, int | None, np.ndarray]:
    """(largest horizontal step in mm within the resting runs `rest`, its point index, its frame,
    (N,) the largest step ending at each frame)."""
    step = np.linalg.norm(np.diff(points[..., [0, 2]], axis=0), axis=-1) * 1000.0
    step = np.where(rest[1:] & rest[:-1], step, 0.0)
    per_frame = np.concatenate([[0.0], step.max(axis=1, initial=0.0)])
    if not step.size or step.max() == 0:
        return 0.0, None, None, per_frame
    n, k = np.unravel_index(np.argmax(step), step.shape)
    return float(step[n, k]), int(k), int(n + 1), per_frame


def _accelerations(rig: Rig, case: Case) -> np.ndarray:
    """(N - 2, K) acceleration of every canonical joint and its End Sites in each frame, metres per s^2."""
    R, p = world_frames(rig)
    columns = [rig.names.index(case.names[name]) for name in case.names]
    points = [p[:, j] for j in columns] + [
        p[:, j] + np.einsum("nij,j->ni", R[:, j], offset) for _, j, offset in rig.sites if j in columns
    ]
    x = np.stack(points, axis=1) / case.unit
    if len(x) < 3:
        return np.zeros((0, x.shape[1]))
    return np.linalg.norm(np.diff(x, 2, axis=0), axis=-1) / rig.frame_time**2


def _peak_ratios(before: np.ndarray, after: np.ndarray, frame_time: float) -> np.ndarray:
    """(K,) each point's largest ratio of `after` (M, K) to `before`'s largest within
    PEAK_SECONDS of that frame (at least STILL)."""
    if not len(before):
        return np.zeros(before.shape[1])
    w = max(1, int(round(PEAK_SECONDS / frame_time)))
    around = np.array([before[max(0, m - w) : m + w + 1].max(axis=0) for m in range(len(before))])
    return (after / np.maximum(around, STILL)).max(axis=0)


def _point_labels(rig: Rig, case: Case) -> list[str]:
    columns = [rig.names.index(case.names[name]) for name in case.names]
    return list(case.names) + [name for name, j, _ in rig.sites if j in columns]


def _steps(before: np.ndarray, after: np.ndarray, frame_time: float) -> tuple[int, int]:
    """(matched, total) resting runs of `before` (N, K) found again in `after` (module notes)."""
    slack = max(1, int(round(STEP_SLACK / frame_time)))
    matched = total = 0
    for k in range(before.shape[1]):
        found = _runs(after[:, k])
        for a, b in _runs(before[:, k]):
            total += 1
            matched += any(abs(a - c) <= slack and abs(b - d) <= slack for c, d in found)
    return matched, total


def judge(case: Case, capture: Rig, result: Rig, unmet: np.ndarray | None = None, truth: Rig | None = None) -> dict:
    """The module's measures of `result` against `capture` (both of `case`'s rig); `unmet` (N,)
    the frames the cleaner said it did not meet (for listed_misses); `truth`: the capture
    without the errors a case's transform added to its data (Case.truth), where points rest (a
    foot the transform sank 12 mm, or a glitch frame, is not a step), default the capture."""
    truth = capture if truth is None else truth
    names, before, clear = contact_points(case, capture)
    after = contact_points(case, result)[1]
    rest = resting(contact_points(case, truth)[1], clear, truth.frame_time)
    slide_before = _sliding(before, rest)
    slide_after = _sliding(after, rest)
    depth_before, depth_after = deepest(case, capture), deepest(case, result)
    ratios = _peak_ratios(_accelerations(capture, case), _accelerations(result, case), capture.frame_time)
    worst = int(np.argmax(ratios))
    feet = [k for k, name in enumerate(names) if name.endswith(("heel", "toe"))]
    matched, total = _steps(rest[:, feet], resting(after, clear, result.frame_time)[:, feet], capture.frame_time)
    hips = [rig.names.index(case.names["Hips"]) for rig in (capture, result)]
    travel = [
        np.linalg.norm((world_frames(rig)[1][-1, j] - world_frames(rig)[1][0, j])[[0, 2]]) / case.unit
        for rig, j in zip((capture, result), hips)
    ]
    bad = (slide_after[3] > 1.0) | (depth_after * 1000.0 > 2.0)
    listed = bool(unmet is not None and np.all(unmet[bad])) or not bad.any()
    return {
        "resting_points": [names[k] for k in range(len(names)) if rest[:, k].any()],
        "sliding_mm_per_frame": slide_after[0],
        "sliding_point": None if slide_after[1] is None else names[slide_after[1]],
        "sliding_frame": slide_after[2],
        "sliding_capture_mm_per_frame": slide_before[0],
        "depth_mm": float(max(depth_after.max(), 0.0) * 1000.0),
        "depth_frame": int(np.argmax(depth_after)),
        "depth_capture_mm": float(max(depth_before.max(), 0.0) * 1000.0),
        "peak_ratio": float(ratios[worst]),
        "peak_point": _point_labels(capture, case)[worst],
        "travel_m": float(travel[1]),
        "travel_capture_m": float(travel[0]),
        "steps_matched": matched,
        "steps": total,
        "frames_missing_goals": int(bad.sum()),
        "misses_listed": listed,
    }

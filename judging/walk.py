"""A walk made from nothing but geometry, for the clip tests and benchmarks that must run without
the shared clips: the DeepMimic humanoid's rig (judging/cases.CANON, metres, Y up, facing
+X, its right side +Z) walking on the floor at height 0 with feet that never slide.

Each foot is flat and still on the floor through its stance (STANCE of the cycle) and swings
forward along a smooth arc (SWING_HEIGHT high) between; the pelvis moves forward at the mean
speed of the feet, bobbing a little; each leg's hip, knee and ankle angles come from two-link
inverse kinematics in the plane of the walk, so the soles stay flat; the arms swing against the
legs. So the ground truth is known: the resting feet slide 0 mm, nothing goes under the floor.
"""

from __future__ import annotations

import numpy as np

from judging.cases import CANON, Case
from judging.rigs import Rig

ROTATIONS = ("Zrotation", "Xrotation", "Yrotation")
OFFSETS = {  # the shared humanoid's bones, metres
    "Hips": (0, 0, 0), "RightHip": (0, 0, 0.084887), "RightKnee": (0, -0.421546, 0),
    "RightAnkle": (0, -0.40987, 0), "LeftHip": (0, 0, -0.084887), "LeftKnee": (0, -0.421546, 0),
    "LeftAnkle": (0, -0.40987, 0), "Chest": (0, 0.236151, 0), "Neck": (0, 0.223894, 0),
    "RightShoulder": (-0.02405, 0.2435, 0.18311), "RightElbow": (0, -0.274788, 0),
    "LeftShoulder": (-0.02405, 0.2435, -0.18311), "LeftElbow": (0, -0.274788, 0),
}  # fmt: skip
PARENTS = {"RightHip": "Hips", "RightKnee": "RightHip", "RightAnkle": "RightKnee", "LeftHip": "Hips",
           "LeftKnee": "LeftHip", "LeftAnkle": "LeftKnee", "Chest": "Hips", "Neck": "Chest",
           "RightShoulder": "Chest", "RightElbow": "RightShoulder", "LeftShoulder": "Chest",
           "LeftElbow": "LeftShoulder"}  # fmt: skip
SITES = (("RightAnkle", (0.1335, -0.05, 0)), ("LeftAnkle", (0.1335, -0.05, 0)), ("Neck", (0, 0.175, 0)),
         ("RightElbow", (0, -0.258947, 0)), ("LeftElbow", (0, -0.258947, 0)))  # fmt: skip
PERIOD, STEP, STANCE, SWING_HEIGHT = 1.1, 0.38, 0.62, 0.09  # s, m per step, share of the cycle, m
ANKLE_HEIGHT = 0.05  # the sole lies this far under the ankle joint


def _swing(phase: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(forward share 0..1, lift share 0..1) of a foot over its swing, phase 0..1 of it."""
    return phase - np.sin(2 * np.pi * phase) / (2 * np.pi), np.sin(np.pi * phase) ** 2


def _ankle_paths(t: np.ndarray) -> dict:
    """{side: (x (N,), height (N,))} of each ankle joint at times t (s)."""
    out = {}
    for side, lag in (("Right", 0.0), ("Left", 0.5)):
        cycle = t / PERIOD + lag
        k, phase = np.floor(cycle), cycle - np.floor(cycle)
        swinging = phase >= STANCE
        forward, lift = _swing(np.clip((phase - STANCE) / (1 - STANCE), 0, 1))
        x = 2 * STEP * (k + np.where(swinging, forward, 0.0)) - lag * 2 * STEP
        out[side] = (x, ANKLE_HEIGHT + np.where(swinging, SWING_HEIGHT * lift, 0.0))
    return out


def _leg_angles(hip: np.ndarray, ankle: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(hip, knee, ankle) flexion about Z, degrees, that put the ankle at `ankle` (N, 2: x, height)
    from a hip at `hip` (N, 2) with the sole flat."""
    thigh, shin = -OFFSETS["RightKnee"][1], -OFFSETS["RightAnkle"][1]
    dx, dy = ankle[:, 0] - hip[:, 0], ankle[:, 1] - hip[:, 1]
    reach = np.minimum(np.hypot(dx, dy), 0.999 * (thigh + shin))
    bend = np.arccos(np.clip((thigh**2 + shin**2 - reach**2) / (2 * thigh * shin), -1, 1))
    knee = -(np.pi - bend)
    hip_angle = np.arctan2(dx, -dy) + np.arccos(np.clip((thigh**2 + reach**2 - shin**2) / (2 * thigh * reach), -1, 1))
    return np.degrees(hip_angle), np.degrees(knee), np.degrees(-(hip_angle + knee))


def procedural_walk(seconds: float = 2.2, fps: float = 30.0) -> Case:
    """The walk of the module notes as a Case (the DeepMimic rig's canonical names)."""
    t = np.arange(int(round(seconds * fps))) / fps
    ankles = _ankle_paths(t)
    pelvis_x = np.mean([ankles[side][0] for side in ankles], axis=0) + 0.03
    pelvis_y = 0.76 + 0.01 * np.cos(4 * np.pi * t / PERIOD)
    names = CANON
    columns = {name: np.zeros((len(t), 3)) for name in names}  # Z, X, Y rotation per joint
    for side in ("Right", "Left"):
        hip = np.stack([pelvis_x, pelvis_y], axis=1)
        angles = _leg_angles(hip, np.stack(ankles[side], axis=1))
        for joint, angle in zip((f"{side}Hip", f"{side}Knee", f"{side}Ankle"), angles):
            columns[joint][:, 0] = angle
    arm = 18.0 * np.sin(2 * np.pi * t / PERIOD)
    columns["RightShoulder"][:, 0], columns["LeftShoulder"][:, 0] = arm, -arm
    columns["RightElbow"][:, 0] = columns["LeftElbow"][:, 0] = 12.0
    root = np.stack([pelvis_x, pelvis_y, np.zeros_like(t)], axis=1)
    frames = np.concatenate([root] + [columns[name] for name in names], axis=1)
    channels = (("Xposition", "Yposition", "Zposition") + ROTATIONS,) + (ROTATIONS,) * (len(names) - 1)
    rig = Rig(
        tuple(names),
        tuple(names.index(PARENTS[name]) if name in PARENTS else -1 for name in names),
        np.array([OFFSETS[name] for name in names], float),
        channels,
        tuple((f"{joint}_end", names.index(joint), np.array(offset, float)) for joint, offset in SITES),
        frames,
        1.0 / fps,
    )
    return Case("procedural_walk", rig, {name: name for name in names}, 1.0, dict.fromkeys(names, 1.0), "procedural")

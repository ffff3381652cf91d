"""Euler channels that stay continuous: among the Euler values of one rotation, the nearest.

A joint's rotation DOFs (radians, about signed coordinate axes) describe the same rotation when
- any of them moves by whole turns (2 pi);
- a Tait-Bryan triple (three rotations about perpendicular axes, intrinsic, in DOF order)
  (a, b, c) becomes (a + pi, pi - b, c + pi);
- at gimbal lock (the middle rotation turns the last axis onto the first, |cos b| below
  LOCK), a and c trade: (a + s t, b, c - t) for any t, s = +-1 by the axes.
`continuous_angles` re-expresses solved poses nearest the frames they replace;
`continuous_frames` re-expresses every frame nearest the frame before it, so that no channel
jumps by a turn or flips where the motion itself is smooth; `canonical_frames` also writes the
first frame nearest 0, so that one motion reads the same whatever values its file chose.
"""

from __future__ import annotations

import math

import numpy as np

from deik.model.joints import ROTATE
from deik.model.rotations import axis_angle_matrix
from deik.model.skeleton import Skeleton

TWO_PI = 2.0 * math.pi
AXIS_TOLERANCE = 1e-9
LIMIT_SLACK = 1e-9  # radians: a value this far past a limit is on it
LOCK = 1e-9  # |cos b| below which a triple is at gimbal lock: trading a and c moves no point by more


def nearest_turn(angles: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """`angles` shifted by whole turns (2 pi) to lie nearest `reference`, elementwise."""
    return angles + TWO_PI * np.round((reference - angles) / TWO_PI)


def tait_bryan_triples(sk: Skeleton) -> list[np.ndarray]:
    """DOF indices (3,) of each joint with exactly three rotations about perpendicular axes."""
    triples = []
    for k in range(sk.n_joints):
        own = np.arange(sk.joint_dof_start[k], sk.joint_dof_start[k + 1])
        rotations = own[sk.dof_kind[own] == ROTATE]
        if len(rotations) == 3:
            axes = sk.dof_axis[rotations]
            if np.allclose(axes @ axes.T, np.eye(3), atol=AXIS_TOLERANCE):
                triples.append(rotations)
    return triples


def _nearest_triple(angles: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(N, 3) each triple of `angles` (N, 3) or its flipped twin (a + pi, pi - b, c + pi),
    turned by whole turns, whichever lies nearer `reference` (N, 3) (sum of squares)."""
    flipped = angles + math.pi
    flipped[:, 1] = math.pi - angles[:, 1]
    direct, flipped = nearest_turn(angles, reference), nearest_turn(flipped, reference)
    closer = ((flipped - reference) ** 2).sum(1) < ((direct - reference) ** 2).sum(1)
    return np.where(closer[:, None], flipped, direct)


def continuous_angles(sk: Skeleton, new: np.ndarray, old: np.ndarray) -> np.ndarray:
    """`new` poses (N, D) re-expressed nearest `old` (N, D) without changing any rotation.

    Each rotation DOF moves by whole turns; each Tait-Bryan triple (a, b, c) may also become
    (a + pi, pi - b, c + pi), the same rotation, when that lies nearer (sum of squares) to old.
    """
    out = np.array(new, dtype=np.float64)
    rotation = sk.dof_kind == ROTATE
    out[:, rotation] = nearest_turn(out[:, rotation], old[:, rotation])
    for triple in tait_bryan_triples(sk):
        out[:, triple] = _nearest_triple(np.array(new[:, triple], dtype=np.float64), old[:, triple])
    return out


def _lock_sign(axes: np.ndarray, b: float) -> float:
    """s in (a + s t, b, c - t) for a triple about `axes` (3, 3) whose middle angle b locks it:
    the middle rotation carries the last axis onto s times the first."""
    return float(np.sign((axis_angle_matrix(axes[1], b) @ axes[2]) @ axes[0]))


def _rotation_groups(sk: Skeleton) -> tuple[np.ndarray, np.ndarray]:
    """(the Tait-Bryan triples (T, 3) of DOF indices, (D,) bool the other rotation DOFs)."""
    triples = np.array(tait_bryan_triples(sk), dtype=np.intp).reshape(-1, 3)
    single = sk.dof_kind == ROTATE
    single[triples.ravel()] = False
    return triples, single


def canonical_frames(sk: Skeleton, frames: np.ndarray) -> np.ndarray:
    """`frames` (N, D) written one way whatever whole turns or Euler twins a file used: the first
    frame's rotations nearest 0 (each triple or its twin, by whole turns) where that lies within
    `sk`'s limits or the values as written do not, every later frame nearest the one before it
    (continuous_frames); no rotation changes. A table of limits measured from the file's own
    values (`deik limits`) thus still holds its first frame."""
    out = np.array(frames, dtype=np.float64)
    if not len(out):
        return out
    triples, single = _rotation_groups(sk)
    first = out[0].copy()
    out[0, single] = nearest_turn(out[0, single], 0.0)
    out[0, triples] = _nearest_triple(out[0, triples], np.zeros(triples.shape))
    written, chosen = ((pose >= sk.lower - LIMIT_SLACK) & (pose <= sk.upper + LIMIT_SLACK) for pose in (first, out[0]))
    kept = written & ~chosen
    kept[triples] = written[triples].all(axis=1, keepdims=True) & ~chosen[triples].all(axis=1, keepdims=True)
    out[0, kept] = first[kept]
    rotation = sk.dof_kind == ROTATE
    steps = np.abs(np.diff(out[:, rotation], axis=0))
    if (steps < 0.25 * math.pi).all() and not (np.abs(np.cos(out[:, triples[:, 1]])) < LOCK).any():
        return out  # no channel steps by a turn or a twin's half turn, none locks: every frame is its nearest
    return continuous_frames(sk, out)


def continuous_frames(sk: Skeleton, frames: np.ndarray) -> np.ndarray:
    """`frames` (N, D) with every frame after the first re-expressed nearest the one before
    it (see the module notes; the first frame is kept), radians / length units; no rotation
    changes (at gimbal lock by at most LOCK radians times the trade)."""
    out = np.array(frames, dtype=np.float64)
    triples, single = _rotation_groups(sk)
    for n in range(1, len(out)):
        out[n, single] = nearest_turn(out[n, single], out[n - 1, single])
        chosen = _nearest_triple(out[n, triples], out[n - 1, triples])
        for k in np.flatnonzero(np.abs(np.cos(chosen[:, 1])) < LOCK):
            s = _lock_sign(sk.dof_axis[triples[k]], chosen[k, 1])
            (a, pa), (c, pc) = (chosen[k, 0], out[n - 1, triples[k, 0]]), (chosen[k, 2], out[n - 1, triples[k, 2]])
            t = 0.5 * ((c - pc) - s * (a - pa))
            chosen[k, 0], chosen[k, 2] = a + s * t, c - t
        out[n, triples] = chosen
    return out

"""Joint values a robot can play: each frame written as the same pose nearest the frame before.

One rotation has many joint values (io/euler.py): a rotation DOF moved by whole turns, and a
Tait-Bryan triple (three rotations about perpendicular axes: a URDF ball joint's Z/X/Y hinge
chain, a BVH joint's Euler channels) (a, b, c) written as its twin (a + pi, pi - b, c + pi).
Solving frames one by one picks any of them, so a trajectory written as solved can jump by a
turn, or by pi on three DOFs at once, between two frames where the robot barely moves: a
controller reading it swings the joint all the way round. `continuous_within_limits` writes
every frame as the values nearest (sum of squares) the frame before among those within the
limits; a rotation free over a whole turn (a continuous joint, a floating root) is unwrapped
(it may leave [-pi, pi]: the same angle, and no limit violation). The first frame is written
within the limits nearest its values as solved.
"""

from __future__ import annotations

import math

import numpy as np

from deik.io.euler import nearest_turn, tait_bryan_triples
from deik.model.joints import ROTATE
from deik.model.skeleton import Skeleton

TWO_PI = 2.0 * math.pi
SLACK = 1e-9  # radians: rounding at a limit is within it


def _into_limits(values: np.ndarray, reference: np.ndarray, lower: np.ndarray, upper: np.ndarray, free: np.ndarray):
    """(values moved by whole turns nearest `reference` within [lower, upper] where one such
    exists, whether each ended within) for (..., k) arrays; `free` (k,) turns are unwrapped."""
    near = nearest_turn(values, reference)
    inside = (near >= lower - SLACK) & (near <= upper + SLACK)
    for shift in (-TWO_PI, TWO_PI):  # the nearest may lie just outside while a neighbour is within
        other = near + shift
        fits = ~inside & (other >= lower - SLACK) & (other <= upper + SLACK)
        near, inside = np.where(fits, other, near), inside | fits
    return np.where(free, nearest_turn(values, reference), near), inside | free


def _single_rotation(skeleton: Skeleton, k: int) -> int | None:
    """The DOF of joint `k` when it has exactly one, a rotation, else None."""
    start, stop = skeleton.joint_dof_start[k], skeleton.joint_dof_start[k + 1]
    return int(start) if stop - start == 1 and skeleton.dof_kind[start] == ROTATE else None


def rotation_triples(skeleton: Skeleton) -> list[np.ndarray]:
    """DOF indices (3,) of every Tait-Bryan triple: a joint's three rotations about
    perpendicular axes (io.euler.tait_bryan_triples), and a chain of three one-rotation joints
    at one point (a URDF ball joint as Z/X/Y hinges through two massless links) whose axes,
    carried into the first joint's frame, are perpendicular."""
    triples = list(tait_bryan_triples(skeleton))
    children = {k: [c for c in range(skeleton.n_joints) if skeleton.parents[c] == k] for k in range(skeleton.n_joints)}
    for first in range(skeleton.n_joints):
        chain, turn, axes = [first], np.eye(3), []
        while len(chain) < 3 and len(children[chain[-1]]) == 1:
            child = children[chain[-1]][0]
            if np.abs(skeleton.offsets[child]).max() > 0:
                break
            chain.append(child)
        dofs = [_single_rotation(skeleton, k) for k in chain]
        if len(chain) < 3 or None in dofs:
            continue
        for k, d in zip(chain, dofs):
            turn = turn @ (skeleton.joint_rotation[k] if k != first else np.eye(3))
            axes.append(turn @ skeleton.dof_axis[d])
        axes = np.array(axes)
        if np.allclose(axes @ axes.T, np.eye(3), atol=1e-9):
            triples.append(np.array(dofs))
    return triples


def continuous_within_limits(skeleton: Skeleton, frames: np.ndarray) -> np.ndarray:
    """`frames` (N, D) with each frame re-expressed as the same pose nearest the one before
    within the limits (module notes); values radians / length units. A frame with no such
    values keeps its own."""
    out = np.array(frames, dtype=np.float64)
    if not len(out):
        return out
    rotation = skeleton.dof_kind == ROTATE
    free = rotation & (skeleton.upper - skeleton.lower >= TWO_PI)
    triples = np.array(rotation_triples(skeleton), dtype=np.intp).reshape(-1, 3)
    single = np.flatnonzero(rotation & ~np.isin(np.arange(skeleton.n_dofs), triples))
    lower, upper = skeleton.lower, skeleton.upper
    previous = out[0].copy()  # the first frame: nearest its own values
    for n in range(len(out)):
        row = out[n]
        row[single] = _into_limits(row[single], previous[single], lower[single], upper[single], free[single])[0]
        if len(triples):
            direct = row[triples]
            twin = direct + math.pi
            twin[:, 1] = math.pi - direct[:, 1]
            box = (previous[triples], lower[triples], upper[triples], free[triples])
            (a, a_in), (b, b_in) = _into_limits(direct, *box), _into_limits(twin, *box)
            a_ok, b_ok = a_in.all(axis=1), b_in.all(axis=1)
            a_far = ((a - previous[triples]) ** 2).sum(axis=1)
            b_far = ((b - previous[triples]) ** 2).sum(axis=1)
            take_twin = (b_ok & ~a_ok) | ((b_ok == a_ok) & (b_far < a_far))
            row[triples] = np.where(take_twin[:, None], b, a)
        previous = row
    return out

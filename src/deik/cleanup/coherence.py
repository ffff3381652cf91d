"""Which DOFs each frame's DE repair may move, and smooth easing of displacements over time.

A frame's DE repair only moves the DOFs that can reach one of its goals (the chain from the root
to each site in contact or reaching, every DOF for balance, the chains of the points near the
floor); the others take the change a repair made eased in from the neighbouring frames, so nothing pops
where a repair starts or stops and no search noise reaches joints no goal needs (an idle arm).
(The warm start, cleanup/warmstart.py, needs no such mask: a DOF no goal row moves stays put.)

Easing: per DOF, the displacements x (N,) the searches found are kept where a search moved
the DOF; elsewhere x minimises, over L frames (a length),
    sum_n  x[n]^2 / L^4  +  2 (x[n+1] - x[n])^2 / L^2  +  (x[n+2] - 2 x[n+1] + x[n])^2,
a critically damped spring (cleanup/spacetime.py): a correction goes on at the rate it had where
its goal let go, then fades back to the original over about L frames, with no kink in value or
rate.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from deik.cleanup.banded import solve_spd_band
from deik.cleanup.spacetime import spring_bands
from deik.io.motion import held_translations
from deik.io.trajectory import Motion
from deik.model.capsules import STILL_TURN, body_reach
from deik.model.joints import ROTATE, TRANSLATE
from deik.model.skeleton import Skeleton
from deik.objectives.goals import Comfort, Floor, Goal, Position

NEAR_FLOOR = 0.03  # of reach: points this close above the floor may be pushed through it by a fix


def moving_dofs(skeleton: Skeleton, name: str) -> np.ndarray:
    """(D,) bool: the free DOFs that move joint or site `name` (its ancestors' DOFs, and a
    joint's own translations; mimic DOFs count through their source). KeyError if unknown."""
    f = skeleton.frame_index(name)
    m = skeleton.motions
    out = np.zeros(skeleton.n_dofs, bool)
    if f < skeleton.n_joints:
        own = slice(m.joint_start[f], m.joint_start[f + 1])
        out[m.source[own][m.kind[own] == TRANSLATE]] = True
        joint = int(skeleton.parents[f])
    else:
        joint = int(skeleton.site_joint[f - skeleton.n_joints])
    while joint >= 0:
        out[m.source[m.joint_start[joint] : m.joint_start[joint + 1]]] = True
        joint = int(skeleton.parents[joint])
    return out


def hinge_channels(clip: Motion) -> np.ndarray:
    """(D,) bool: the rotation DOFs the fix keeps as captured. Those that stay exactly 0 in every
    frame while another DOF of their joint moves (the X and Y channels of a knee that bends about
    Z): the performance uses the joint as a hinge, so the fix keeps it one. And every rotation of
    a joint below the root that the capture never turns, to within STILL_TURN on each channel
    (its noise), while other joints move (a toe, a finger, a wrist the performance leaves
    still): turning it would add an articulation the performance never had (a toe bent to
    stand on while the capture's foot lands flat; a shaken toe bent 80 degrees). A
    translation that stays 0 is no hinge: a root on the ground (a `Reference` joint at height
    0, a walk along one axis) must still lift or shift the body it carries."""
    sk = clip.skeleton
    frames = clip.frames
    rotate = sk.dof_kind == ROTATE
    zero = (frames == 0.0).all(axis=0)
    span = np.ptp(frames, axis=0) if len(frames) else np.zeros(sk.n_dofs)
    moving = span > 0
    joint_moves = np.zeros(sk.n_joints, bool)
    np.logical_or.at(joint_moves, sk.dof_joint, moving)
    turned = np.zeros(sk.n_joints, bool)
    np.logical_or.at(turned, sk.dof_joint, (span > STILL_TURN) & rotate)  # a toe the capture's noise shakes is still
    still = ~turned[sk.dof_joint] & (sk.parents[sk.dof_joint] >= 0) & turned.any()
    return (zero & joint_moves[sk.dof_joint] | still) & rotate


def active_frames(goal: Goal, n_frames: int) -> np.ndarray:
    """(N,) bool: the frames where deik goal `goal` applies (its `active` mask; all if None)."""
    return np.broadcast_to(np.asarray(True if goal.active is None else goal.active, bool), (n_frames,))


def near_floor(clip: Motion, height: float, clearance: np.ndarray | None = None) -> np.ndarray:
    """(N, F) bool: the joints and sites within NEAR_FLOOR x reach of the floor at `height`
    plus their `clearance` (F,) (default 0; NaN: never) in the frame or a neighbouring one:
    those a search may have to lift."""
    sk = clip.skeleton
    level = height + (0.0 if clearance is None else np.nan_to_num(clearance, nan=-np.inf))
    near = clip.kinematics.p_world_frame @ sk.up <= level + NEAR_FLOOR * body_reach(sk)
    out = near.copy()
    out[1:] |= near[:-1]
    out[:-1] |= near[1:]
    return out


def searched_dofs(clip: Motion, goals: Iterable[Goal]) -> np.ndarray:
    """(N, D) bool: the DOFs each frame's search may move for the `goals` (deik goal objects)
    that hold sites (all but Comfort): a Position goal moves its frame's chain, a Floor the
    chains of the points near it (near_floor), any other goal (the centre of mass over the
    support) every DOF, in the frames where it is active; hinge_channels and the translations
    the clip holds (deik.io.motion.held_translations) never move."""
    sk = clip.skeleton
    out = np.zeros((clip.n_frames, sk.n_dofs), bool)
    for goal in goals:
        if isinstance(goal, Comfort):
            continue
        if isinstance(goal, Floor):
            near = near_floor(clip, goal.height, goal.clearance)
            chains = np.array([moving_dofs(sk, name) for name in sk.frame_names])
            out |= (near[:, :, None] & chains[None]).any(axis=1)
            continue
        chain = moving_dofs(sk, goal.frame) if isinstance(goal, Position) else True
        out |= active_frames(goal, clip.n_frames)[:, None] & chain
    return out & ~(hinge_channels(clip) | held_translations(clip.skeleton, clip.frames))[None, :]


def _solve_bands(a0, a1, a2, rhs):
    """Solve symmetric positive definite pentadiagonal systems, one per column: diagonal a0
    (N, ...), first off-diagonal a1 (N-1, ...), second a2 (N-2, ...), rhs (N, ...); as one
    banded system (cleanup/banded.py), the columns one after another (they do not couple)."""
    shape = rhs.shape
    a0, a1, a2, rhs = (np.reshape(v, (len(v), -1)) for v in (a0, a1, a2, rhs))
    N, C = a0.shape
    upper = np.zeros((C, N, 3))
    upper[:, :, 0] = a0.T
    upper[:, :-1, 1] = a1.T
    upper[:, :-2, 2] = a2.T
    return solve_spd_band(upper.reshape(C * N, 3), rhs.T.reshape(C * N)).reshape(C, N).T.reshape(shape)


def ease(values: np.ndarray, known: np.ndarray, length: float) -> np.ndarray:
    """(N, D) displacements: `values` (N, D) where `known` (N, D) is True, and elsewhere the
    smoothest continuation (see the module notes: the spring energy of cleanup/spacetime.py), a
    correction fading like a critically damped spring over `length` > 0 frames, continuous in
    value and rate with the known ones."""
    y = np.asarray(values, float)
    known = np.broadcast_to(np.asarray(known, bool), y.shape)
    N = len(y)
    if known.all():
        return y.copy()
    if N < 3:  # too short for a rate: what no goal holds stays as in the original
        return np.where(known, y, 0.0)
    shape = (1,) * (y.ndim - 1)
    a0, a1, a2 = (np.broadcast_to(b.reshape(b.shape + shape), (len(b),) + y.shape[1:]) for b in spring_bands(N, length))
    # known entries: move their terms to the right-hand side, keep the system symmetric
    fixed = np.where(known, y, 0.0)
    rhs = np.zeros_like(y)
    rhs[:-1] -= a1 * fixed[1:]
    rhs[1:] -= a1 * fixed[:-1]
    rhs[:-2] -= a2 * fixed[2:]
    rhs[2:] -= a2 * fixed[:-2]
    a1 = np.where(known[:-1] | known[1:], 0.0, a1)
    a2 = np.where(known[:-2] | known[2:], 0.0, a2)
    a0 = np.where(known, 1.0, a0)
    rhs = np.where(known, y, rhs)
    return _solve_bands(a0, a1, a2, rhs)

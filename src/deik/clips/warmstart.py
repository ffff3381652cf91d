"""A damped least-squares warm start for a clip fix, before DE repairs what it leaves unmet.

Each frame's level-0 position goals (planted contacts, reach tracks) are met as nearly as
possible by the smallest change of the DOFs that frame may move (coherence.searched_dofs),
each DOF counted by dof_weights as the fidelity term counts it, in a few damped Gauss-Newton
steps on the positions' Jacobian (the kernels' analytic one: each DOF turns about or slides
along its world axis). Balance goals add two rows, the centre of mass's horizontal Jacobian,
steering it along a track over the support (balance.py). A few more steps each start from
the mean of the neighbouring frames' displacements, so frames agree where the goals in force
change (a foot lifts, a reach begins). The clip's corrections are small (millimetres to
centimetres), so this is cheap, smooth in time and exact to microns. Goals that cannot all be
met are left to DE, with its priorities and tolerances.
"""

from __future__ import annotations

import numpy as np

from deik.clips.balance import balance_track, horizontal_axes
from deik.clips.coherence import active_frames
from deik.clips.problem import neighbour_displacement
from deik.kernels.cpu_backend import point_jacobians
from deik.kernels.pack import pack_skeleton
from deik.model.joints import ROTATE
from deik.model.kinematics import forward_kinematics
from deik.objectives.goals import ComInPolygon, Position

DAMPING = 1e-3  # radians (weighted DOF units): keeps a step finite at a straight knee
STEPS = 2
SMOOTHING = 6
LONGEST_STEP = 0.1  # of reach: how far one step moves a goal's site towards its target


def position_jacobian(skeleton, poses, names, centre_of_mass: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """World positions (N, G, 3) of the joints or sites `names` (then of the centre of mass if
    `centre_of_mass`) at `poses` (N, D), and their Jacobian (N, G, 3, D): length units per
    radian (rotations) or per length unit. The kernels' float64 FK and analytic rows compute
    both (deik.kernels.cpu_backend.point_jacobians)."""
    frames = [skeleton.frame_index(name) for name in names] + [-1] * centre_of_mass
    return point_jacobians(np.atleast_2d(np.asarray(poses, np.float64)), frames, pack_skeleton(skeleton, np.float64))


def dof_weights(clip) -> np.ndarray:
    """(D,) what a unit change of each DOF costs: 1 per radian, and per length unit of a
    translation 1 / r, r the root-mean-square distance of the joints and sites from the root
    over the clip: moving the root counts like the root turn that moves the body as much. With
    1 per length unit too (metres as radians), lifting the whole body would be the cheap way to
    move a hand."""
    sk = clip.skeleton
    p = forward_kinematics(sk, clip.poses()).p_world_frame
    r = np.sqrt(((p - p[:, :1]) ** 2).sum(axis=-1).mean())
    return np.where(sk.dof_kind == ROTATE, 1.0, 1.0 / r if r > 0 else 1.0)


def warm_start(
    skeleton,
    original: np.ndarray,
    goals,
    searched: np.ndarray,
    weights: np.ndarray,
    steps: int = STEPS,
    smoothing: int = SMOOTHING,
) -> np.ndarray:
    """(N, D) displacement from the `original` poses (N, D) that meets the level-0 Position
    goals active in each frame and brings the centre of mass over the support of its level-0
    ComInPolygon goals (clips/balance.py), moving only the `searched` (N, D) DOFs, each change
    counted by `weights` (D,) (dof_weights). `steps` Gauss-Newton steps from the original,
    then `smoothing` more, each from the mean of the neighbouring frames' displacements, so
    that frames agree where the goals in force change; a step moves a site or the COM at most
    LONGEST_STEP x reach, so an unreachable target is approached, not chased. Zero where no
    goal needs a DOF; limits are not applied here (fix_clip does)."""
    held = [goal for goal in goals if isinstance(goal, Position) and goal.level == 0]
    balance = [goal for goal in goals if isinstance(goal, ComInPolygon) and goal.level == 0]
    N, D = original.shape
    d = np.zeros((N, D))
    if not held and not balance:
        return d
    H = len(held)
    sites = sorted({site for goal in balance for site in goal.frames} - {goal.frame for goal in held})
    names = [goal.frame for goal in held] + sites
    targets = np.array([np.broadcast_to(np.asarray(goal.target, float), (N, 3)) for goal in held]).reshape(H, N, 3)
    targets = targets.transpose(1, 0, 2)  # (N, H, 3)
    active = np.array([active_frames(goal, N) for goal in held]).reshape(H, N).T
    supports = [
        (np.array([names.index(site) for site in goal.frames]), active_frames(goal, N), 0.5 * (goal.tolerance or 0.0))
        for goal in balance
    ]
    ground = horizontal_axes(skeleton)
    rows = 3 * H + 2 * bool(balance)
    damping = DAMPING**2 * np.eye(rows)
    inverse = np.where(weights > 0, 1.0 / np.where(weights > 0, weights, 1.0), 0.0)
    longest = LONGEST_STEP * skeleton.reach
    for k in range(steps + smoothing):
        if k >= steps:
            d = np.where(searched, neighbour_displacement(d), 0.0)
        x, jac = position_jacobian(skeleton, original + d, names, centre_of_mass=bool(balance))
        error = _at_most(np.where(active[..., None], targets - x[:, :H], 0.0), longest)
        errors, parts = [error.reshape(N, 3 * H)], [(jac[:, :H] * active[:, :, None, None]).reshape(N, 3 * H, D)]
        if balance:
            com = x[:, -1] @ ground.T
            if k == 0:
                track, steered = balance_track(com, [(x[:, f] @ ground.T, on, m) for f, on, m in supports])
            errors.append(np.where(steered[:, None], _at_most(track - com, longest), 0.0))
            parts.append(np.einsum("ij,njd->nid", ground, jac[:, -1]) * steered[:, None, None])
        B = np.concatenate(parts, axis=1) * (searched * inverse)[:, None, :]
        multipliers = np.linalg.solve(B @ B.transpose(0, 2, 1) + damping, np.concatenate(errors, axis=1)[..., None])
        d += (B.transpose(0, 2, 1) @ multipliers)[..., 0] * inverse
    return d


def _at_most(vectors: np.ndarray, longest: float) -> np.ndarray:
    """vectors (..., k), each cut to a length of at most `longest`."""
    length = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors * np.minimum(1.0, longest / np.maximum(length, longest))

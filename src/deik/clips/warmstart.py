"""A damped least-squares warm start for a clip fix, before DE repairs what it leaves unmet.

Each frame's level-0 position goals (planted contacts, reach tracks) are met as nearly as
possible by the smallest change of the DOFs that frame may move (coherence.searched_dofs),
each DOF counted by dof_weights as the fidelity term counts it, in a few damped Gauss-Newton
steps on the positions' Jacobian (the kernels' analytic one: each DOF turns about or slides
along its world axis). A few more steps each start from the mean of the neighbouring frames'
displacements, so frames agree where the goals in force change (a foot lifts, a reach
begins). The clip's corrections are small (millimetres to centimetres), so this is cheap,
smooth in time and exact to microns. The centre of mass (balance) and goals that cannot all be met are left to
DE, with its priorities and tolerances.
"""

from __future__ import annotations

import numpy as np

from deik.clips.coherence import active_frames
from deik.clips.problem import neighbour_displacement
from deik.joints import ROTATE
from deik.kernels import cpu
from deik.kernels.pack import pack_skeleton
from deik.kinematics import forward_kinematics
from deik.objectives.goals import Position

DAMPING = 1e-3  # radians (weighted DOF units): keeps a step finite at a straight knee
STEPS = 2
SMOOTHING = 6
LONGEST_STEP = 0.1  # of reach: how far one step moves a goal's site towards its target


def position_jacobian(skeleton, poses, names) -> tuple[np.ndarray, np.ndarray]:
    """World positions (N, G, 3) of the joints or sites `names` at `poses` (N, D), and their
    Jacobian (N, G, 3, D): length units per radian (rotations) or per length unit. The kernels'
    float64 FK and analytic rows compute both (deik.kernels.cpu.point_jacobians)."""
    poses = np.ascontiguousarray(np.atleast_2d(np.asarray(poses, np.float64)))
    frames = np.array([skeleton.frame_index(name) for name in names], np.int64)
    x = np.empty((len(poses), len(frames), 3))
    jac = np.empty((len(poses), len(frames), 3, skeleton.n_dofs))
    cpu.point_jacobians(poses, frames, pack_skeleton(skeleton, np.float64), x, jac)
    return x, jac


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


def warm_start(skeleton, original: np.ndarray, goals, searched: np.ndarray, weights: np.ndarray,
               steps: int = STEPS, smoothing: int = SMOOTHING) -> np.ndarray:
    """(N, D) displacement from the `original` poses (N, D) that meets the level-0 Position
    `goals` active in each frame, moving only the `searched` (N, D) DOFs, each change counted
    by `weights` (D,) (dof_weights). `steps` Gauss-Newton steps from the original, then
    `smoothing` more, each from the mean of the neighbouring frames' displacements, so that
    frames agree where the goals in force change; a step moves a site at most LONGEST_STEP x
    reach, so an unreachable target is approached, not chased. Zero where no goal needs a
    DOF; limits are not applied here (fix_clip does)."""
    held = [goal for goal in goals if isinstance(goal, Position) and goal.level == 0]
    N, D = original.shape
    d = np.zeros((N, D))
    if not held:
        return d
    names = [goal.frame for goal in held]
    targets = np.stack([np.broadcast_to(np.asarray(goal.target, float), (N, 3)) for goal in held], axis=1)
    active = np.stack([active_frames(goal, N) for goal in held], axis=1)
    rows = 3 * len(held)
    damping = DAMPING**2 * np.eye(rows)
    inverse = np.where(weights > 0, 1.0 / np.where(weights > 0, weights, 1.0), 0.0)
    for k in range(steps + smoothing):
        if k >= steps:
            d = np.where(searched, neighbour_displacement(d), 0.0)
        x, jac = position_jacobian(skeleton, original + d, names)
        error = np.where(active[..., None], targets - x, 0.0)
        length = np.linalg.norm(error, axis=-1, keepdims=True)
        longest = LONGEST_STEP * skeleton.reach
        error = (error * np.minimum(1.0, longest / np.maximum(length, longest))).reshape(N, rows)
        B = (jac * active[:, :, None, None] * (searched * inverse)[:, None, None, :])
        B = B.reshape(N, rows, D)
        multipliers = np.linalg.solve(B @ B.transpose(0, 2, 1) + damping, error[..., None])
        d += (B.transpose(0, 2, 1) @ multipliers)[..., 0] * inverse
    return d

"""A damped least-squares warm start for a clip fix, before DE repairs what it leaves unmet.

Each frame's contacts, floor and balance goals (clips/problem.py's levels 0 and 1) are met as
nearly as possible by the smallest change of the DOFs that frame may move (coherence.searched_dofs),
each DOF counted by dof_weights as the fidelity term counts it, in a few damped Gauss-Newton
steps on the positions' Jacobian (the kernels' analytic one: each DOF turns about or slides
along its world axis). Balance goals add two rows, the centre of mass's horizontal Jacobian,
steering it along a track over the support (balance.py). A few more steps each start from
the mean of the neighbouring frames' displacements, so frames agree where the goals in force
change (a foot lifts, a reach begins). Reach tracks (level 2) take only the changes that
leave the level-0 rows as they are (their null space), so an unreachable reach never drags a
planted contact. The clip's corrections are small (millimetres to
centimetres), so this is cheap, smooth in time and exact to microns. Goals that cannot all be
met are left to DE, with its priorities and tolerances.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from deik.clips.balance import balance_track, horizontal_axes
from deik.clips.coherence import active_frames
from deik.clips.problem import REACH_LEVEL, neighbour_displacement
from deik.io.trajectory import Motion
from deik.kernels.pack import pack_skeleton
from deik.model.joints import ROTATE
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.objectives.goals import ComInPolygon, Floor, Goal, Position

DAMPING = 1e-3  # radians (weighted DOF units): keeps a step finite at a straight knee
STEPS = 2
SMOOTHING = 6
LONGEST_STEP = 0.1  # of reach: how far one step moves a goal's site towards its target
SETTLE = 2  # last steps without the reach rows: its steps bend the contacts and the floor a little
FLOOR_MARGIN = 1e-4  # length units a point pushed out of the floor ends above it


def position_jacobian(
    skeleton: Skeleton, poses: np.ndarray, names: Sequence[str], centre_of_mass: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """World positions (N, G, 3) of the joints or sites `names` (then of the centre of mass if
    `centre_of_mass`) at `poses` (N, D), and their Jacobian (N, G, 3, D): length units per
    radian (rotations) or per length unit. The kernels' float64 FK and analytic rows compute
    both (deik.kernels.cpu_backend.point_jacobians)."""
    from deik.kernels.cpu_backend import point_jacobians  # loads Numba: `import deik` stays light

    frames = [skeleton.frame_index(name) for name in names] + [-1] * centre_of_mass
    return point_jacobians(np.atleast_2d(np.asarray(poses, np.float64)), frames, pack_skeleton(skeleton, np.float64))


def dof_weights(clip: Motion) -> np.ndarray:
    """(D,) what a unit change of each DOF costs: 1 per radian, and per length unit of a
    translation 1 / r, r the root-mean-square distance of the joints and sites from the root
    over the clip: moving the root counts like the root turn that moves the body as much. With
    1 per length unit too (metres as radians), lifting the whole body would be the cheap way to
    move a hand."""
    sk = clip.skeleton
    p = forward_kinematics(sk, clip.poses()).p_world_frame
    r = np.sqrt(((p - p[:, :1]) ** 2).sum(axis=-1).mean())
    return np.where(sk.dof_kind == ROTATE, 1.0, 1.0 / r if r > 0 else 1.0)


def _rows(goals, N: int, names: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(index (H,) into `names`, targets (N, H, 3), active (N, H)) of Position `goals`."""
    index = np.array([names.index(goal.frame) for goal in goals], int)
    targets = np.array([np.broadcast_to(np.asarray(goal.target, float), (N, 3)) for goal in goals])
    active = np.array([active_frames(goal, N) for goal in goals]).reshape(len(goals), N).T
    return index, targets.reshape(len(goals), N, 3).transpose(1, 0, 2), active


def _position_rows(x, jac, rows, longest: float):
    """(errors (N, 3H), Jacobian rows (N, 3H, D)) of the Position rows (index, targets, active)."""
    index, targets, active = rows
    N, D = jac.shape[0], jac.shape[-1]
    error = _at_most(np.where(active[..., None], targets - x[:, index], 0.0), longest)
    return error.reshape(N, -1), (jac[:, index] * active[:, :, None, None]).reshape(N, -1, D)


def _floor_rows(x, jac, up: np.ndarray, floor: float):
    """(errors (N, F), Jacobian rows (N, F, D)): each joint or site lower than floor + 2
    FLOOR_MARGIN is lifted to floor + FLOOR_MARGIN (the band between holds it there)."""
    height = x @ up
    low = height < floor + 2 * FLOOR_MARGIN
    return np.where(low, floor + FLOOR_MARGIN - height, 0.0), np.einsum("k,nfkd->nfd", up, jac) * low[..., None]


def _solve(B: np.ndarray, error: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(step (N, D), projector (N, D, D)): the damped least-squares step meeting rows B (N, R,
    D) for `error` (N, R), and the projector onto the changes that leave those rows alone."""
    N, R, D = B.shape
    if R == 0:
        return np.zeros((N, D)), np.broadcast_to(np.eye(D), (N, D, D))
    inverse = np.linalg.solve(B @ B.transpose(0, 2, 1) + DAMPING**2 * np.eye(R), np.eye(R))
    pseudo = B.transpose(0, 2, 1) @ inverse
    return (pseudo @ error[..., None])[..., 0], np.eye(D) - pseudo @ B


def warm_start(
    skeleton: Skeleton,
    original: np.ndarray,
    goals: Sequence[Goal],
    searched: np.ndarray,
    weights: np.ndarray,
    steps: int = STEPS,
    smoothing: int = SMOOTHING,
) -> np.ndarray:
    """(N, D) displacement from the `original` poses (N, D) that meets the Position goals
    above REACH_LEVEL active in each frame (contacts), keeps every joint and site above a
    Floor, brings the centre of mass over the support of its ComInPolygon goals
    (clips/balance.py) and then, with what those leave free (their rows' null space), meets
    the Position goals on REACH_LEVEL (reach tracks), moving only the `searched` (N, D) DOFs,
    each change counted by `weights` (D,) (dof_weights). `steps` Gauss-Newton steps from the
    original, then `smoothing` more, each from the mean of the neighbouring frames'
    displacements, so that frames agree where the goals in force change; a step moves a site
    or the COM at most LONGEST_STEP x reach, so an unreachable target is approached, not
    chased. With reach tracks, SETTLE last steps meet the other goals alone again: a reach
    step keeps them only to first order, and only the floor rows of points already low. Zero
    where no goal needs a DOF; limits are not applied here (fix_clip does)."""
    held = [goal for goal in goals if isinstance(goal, Position) and goal.level < REACH_LEVEL]
    reach = [goal for goal in goals if isinstance(goal, Position) and goal.level == REACH_LEVEL]
    balance = [goal for goal in goals if isinstance(goal, ComInPolygon)]
    floors = [goal for goal in goals if isinstance(goal, Floor)]
    N, D = original.shape
    d = np.zeros((N, D))
    if not (held or reach or balance or floors):
        return d
    names = list(skeleton.frame_names) if floors else []
    names += [name for name in dict.fromkeys(goal.frame for goal in held + reach) if name not in names]
    names += sorted({site for goal in balance for site in goal.frames} - set(names))
    held_rows, reach_rows = _rows(held, N, names), _rows(reach, N, names)
    supports = [
        (np.array([names.index(site) for site in goal.frames]), active_frames(goal, N), 0.5 * (goal.tolerance or 0.0))
        for goal in balance
    ]
    ground = horizontal_axes(skeleton)
    up = np.asarray(skeleton.up, float)
    scale = searched * np.where(weights > 0, 1.0 / np.where(weights > 0, weights, 1.0), 0.0)
    longest = LONGEST_STEP * skeleton.reach
    for k in range(steps + smoothing + SETTLE * bool(reach)):
        if steps <= k < steps + smoothing:
            d = np.where(searched, neighbour_displacement(d), 0.0)
        x, jac = position_jacobian(skeleton, original + d, names, centre_of_mass=bool(balance))
        error, rows = _position_rows(x, jac, held_rows, longest)
        errors, parts = [error], [rows]
        for floor in floors:
            error, rows = _floor_rows(x[:, : skeleton.n_frames], jac[:, : skeleton.n_frames], up, floor.height)
            errors.append(_at_most(error[..., None], longest)[..., 0])
            parts.append(rows)
        if balance:
            com = x[:, -1] @ ground.T
            if k == 0:
                track, steered = balance_track(com, [(x[:, f] @ ground.T, on, m) for f, on, m in supports])
            errors.append(np.where(steered[:, None], _at_most(track - com, longest), 0.0))
            parts.append(np.einsum("ij,njd->nid", ground, jac[:, -1]) * steered[:, None, None])
        step, free = _solve(np.concatenate(parts, axis=1) * scale[:, None, :], np.concatenate(errors, axis=1))
        if reach and k < steps + smoothing:
            error, rows = _position_rows(x, jac, reach_rows, longest)
            rows = rows * scale[:, None, :]
            step = step + _solve(rows @ free, error - (rows @ step[..., None])[..., 0])[0]
        d += step * scale
    return d


def _at_most(vectors: np.ndarray, longest: float) -> np.ndarray:
    """vectors (..., k), each cut to a length of at most `longest`."""
    length = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors * np.minimum(1.0, longest / np.maximum(length, longest))

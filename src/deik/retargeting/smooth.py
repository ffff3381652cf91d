"""The space-time pass of a rig retarget: every frame at once, smooth, planted and within limits.

After the per-frame key-point IK (ik.py), one Levenberg-Marquardt least squares over the whole
clip finds the displacement from those poses that
- holds each contact site still at its plant for its whole contact (clips.plants.planted_targets
  of the current motion: a plant is where the site sits on average, on the floor when near it;
  planted again every REPLANT iterations, so plants that the target's limits cannot all meet
  at once move to where it can),
- keeps every joint and site of the body above the floor (clips.warmstart.floor_rows) and the
  body's bone capsules apart (collision.py),
- keeps the key points and orientation points near their targets, counted KEYPOINT_WEIGHT /
  HELD_WEIGHT as much as the rows above, so a point the body cannot reach while its feet stay
  planted is given up first,
- against the spring energy of the displacement (cleanup/spacetime.py: each DOF's stiffness by
  how much of the body it moves, clips.warmstart.motion_stiffness): a correction that a contact
  needs starts before the contact does and fades after it, so the motion keeps the per-frame
  IK's velocities and accelerations instead of jumping where a contact starts or ends.
Each iteration solves the block-banded normal equations (clips.spacetime.spacetime_step) with
the DOFs at a limit that the step pushes outwards held, cuts the step into the limits, and keeps
it only when the whole clip's cost falls (the damping then falls; else it rises and the step is
tried again shorter). Rotations free over a whole turn (a free root's) are unwrapped over the
frames and never cut.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from deik.cleanup.contacts import Contacts
from deik.cleanup.plants import planted_targets
from deik.cleanup.spacetime import spacetime_step, spring_energy
from deik.cleanup.warmstart import FADE, FLOOR_MARGIN, floor_rows, motion_stiffness, position_jacobian
from deik.io.trajectory import Trajectory
from deik.model.skeleton import Skeleton
from deik.retargeting.collision import BonePairs, collision_rows
from deik.retargeting.ik import Targets, full_turns, targets_at

HELD_WEIGHT = 1e7  # contacts, floor and capsules: their squared error in reach units, against the spring
KEYPOINT_WEIGHT = 1e3  # key points: 1e4 met them 1.2-3.9 mm closer (jump, crawl) but slid the jump's feet 2 mm/frame
ITERATIONS = 30
REPLANT = 5  # iterations between plantings
DAMPING = (1e-6, 1.0, 1e8)  # least, first and most damping (weighted DOF units squared)
CAPSULE_MARGIN = 1e-4  # of reach: how far apart a collision row pushes two capsules


def smooth_motion(
    skeleton: Skeleton,
    first: np.ndarray,
    names: Sequence[str],
    targets: Targets,
    contacts: Contacts | None,
    searched: np.ndarray,
    weights: np.ndarray,
    body: Sequence[str],
    pairs: BonePairs,
    frame_time: float,
    floor: float = 0.0,
) -> np.ndarray:
    """(N, D) poses near the per-frame IK's `first` (N, D) that meet the module notes: key
    points `names` (K,) near `targets` (ik.targets_at), the `contacts` (target sites, or None)
    planted, every frame of `body` above the `floor` (height along up) and the capsules of
    `pairs` (collision.body_pairs) apart,
    moving only the `searched` DOFs (broadcast to (N, D)), each change counted by `weights`
    (D,) (dof_weights); `frame_time` seconds. Rotations free over a whole turn come out
    unwrapped (continuous over the frames)."""
    N, D = first.shape
    full_turn = full_turns(skeleton)
    base = np.array(first, float)
    base[:, full_turn] = np.unwrap(base[:, full_turn], axis=0)
    lower = np.where(full_turn, -np.inf, skeleton.lower)
    upper = np.where(full_turn, np.inf, skeleton.upper)
    frames = list(skeleton.frame_names)
    points = [frames.index(name) for name in names]
    floor_points = [frames.index(name) for name in body]
    sites = [] if contacts is None else [frames.index(name) for name in contacts.sites]
    mask = np.zeros((N, 0), bool) if contacts is None else contacts.mask
    scale = np.where(weights > 0, 1.0 / np.where(weights > 0, weights, 1.0), 0.0)
    stiffness = motion_stiffness(skeleton, base, weights)
    movable = np.broadcast_to(np.asarray(searched, bool), (N, D))
    reach2 = skeleton.reach**2

    def plants_at(q):
        if contacts is None:
            return np.zeros((N, 0, 3))
        return planted_targets(Trajectory(skeleton, q, frame_time), contacts)

    def measured(q, plants):
        """(cost, errors (N, R), rows (N, R, D) per weighted DOF unit, row weights (N, R))."""
        x, jac = position_jacobian(skeleton, q, frames)
        held_errors = [np.where(mask[..., None], plants - x[:, sites], 0.0).reshape(N, -1)]
        held_rows = [(jac[:, sites] * mask[:, :, None, None]).reshape(N, -1, D)]
        error, rows = floor_rows(
            x[:, floor_points], jac[:, floor_points], skeleton.up, floor, FLOOR_MARGIN * skeleton.reach
        )
        held_errors.append(error)
        held_rows.append(rows)
        error, rows = collision_rows(x, jac, pairs, CAPSULE_MARGIN * skeleton.reach)
        held_errors.append(error)
        held_rows.append(rows)
        held = np.concatenate(held_errors, axis=1)
        key = (targets_at(targets, q, np.arange(N)) - x[:, points]).reshape(N, -1)
        errors = np.concatenate([held, key], axis=1)
        rows = np.concatenate(held_rows + [jac[:, points].reshape(N, -1, D)], axis=1) * scale
        row_weights = np.concatenate([np.full(held.shape, HELD_WEIGHT), np.full(key.shape, KEYPOINT_WEIGHT)], axis=1)
        row_weights = row_weights / reach2
        cost = (row_weights * errors**2).sum() + spring_energy((q - base) * weights, FADE, stiffness)
        return cost, errors, rows, row_weights

    q = base.copy()
    plants = plants_at(q)
    cost, errors, rows, row_weights = measured(q, plants)
    damping = DAMPING[1]
    for k in range(ITERATIONS):
        if k and k % REPLANT == 0 and contacts is not None:
            plants = plants_at(q)
            cost, errors, rows, row_weights = measured(q, plants)
        x = (q - base) * weights
        step = spacetime_step(rows, errors, row_weights, x, movable, FADE, damping, stiffness) * scale
        held = ((q <= lower) & (step < 0)) | ((q >= upper) & (step > 0))
        if held.any():  # those DOFs stay at their limit; the others make up for them
            free = movable & ~held
            step = spacetime_step(rows, errors, row_weights, x, free, FADE, damping, stiffness) * scale
        trial = np.clip(q + step, lower, upper)
        measured_trial = measured(trial, plants)
        if measured_trial[0] < cost:
            q, (cost, errors, rows, row_weights) = trial, measured_trial
            damping = max(damping / 3.0, DAMPING[0])
        else:
            damping = min(damping * 8.0, DAMPING[2])
    return q

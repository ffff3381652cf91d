"""The space-time pass of a rig retarget: every frame at once, smooth, planted and within limits.

After the per-frame key-point IK (ik.py), one Levenberg-Marquardt least squares over the whole
clip finds the displacement from those poses that
- holds each contact site still at its plant for its whole contact (clips.plants.planted_targets
  of the current motion: a plant is where the site sits on average, on the floor when near it;
  planted again every REPLANT iterations, so plants that the target's limits cannot all meet
  at once move to where it can),
- keeps every joint and site of the body above the floor (clips.warmstart.floor_rows) and the
  body's bone capsules apart (capsule_overlaps.py), each pair to one side over the frames it
  is close in: where the per-frame IK holds it close for SIDE_SECONDS or more, the side the IK
  shows, kept from frame to frame (deep in an overlap the closest points' line flips, and the
  get-up from lying face up onto human.urdf flicked a hand between the two sides at 12 m/s),
  else the side it came from and the side it leaves to,
- keeps the key points and orientation points near their targets, counted KEYPOINT_WEIGHT /
  HELD_WEIGHT as much as the rows above, so a point the body cannot reach while its feet stay
  planted is given up first; a key point that is also a contact site has its plant as target
  during the contact, and its target joins the plant over EASE_SECONDS before the contact and
  leaves it over EASE_SECONDS after (eased_offsets): a point the source moves while it rests
  (a toe dragged along the floor, a hand pivoting) would otherwise be pulled back to the
  source's path in the frame its plant ends, a jump (102 mm in a frame on the shared kick
  retargeted to longer legs, twice its fastest step in the source),
- against the spring energy of the displacement (cleanup/spacetime.py: each DOF's stiffness by
  how much of the body it moves, clips.warmstart.motion_stiffness): a correction that a contact
  needs starts before the contact does and fades after it, so the motion keeps the per-frame
  IK's velocities and accelerations instead of jumping where a contact starts or ends. Where
  the per-frame IK jumps between basins (spring_reference: a DOF stepping past its largest step
  and JUMP_RATIO times its steps either side, a shoulder's Euler angles swapping for their twin
  in one frame), the displacement is measured from the IK's poses averaged over the frames
  around the jump (a Gaussian of one frame, within JUMP_FRAMES of it, eased back over as many
  more): measured from the jump itself, the spring held the pass to it, and the step rows below
  let it through only as a zigzag at the largest step (the shared dance onto human.urdf swung
  its pelvis and lumbar joints 0.27 rad a frame back and forth, its neck at 2.5 times its scaled
  source's top speed);
- keeps every DOF's step between two frames within its largest step (a robot's velocity limit
  times the frame time; settle.step_limits): a row per DOF and pair of frames whose step goes past STEP_MARGIN of
  it, counted as the held rows are, so a joint that would swing round in a frame (a shoulder
  at gimbal lock) takes the turn the key points leave free instead.
Each iteration solves the block-banded normal equations (clips.spacetime.spacetime_step) with
the DOFs at a limit that the step pushes outwards held, cuts the step into the limits, and keeps
it only when the whole clip's cost falls (the damping then falls; else it rises and the step is
tried again shorter). The pass ends after a round of REPLANT iterations that moved the poses
but lowered the whole cost and the held rows' cost (contacts, floor, capsules, steps) by less
than their CONVERGED shares, or after ITERATIONS: the held rows go on falling well after the
key points settle (a fixed 30 left the contacts of robots it was not tuned on sliding 1.4-7.9
mm a frame, docs/decisions.md). Rotations free over a whole turn (a free root's) are unwrapped
over the frames and never cut.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from deik.cleanup.calm import eased_share
from deik.cleanup.contacts import Contacts, true_runs
from deik.cleanup.dynamics import widened
from deik.cleanup.noise import gaussian
from deik.cleanup.plants import planted_targets
from deik.cleanup.spacetime import spacetime_step, spring_energy
from deik.cleanup.warmstart import FADE, FLOOR_MARGIN, floor_levels, floor_rows, motion_stiffness, position_jacobian
from deik.io.trajectory import Trajectory
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.retargeting.capsule_overlaps import BonePairs, collision_rows, parting_sides
from deik.retargeting.ik import Targets, targets_at

HELD_WEIGHT = 1e7  # contacts, floor, capsules and steps: their squared error in size units, against the spring
KEYPOINT_WEIGHT = 1e3  # key points: 1e4 met them 1.2-3.9 mm closer (jump, crawl) but slid the jump's feet 2 mm/frame
ITERATIONS = 150  # at most; the pass stops sooner where a round of REPLANT iterations gains little (CONVERGED)
REPLANT = 5  # iterations between plantings
CONVERGED = (1e-4, 1e-2)  # a round's least fall of the whole cost and of the held rows' cost, as a share of each
DAMPING = (1e-6, 1.0, 1e8)  # least, first and most damping (weighted DOF units squared)
CAPSULE_MARGIN = 1e-4  # of the size: how far apart a collision row pushes two capsules
SIDE_SECONDS = 0.1  # an overlap the per-frame IK holds this long keeps one side (parting_sides)
EASE_SECONDS = 0.15  # how long a key point's target takes to join its plant, and to leave it
STEP_MARGIN = 0.95  # a step row asks a DOF's step down to this share of its largest step
JUMP_RATIO = 2.0  # a basin jump: a step past the largest this many times the DOF's steps either side
JUMP_FRAMES = 3  # frames either side of a basin jump averaged in the spring's reference, and eased back over
STEP_WEIGHT = (
    0.1 * HELD_WEIGHT
)  # per weighted DOF unit squared: a tenth of a radian turns a limb's end by a tenth of its length


@dataclass(frozen=True)
class MotionGoals:
    """What the space-time pass asks of a clip's motion on `skeleton`: key points `names` (K,)
    near `targets` (ik.targets_at), the `contacts` (target sites, or None) planted, every frame
    of `body` above the `floor` (height along up) and the capsules of `pairs`
    (collision.body_pairs) apart, each DOF's step between frames within `largest_step` (D,)
    (radians or length units; inf for none), moving only the `searched` DOFs ((D,) or (N, D)),
    each change counted by `weights` (D,) (dof_weights); frames `frame_time` s apart; `size`
    the body's size (its stature, length units), which the weights of the rows are measured in."""

    skeleton: Skeleton
    names: Sequence[str]
    targets: Targets
    contacts: Contacts | None
    searched: np.ndarray
    weights: np.ndarray
    body: Sequence[str]
    pairs: BonePairs
    frame_time: float
    size: float
    largest_step: np.ndarray | None = None
    floor: float = 0.0


def step_rows(q: np.ndarray, largest: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(row weights (N-1, D), errors (N-1, D) in weighted DOF units) of the step rows at poses
    q (N, D): where |q[n+1] - q[n]| goes past STEP_MARGIN x `largest` (D,), the change of the
    step that brings it back there; 0 elsewhere."""
    delta = np.diff(q, axis=0)
    allowed = STEP_MARGIN * largest
    over = np.abs(delta) > allowed
    errors = np.where(over, np.sign(delta) * np.where(over, allowed, 0.0) - delta, 0.0) * weights
    return over * STEP_WEIGHT, errors


def spring_reference(first: np.ndarray, largest: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """(N, D) the poses the space-time pass's spring measures its displacement from: the
    per-frame IK's `first` (N, D), but within JUMP_FRAMES of a basin jump (a DOF's step past
    STEP_MARGIN x its `largest` (D,) and JUMP_RATIO times its steps either side) averaged over
    the frames (a Gaussian of one frame), eased back to `first` over JUMP_FRAMES more (module
    notes); within `lower` and `upper` (D,)."""
    if len(first) < 3:
        return np.array(first, float)
    steps = np.abs(np.diff(first, axis=0))
    none = np.zeros((1, steps.shape[1]))
    beside = np.maximum(np.concatenate([none, steps[:-1]]), np.concatenate([steps[1:], none]))
    jumps = ((steps > STEP_MARGIN * largest) & (steps > JUMP_RATIO * beside)).any(axis=1)
    if not jumps.any():
        return np.array(first, float)
    at = np.zeros(len(first), bool)
    at[:-1] |= jumps
    at[1:] |= jumps
    share = eased_share(widened(at, JUMP_FRAMES), JUMP_FRAMES)[:, None]
    return np.clip(first + share * (gaussian(first, 1.0, fit_ends=True) - first), lower, upper)


def eased_offsets(mask: np.ndarray, gaps: np.ndarray, frames: float) -> np.ndarray:
    """(N, S, 3) what to add to the targets of S key points that are contact sites so that
    they meet their plants: `gaps` (N, S, 3), plant minus target, taken whole in the frames
    `mask` (N, S) marks; outside, the gap at the nearest contact frame falls as a smoothstep to
    0 over `frames` frames, and between two contacts closer than twice that it passes from the
    one's gap to the other's by a smoothstep across the frames between them."""
    N = len(mask)
    out = np.where(mask[..., None], gaps, 0.0)

    def fall(distance):
        x = np.clip(distance / (frames + 1.0), 0.0, 1.0)
        return 1.0 - x * x * (3.0 - 2.0 * x)

    for s in range(mask.shape[1]):
        runs = true_runs(mask[:, s])
        for (_, end), (begin, _) in zip([(None, 0)] + runs, runs + [(N, None)]):
            between = np.arange(end, begin)
            if not len(between):
                continue
            after, before = between - end + 1, begin - between  # frames from the contact before, after
            if 0 < end and begin < N and begin - end < 2 * frames:
                u = after / (begin - end + 1.0)
                weights = (1.0 - u * u * (3.0 - 2.0 * u), u * u * (3.0 - 2.0 * u))
            else:
                weights = (fall(after) if end > 0 else 0.0 * after, fall(before) if begin < N else 0.0 * before)
            if end > 0:
                out[between, s] += weights[0][:, None] * gaps[end - 1, s]
            if begin < N:
                out[between, s] += weights[1][:, None] * gaps[begin, s]
    return out


def smooth_motion(goals: MotionGoals, first: np.ndarray) -> np.ndarray:
    """(N, D) poses near the per-frame IK's `first` (N, D) that meet `goals` as the module
    notes say. Rotations free over a whole turn come out unwrapped (continuous over the
    frames)."""
    skeleton, contacts, weights = goals.skeleton, goals.contacts, goals.weights
    N, D = first.shape
    full_turn = skeleton.full_turns
    unwrapped = np.array(first, float)
    unwrapped[:, full_turn] = np.unwrap(unwrapped[:, full_turn], axis=0)
    lower = np.where(full_turn, -np.inf, skeleton.lower)
    upper = np.where(full_turn, np.inf, skeleton.upper)
    largest = np.full(D, np.inf) if goals.largest_step is None else np.asarray(goals.largest_step, float)
    base = spring_reference(unwrapped, largest, lower, upper)
    frames = list(skeleton.frame_names)
    points = [frames.index(name) for name in goals.names]
    floor_points = [frames.index(name) for name in goals.body]
    sites = [] if contacts is None else [frames.index(name) for name in contacts.sites]
    mask = np.zeros((N, 0), bool) if contacts is None else contacts.mask
    scale = np.where(weights > 0, 1.0 / np.where(weights > 0, weights, 1.0), 0.0)
    stiffness = motion_stiffness(skeleton, base, weights)
    movable = np.broadcast_to(np.asarray(goals.searched, bool), (N, D))
    size2 = goals.size**2

    planted_keys = [(s, goals.names.index(name)) for s, name in enumerate(contacts.sites if contacts else ())
                    if name in goals.names]  # fmt: skip
    ease_frames = EASE_SECONDS / goals.frame_time
    lasting = max(2, round(SIDE_SECONDS / goals.frame_time))
    ik_points = forward_kinematics(skeleton, base).p_world_frame
    sides = parting_sides(ik_points, goals.pairs, CAPSULE_MARGIN * goals.size, lasting)

    def plants_at(q):
        """(plants (N, S, 3), what to add to the key points' targets (N, K, 3))."""
        offsets = np.zeros((N, len(points), 3))
        if contacts is None:
            return np.zeros((N, 0, 3)), offsets
        # the mean along the ground: the IK's path of a planted point, fast ends included, is its own
        plants = planted_targets(Trajectory(skeleton, q, goals.frame_time), contacts, along="mean")
        if planted_keys:
            s, k = (list(column) for column in zip(*planted_keys))
            gaps = plants[:, s] - targets_at(goals.targets, q, np.arange(N))[:, k]
            offsets[:, k] = eased_offsets(mask[:, s], gaps, ease_frames)
        return plants, offsets

    def measured(q, planted):
        """(cost, errors (N, R), rows (N, R, D) per weighted DOF unit, row weights (N, R), step rows)."""
        plants, offsets = planted
        x, jac = position_jacobian(skeleton, q, frames)
        held_errors = [np.where(mask[..., None], plants - x[:, sites], 0.0).reshape(N, -1)]
        held_rows = [(jac[:, sites] * mask[:, :, None, None]).reshape(N, -1, D)]
        margin = FLOOR_MARGIN * skeleton.reach
        error, rows = floor_rows(
            x[:, floor_points], jac[:, floor_points], skeleton.up, floor_levels(goals.floor, margin, None), margin
        )
        held_errors.append(error)
        held_rows.append(rows)
        error, rows = collision_rows(x, jac, goals.pairs, CAPSULE_MARGIN * goals.size, sides)
        held_errors.append(error)
        held_rows.append(rows)
        held = np.concatenate(held_errors, axis=1)
        key = (targets_at(goals.targets, q, np.arange(N)) + offsets - x[:, points]).reshape(N, -1)
        errors = np.concatenate([held, key], axis=1)
        rows = np.concatenate(held_rows + [jac[:, points].reshape(N, -1, D)], axis=1) * scale
        row_weights = np.concatenate([np.full(held.shape, HELD_WEIGHT), np.full(key.shape, KEYPOINT_WEIGHT)], axis=1)
        row_weights = row_weights / size2
        steps = step_rows(q, largest, weights)
        cost = (row_weights * errors**2).sum() + (steps[0] * steps[1] ** 2).sum()
        cost += spring_energy((q - base) * weights, FADE, stiffness)
        return cost, errors, rows, row_weights, steps

    def costs(state):
        """(whole cost, the held rows' cost) of a `measured` state."""
        cost, errors, _, row_weights, steps = state
        held = errors.shape[1] - 3 * len(points)
        return cost, (row_weights[:, :held] * errors[:, :held] ** 2).sum() + (steps[0] * steps[1] ** 2).sum()

    q = base.copy()
    plants = plants_at(q)
    cost, errors, rows, row_weights, steps = measured(q, plants)
    damping = DAMPING[1]
    round_start, moved = costs((cost, errors, rows, row_weights, steps)), False
    for k in range(ITERATIONS):
        if k and k % REPLANT == 0:
            now = costs((cost, errors, rows, row_weights, steps))
            if moved and all(a >= (1.0 - least) * b for a, b, least in zip(now, round_start, CONVERGED)):
                break
            if contacts is not None:
                plants = plants_at(q)
                cost, errors, rows, row_weights, steps = measured(q, plants)
            round_start, moved = costs((cost, errors, rows, row_weights, steps)), False
        x = (q - base) * weights
        step = spacetime_step((rows, errors, row_weights), x, movable, FADE, damping, stiffness, steps) * scale
        held = ((q <= lower) & (step < 0)) | ((q >= upper) & (step > 0))
        if held.any():  # those DOFs stay at their limit; the others make up for them
            free = movable & ~held
            step = spacetime_step((rows, errors, row_weights), x, free, FADE, damping, stiffness, steps) * scale
        trial = np.clip(q + step, lower, upper)
        measured_trial = measured(trial, plants)
        if measured_trial[0] < cost:
            q, (cost, errors, rows, row_weights, steps) = trial, measured_trial
            moved = True
            damping = max(damping / 3.0, DAMPING[0])
        else:
            damping = min(damping * 8.0, DAMPING[2])
    return q

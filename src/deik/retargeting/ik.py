"""Key-point IK for every frame of a retarget at once: Levenberg-Marquardt on the points'
positions within the joint limits, then the frames that landed apart from their neighbours
solved again from theirs.

Each iteration takes, per frame, the damped least-squares step of the searched DOFs towards
the key points' targets (each point's error cut to LONGEST_STEP x reach, so a far target is
approached, not chased), with the DOFs at a limit that the step pushes outwards held, as the
kernels' LM polish holds them; the step is kept where it lowers the frame's error (its damping
then falls) and refused where it does not (its damping rises). Frames all start from the same
pose, so neighbouring frames mostly settle in the same basin. Without the holding, steps cut
back into the limits stalled knees and ankles at a limit, toes pointing down, 10-30 cm from
their targets.

Some frames still settle in another basin than their neighbours (an arm folded the other way,
40 cm from its wrist's target, in one to four frames of the humanoid's crawl), and a whole
clip's passes between equally good basins (a shoulder's Euler angles turning 2 rad between two
frames) jolt. repair_outliers solves the frames whose worst error stands out again from each
neighbour's pose; rebasin starts every frame from a smoothed version of the clip's poses, so a
frame apart from its neighbours starts among theirs (retargeting/rig.py runs both).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from deik.cleanup.contacts import true_runs
from deik.cleanup.dynamics import jolted_points
from deik.cleanup.metrics import joint_angles
from deik.cleanup.noise import gaussian
from deik.cleanup.warmstart import at_most, position_jacobian
from deik.io.trajectory import Trajectory
from deik.model.kinematics import forward_kinematics
from deik.model.rotations import wrap_rotations
from deik.model.skeleton import Skeleton

ITERATIONS = 20  # 40 gave the same errors on the shared clips (within 1 mm) in 1.5x the time
LONGEST_STEP = 0.1  # of reach: the longest error a point's row asks for in one step
DAMPING = (1e-4, 1e-3, 1e4)  # least, first and most damping (weighted DOF units squared)
FLOOR_WEIGHT = 10.0  # a point below the floor counts this many times a key point as far off
# a frame is an outlier when its worst key-point error is OUTLIER_RATIO x the median of the
# OUTLIER_SPAN frames around it and more than OUTLIER_ERROR x reach (3 cm on a person)
OUTLIER_RATIO, OUTLIER_SPAN, OUTLIER_ERROR = 2.0, 5, 0.017
OUTLIER_ROUNDS = 3  # a run of outliers is repaired from its ends inwards, a frame a round
# a jolted frame's pose from its neighbours is kept when its worst error is at most this much
# (x size) above its own: 1.5 cm on a person, half what makes a frame an outlier
JOLT_SLACK = 0.5 * OUTLIER_ERROR
# frames re-solved at once from the pose before them (repair_flips): 1 took the crawl and the dance
# onto human.urdf 3-4x as long as without the repair, 4 about 1.9x (speed peak over the source's:
# the crawl's 1.47 and 1.46, the dance's 2.02 and 2.57)
FLIP_CHUNK = 4
SMOOTHING = 2.0  # frames: the width (a Gaussian's sigma) of the smoothing rebasin starts from

Targets = np.ndarray | Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class KeypointGoals:
    """What the key-point IK asks of every frame of a clip: the frames `names` (K,) of
    `skeleton` meet `targets` (targets_at) as nearly as the limits allow, moving only the
    `searched` DOFs ((D,) or (N, D) bool over the clip's N frames), each change counted by
    `weights` (D,) (dof_weights); with a `floor` (height along up, length units) every joint
    and site of `body` (default all) is also pushed out of the floor, each depth counted
    FLOOR_WEIGHT times. `size` (length units, default the skeleton's reach) is the body's size
    the step and outlier thresholds are fractions of."""

    skeleton: Skeleton
    names: Sequence[str]
    targets: Targets
    searched: np.ndarray
    weights: np.ndarray
    floor: float | None = None
    body: Sequence[str] | None = None
    size: float | None = None

    @property
    def length(self) -> float:
        """The body's size: `size`, else the skeleton's reach."""
        return self.skeleton.reach if self.size is None else self.size

    def above(self, floor: float, body: Sequence[str] | None = None) -> KeypointGoals:
        """The same goals with the floor at height `floor` under the frames `body`."""
        return replace(self, floor=floor, body=body)

    def searched_at(self, frames: np.ndarray) -> np.ndarray:
        """(n, D) the searched DOFs of the clip frames `frames` (n,)."""
        searched = np.asarray(self.searched, bool)
        return searched[frames] if searched.ndim == 2 else np.broadcast_to(searched, (len(frames), len(searched)))


def _inside(skeleton, poses: np.ndarray) -> np.ndarray:
    """`poses` within the limits; rotations free over a whole turn wrap instead."""
    full_turn = skeleton.full_turns
    wrapped = wrap_rotations(poses, full_turn)
    return np.where(full_turn, wrapped, np.clip(poses, skeleton.lower, skeleton.upper))


def _step(A: np.ndarray, e: np.ndarray, damping: np.ndarray) -> np.ndarray:
    """(N, D) the damped least-squares steps of rows A (N, R, D) for errors e (N, R)."""
    D = A.shape[-1]
    normal = A.transpose(0, 2, 1) @ A + damping[:, None, None] * np.eye(D)
    return np.linalg.solve(normal, (A.transpose(0, 2, 1) @ e[..., None]))[..., 0]


def _floor_depth(x: np.ndarray, up: np.ndarray, floor: float) -> np.ndarray:
    """(N, F) how far each point of `x` (N, F, 3) lies below the floor (0 above it)."""
    return np.maximum(floor - x @ up, 0.0)


def targets_at(targets: Targets, poses: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """(n, K, 3) the targets of the clip frames `frames` (n,) at `poses` (n, D): `targets`
    (N, K, 3) for the whole clip, or a function (poses, frames) -> (n, K, 3) (points whose
    targets follow the pose, such as orientation points measured from a frame)."""
    return targets(poses, frames) if callable(targets) else np.asarray(targets)[frames]


def solve_keypoints(goals: KeypointGoals, poses: np.ndarray, frames: np.ndarray | None = None) -> np.ndarray:
    """(n, D) poses near `poses` (n, D) of the clip frames `frames` (n,) (default all) that meet
    `goals` as nearly as the limits allow."""
    skeleton, floor, targets, weights = goals.skeleton, goals.floor, goals.targets, goals.weights
    names = list(goals.names)
    K = len(names)
    poses = _inside(skeleton, np.array(poses, float))
    N = len(poses)
    frames = np.arange(N) if frames is None else np.asarray(frames)
    low = list(skeleton.frame_names if goals.body is None else goals.body) if floor is not None else []
    up = np.asarray(skeleton.up, float)
    searched = goals.searched_at(frames)
    scale = searched * np.where(weights > 0, 1.0 / np.where(weights > 0, weights, 1.0), 0.0)
    longest = LONGEST_STEP * goals.length
    lower, upper = skeleton.lower, skeleton.upper

    def measured(q):
        """(points, Jacobian, cost per frame) at poses q."""
        x, J = position_jacobian(skeleton, q, names + low)
        cost = (np.linalg.norm(targets_at(targets, q, frames) - x[:, :K], axis=-1) ** 2).sum(axis=1)
        if floor is not None:
            cost = cost + FLOOR_WEIGHT**2 * (_floor_depth(x[:, K:], up, floor) ** 2).sum(axis=1)
        return x, J, cost

    damping = np.full(N, DAMPING[1])
    x, J, cost = measured(poses)
    for _ in range(ITERATIONS):
        e = at_most(targets_at(targets, poses, frames) - x[:, :K], longest).reshape(N, -1)
        A = J[:, :K].reshape(N, -1, J.shape[-1])
        if floor is not None:
            depth = np.minimum(_floor_depth(x[:, K:], up, floor), longest)
            rows = np.einsum("k,nfkd->nfd", up, J[:, K:]) * (depth > 0)[..., None]
            e = np.concatenate([e, FLOOR_WEIGHT * depth], axis=1)
            A = np.concatenate([A, FLOOR_WEIGHT * rows], axis=1)
        A = A * scale[:, None, :]
        step = _step(A, e, damping) * scale
        held = ((poses <= lower) & (step < 0)) | ((poses >= upper) & (step > 0))
        if held.any():
            step = _step(A * ~held[:, None, :], e, damping) * scale * ~held
        trial = _inside(skeleton, poses + step)
        x_trial, J_trial, trial_cost = measured(trial)
        better = trial_cost < cost
        poses = np.where(better[:, None], trial, poses)
        x = np.where(better[:, None, None], x_trial, x)
        J = np.where(better[:, None, None, None], J_trial, J)
        cost = np.where(better, trial_cost, cost)
        damping = np.clip(np.where(better, damping / 3.0, damping * 10.0), DAMPING[0], DAMPING[2])
    return poses


def _key_points(goals: KeypointGoals, poses: np.ndarray) -> np.ndarray:
    """(n, K, 3) where the goals' frames lie at `poses` (n, D)."""
    kin = forward_kinematics(goals.skeleton, poses)
    return np.stack([kin.position(name) for name in goals.names], axis=1)


def worst_errors(goals: KeypointGoals, poses: np.ndarray, frames: np.ndarray | None = None) -> np.ndarray:
    """(n,) the largest distance of the goals' frames at `poses` (n, D) of the clip frames
    `frames` (default all) from their targets (targets_at), length units."""
    frames = np.arange(len(poses)) if frames is None else np.asarray(frames)
    return np.linalg.norm(_key_points(goals, poses) - targets_at(goals.targets, poses, frames), axis=-1).max(axis=1)


def _local_median(values: np.ndarray, span: int) -> np.ndarray:
    """(N,) the median of the `span` values around each (the ends repeated)."""
    half = span // 2
    padded = np.concatenate([np.repeat(values[:1], half), values, np.repeat(values[-1:], half)])
    return np.median(np.lib.stride_tricks.sliding_window_view(padded, span), axis=1)


def repair_outliers(goals: KeypointGoals, poses: np.ndarray) -> np.ndarray:
    """(N, D) `poses` (N, D) of solve_keypoints with each outlier frame (module notes) solved
    again from its previous and its next frame's pose, the better of the three kept; up to
    OUTLIER_ROUNDS rounds."""
    poses = np.array(poses, float)
    for _ in range(OUTLIER_ROUNDS):
        error = worst_errors(goals, poses)
        bad = np.flatnonzero(
            (error > OUTLIER_RATIO * _local_median(error, OUTLIER_SPAN)) & (error > OUTLIER_ERROR * goals.length)
        )
        if not bad.size:
            break
        best, lowest = poses[bad], error[bad]
        for side in (-1, 1):
            seeds = poses[np.clip(bad + side, 0, len(poses) - 1)]
            found = solve_keypoints(goals, seeds, bad)
            found_error = worst_errors(goals, found, bad)
            better = found_error < lowest
            best[better], lowest[better] = found[better], found_error[better]
        poses[bad] = best
    return poses


def smoothed(poses: np.ndarray, full_turn: np.ndarray, width: float = SMOOTHING) -> np.ndarray:
    """(N, D) `poses` (N, D) smoothed over the frames by a Gaussian of sigma `width` frames (the
    ends repeated), the `full_turn` (D,) rotations unwrapped first so a spin past pi stays a spin."""
    poses = np.array(poses, float)
    poses[:, full_turn] = np.unwrap(poses[:, full_turn], axis=0)
    return gaussian(poses, width)


def rebasin(goals: KeypointGoals, poses: np.ndarray) -> np.ndarray:
    """(N, D) solve_keypoints started from `poses` smoothed over the frames (smoothed): a frame
    whose pose stands apart from its neighbours' starts among theirs and mostly settles in their
    basin, and a clip that switches basins does so in fewer frames."""
    return solve_keypoints(goals, smoothed(poses, goals.skeleton.full_turns))


def _jolt(x: np.ndarray, first: int, last: int) -> tuple[float, float]:
    """(largest step, largest second difference) of the points x (N, K, 3) (length units per
    frame, and per frame squared) from frame first - 1 to last + 1: how much the poses of frames
    first..last jolt their neighbourhood."""
    window = x[max(first - 1, 0) : min(last + 1, len(x) - 1) + 1]
    steps = np.diff(window, axis=0)
    speed = float(np.linalg.norm(steps, axis=-1).max()) if len(steps) else 0.0
    turns = np.diff(steps, axis=0)
    return speed, float(np.linalg.norm(turns, axis=-1).max()) if len(turns) else 0.0


def repair_jolts(goals: KeypointGoals, poses: np.ndarray, frame_time: float) -> np.ndarray:
    """(N, D) `poses` (N, D) with each run of frames where a key point jolts (moves or
    accelerates past what its targets do: cleanup.dynamics.jolted_points) solved again whole,
    from the pose of the frame before it and from that of the frame after; the run's poses that
    jolt the neighbourhood least (its points' largest second difference), moving none of them
    faster, are kept when no frame of them lies further from its targets than the run and its
    two neighbours did, or than JOLT_SLACK x size above its own. A redundant limb that cannot
    reach all its key points has several close compromises, and frames that alternate between
    two of them (an arm flicking between two elbow angles) pass the outlier test; up to
    OUTLIER_ROUNDS rounds."""
    poses = np.array(poses, float)
    N = len(poses)
    frames = np.arange(N)
    for _ in range(OUTLIER_ROUNDS if N >= 3 else 0):
        x = _key_points(goals, poses)
        jolted = jolted_points(targets_at(goals.targets, poses, frames), x, frame_time, goals.length)
        changed = False
        for first, stop in true_runs(jolted):
            last, run = stop - 1, np.arange(first, stop)
            around = np.arange(max(first - 1, 0), min(last + 1, N - 1) + 1)
            own = worst_errors(goals, poses[run], run)
            allowed = np.maximum(worst_errors(goals, poses[around], around).max(), own + JOLT_SLACK * goals.length)
            best, (speed, lowest) = None, _jolt(x, first, last)
            for seed in dict.fromkeys((max(first - 1, 0), min(last + 1, N - 1))):  # before, after
                found = solve_keypoints(goals, np.repeat(poses[seed : seed + 1], len(run), axis=0), run)
                if (worst_errors(goals, found, run) > allowed).any():
                    continue
                trial = x.copy()
                trial[run] = _key_points(goals, found)
                trial_speed, jolt = _jolt(trial, first, last)
                if jolt < lowest and trial_speed <= speed:  # calmer, and no faster anywhere
                    best, lowest = (found, trial[run]), jolt
            if best is not None:
                poses[run], x[run], changed = best[0], best[1], True
        if not changed:
            break
    return poses


def repair_flips(goals: KeypointGoals, poses: np.ndarray, largest: float) -> np.ndarray:
    """(N, D) `poses` (N, D) with each frame in which a joint turns more than `largest` radians
    from the frame before solved again, with the FLIP_CHUNK - 1 frames after it, from that
    frame's pose, in order (a swap that lasts is met again where the re-solved frames end, and
    so followed to its end), so that the run follows its neighbour's basin; kept where the turn
    into it shrinks and no frame of it lies further from its targets than JOLT_SLACK x size above
    its own. DOFs the key points leave free can swap between poses that reach them alike
    (a pelvis turned one way with the spine and hips turned back, or the other way): the crawl
    onto human.urdf turned its lumbar joint 70 degrees in a frame with no key point jolting, and
    the space-time pass, holding each step within its allowance, spread the turn over frames,
    moving a shoulder 88 mm in one."""
    poses = np.array(poses, float)
    N, sk = len(poses), goals.skeleton
    limit = np.degrees(largest)

    def turns(q):  # (n - 1,) degrees: the largest joint turn between consecutive poses q (n, D)
        angles = joint_angles(Trajectory(sk, q[:-1], 1.0), Trajectory(sk, q[1:], 1.0))
        return angles.max(axis=1, initial=0.0)

    steps = turns(poses) if N > 1 else np.zeros(0)  # steps[n]: from frame n to n + 1
    for n in range(1, N):
        if steps[n - 1] <= limit:
            continue
        chunk = np.arange(n, min(n + FLIP_CHUNK, N))  # solved at once from the pose before them
        found = solve_keypoints(goals, np.repeat(poses[n - 1 : n], len(chunk), axis=0), chunk)
        allowed = worst_errors(goals, poses[chunk], chunk) + JOLT_SLACK * goals.length
        around = np.concatenate([poses[n - 1 : n], found, poses[chunk[-1] + 1 : chunk[-1] + 2]])
        local = turns(around)  # the steps into, within and out of the chunk as found
        if local[0] < steps[n - 1] and (worst_errors(goals, found, chunk) <= allowed).all():
            poses[chunk] = found
            steps[n - 1 : n - 1 + len(local)] = local
    return poses

"""The warm start of a clip fix: every frame's goals met at once, smoothly, before DE repairs
what it leaves unmet.

Each frame's contacts, floor and balance goals (cleanup/clip_goals.py's levels 0 and 1) and, below
them, its reach tracks (level 2) are met by a displacement of the whole clip from the capture,
found in space-time Gauss-Newton steps (cleanup/spacetime.py): every frame's goal rows, on
the positions' Jacobian (the kernels' analytic one: each DOF turns about or slides along its
world axis), weighted against the spring energy of the displacement, each DOF counted by how
much of the body it moves (motion_stiffness). A correction therefore starts before a contact
does and bends the legs rather than the hips; where no goal holds a DOF it fades back to the
capture; a DOF no goal needs (an idle arm) is not touched. Balance goals add two rows, the
centre of mass's horizontal Jacobian, steering it along a track over the support
(balance.py). Reach rows weigh REACH_WEIGHT / HELD_WEIGHT as much as the others, so an
unreachable reach pulls a planted contact only a little. Steps repeat until the goal rows are
met to SETTLED x reach or, after FIRST_STEPS, their root-mean-square error stops falling (at
most STEPS): every step moves the whole clip at once, so none lands a frame apart from its
neighbours. Goals that cannot all be met are left to
DE, with its priorities and tolerances.

The feet's roll: a contact holds its point still along the ground only, so nothing else fixes
the height of a foot's heel or toe while it rests, and the spring lets it drift (on the shared
walk a toe planted while its heel rises about it climbed from 5 to 24 mm above the floor where
the capture keeps it at 10 mm, and so left the floor three frames early). The heel and toe of
each foot (the `soles` named) also keep their height in the capture while they rest, raised
out of the floor as far as the deepest of them and the soles rigidly linked to them
(plants.lifted_heights, over the floor's levels or lifts): the foot rolls about its toe as
captured. These rows weigh ROLL_WEIGHT, so a foot that cannot keep both its plant and its
height keeps its plant, and the steps stop on the other rows alone; the reach phase leaves
them out (pulled against by an unreachable reach, they let it drag a planted toe 1.5 mm).

A body lifted whole (`whole`): a floor lift raises the point that sinks, and the cheapest way
to do that is often to turn the bone it is on: a heel lifted 13 mm as a jump lands tipped the
toe down 28 mm onto the floor and back, a jolt that calm then took back, leaving the heel in
the floor. With `whole`, every other point fixed in the same joint's frame (rigid_bodies: the
ankle, toe tip and soles of a foot) keeps at least its capture height in the frames one of
them is lifted (whole_lifts), so the bone is carried up rather than turned. These bounds only
push up: such a point is not held where it is (a point held still would fight the plants).
fix_clip tries the warm start with and without it and keeps the better.

Short levers: a joint whose part of the body reaches no farther than body.SHORT_LEVER x span from it
(a toe, a finger: 2.9 and 4.6 % of it on the shared humanoid with toes and moving fingers; an
ankle carries its heel and toe tip 7 % away) is left as captured (body.short_levers; DE may still
turn it where a frame stays unmet). Such a joint moves its few points cheaply, so a step hands
it what a leg should carry, and a step linear in its angle asks it for more than it can reach:
a game rig whose toes the capture bends (judging/cases.py, toes, with noise) had a toe turned
168 degrees in the first step and 584 after three, the foot left 73 mm under the floor.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from deik.cleanup.balance import horizontal_axes
from deik.cleanup.clip_goals import REACH_LEVEL
from deik.cleanup.coherence import active_frames
from deik.cleanup.contacts import running_max
from deik.cleanup.metrics import point_motion
from deik.cleanup.plants import lifted_heights, rigid_pairs
from deik.cleanup.spacetime import spacetime_step
from deik.io.trajectory import Motion
from deik.model.capsules import body_reach, body_root, carrier_joints, joined_to_parents, off_body
from deik.model.joints import ROTATE
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.objectives.goals import ComOverSupport, Floor, Goal, Position
from deik.solver.jacobians import point_jacobians

DAMPING = 1e-3  # of reach per weighted DOF unit: keeps a step finite at a straight knee
STEPS = 12  # most space-time steps over the whole clip, per phase
SETTLED = 2e-5  # of reach: goal rows met this closely need no more steps
FIRST_STEPS = 4  # steps taken before one that does not lower the rows' root-mean-square error ends them
FADE = 8.0  # frames over which a correction fades where no goal holds it (cleanup/spacetime.py)
# weights of a goal row's squared error, in reach units, against the spring energy (radians^2):
# contacts, floor and balance some 70 times above reach tracks (a reach step is cut to
# LONGEST_STEP: at a tenth, an unreachable reach dragged a rolling foot 10 mm; at 1.5e4, 0.4 mm
# while a reachable reach still ends within 1 mm), reach tracks far above the energy
HELD_WEIGHT = 1e6
REACH_WEIGHT = 1.5e4
ROLL_WEIGHT = 1.5e4  # a resting sole's height in the capture (module notes): as far below the contacts as a reach
ROOT_STIFFNESS = 10.0  # and the root's DOFs, which carry the whole body along its path, this much more
BODY_STIFFNESS = 30.0  # how much more a DOF's spring counts per unit of the body it moves (motion_stiffness)
LONGEST_STEP = 0.1  # of reach: how far one step moves a goal's site towards its target
FLOOR_MARGIN = 1e-4  # of reach: how far above the floor (and its clearance) a point pushed out of it ends
FLOOR_HOLD = 30.0  # margins: a point this close to the floor is held where it is
LIFT_SHARE = 0.05  # of a point's acceleration peak in the capture: the most a floor lift adds (floor_lifts)
LIFT_WIDTHS = (1, 2, 3, 4, 6, 8, 11, 16, 23, 32, 45, 64, 90, 128)  # half widths tried, frames


def position_jacobian(
    skeleton: Skeleton, poses: np.ndarray, names: Sequence[str], centre_of_mass: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """World positions (N, G, 3) of the joints or sites `names` (then of the centre of mass if
    `centre_of_mass`) at `poses` (N, D), and their Jacobian (N, G, 3, D): length units per
    radian (rotations) or per length unit. The kernels' float64 FK and analytic rows compute
    both (deik.solver.jacobians)."""
    frames = [skeleton.frame_index(name) for name in names] + [-1] * centre_of_mass
    return point_jacobians(skeleton, poses, frames)


def dof_weights(clip: Motion, counted: np.ndarray | None = None) -> np.ndarray:
    """(D,) what a unit change of each DOF costs: 1 per radian, and per length unit of a
    translation 1 / r, r the root-mean-square distance of the body's joints and sites (no
    carrier or helper: deik.model.capsules.off_body; or the frames `counted` (F,) bool) from
    its root (the hips, below any carrier: body_root) over the clip: moving the root counts
    like the root turn that moves the body as much. With 1 per length unit too (metres as
    radians), lifting the whole body would be the cheap way to move a hand."""
    sk = clip.skeleton
    p = clip.kinematics.p_world_frame
    counted = ~off_body(sk) if counted is None else counted
    r = np.sqrt(((p[:, counted] - p[:, body_root(sk), None]) ** 2).sum(axis=-1).mean())
    return np.where(sk.dof_kind == ROTATE, 1.0, 1.0 / r if r > 0 else 1.0)


def motion_stiffness(
    skeleton: Skeleton, poses: np.ndarray, weights: np.ndarray, surface: tuple[str, ...] = ()
) -> np.ndarray:
    """(D,) how stiff each DOF's spring is (cleanup/spacetime.py): 1 + BODY_STIFFNESS x the sum
    over every joint and site of its squared speed per unit of the weighted DOF (dof_weights),
    in reach units (body_reach), averaged over `poses` (N, D), and ROOT_STIFFNESS times that for
    the DOFs that carry the whole body: the body's root (body_root) and the carriers above it.
    A correction that must bend somewhere (a heel stopping where a contact starts) then bends
    the leg, not the hips that carry the arms, no channel takes it all (both the points' and the
    channels' accelerations stay low), and the body keeps its path through the world unless the
    legs cannot reach. What is no part of the body (carriers, helpers: model.capsules.off_body) does
    not count: 40 still finger points stiffened a game rig's arms; nor do the `surface` sites
    (cleanup/body.py's trunk centres), points of the surface, not of the motion."""
    carriers = carrier_joints(skeleton)
    off = off_body(skeleton)
    body_frames = [name for f, name in enumerate(skeleton.frame_names) if not off[f] and name not in surface]
    _, jac = position_jacobian(skeleton, poses, body_frames)
    scale = np.where(weights > 0, 1.0 / np.where(weights > 0, weights, 1.0), 0.0)
    body = (jac**2).sum(axis=(1, 2)).mean(axis=0) * scale**2 / body_reach(skeleton) ** 2
    carrying = carriers[skeleton.dof_joint] | (skeleton.dof_joint == body_root(skeleton))
    return (1.0 + BODY_STIFFNESS * body) * np.where(carrying, ROOT_STIFFNESS, 1.0)


def _rows(goals, N: int, names: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(index (H,) into `names`, targets (N, H, 3), active (N, H)) of Position `goals`."""
    index = np.array([names.index(goal.frame) for goal in goals], int)
    targets = np.array([np.broadcast_to(np.asarray(goal.target, float), (N, 3)) for goal in goals])
    active = np.array([active_frames(goal, N) for goal in goals]).reshape(len(goals), N).T
    return index, targets.reshape(len(goals), N, 3).transpose(1, 0, 2), active


def _position_rows(x, jac, rows, longest: float, axes: np.ndarray | None = None):
    """(errors (N, kH), Jacobian rows (N, kH, D)) of the Position rows (index, targets, active),
    along the k = 3 world axes or, given `axes` (k, 3), along those (a contact: the ground's)."""
    index, targets, active = rows
    N, D = jac.shape[0], jac.shape[-1]
    error = at_most(np.where(active[..., None], targets - x[:, index], 0.0), longest)
    part = jac[:, index] * active[:, :, None, None]
    if axes is not None:
        error, part = error @ axes.T, np.einsum("ij,nhjd->nhid", axes, part)
    return error.reshape(N, -1), part.reshape(N, -1, D)


def floor_levels(floor: float, margin: float, clearance: np.ndarray | None) -> np.ndarray | float:
    """(F,) (or a number) the height each joint or site must keep: floor + its `clearance` (F,)
    (default 0; NaN: none, -inf) + `margin`."""
    return floor + margin + (0.0 if clearance is None else np.nan_to_num(clearance, nan=-np.inf))


def floor_lifts(heights: np.ndarray, level: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """(N, F) heights to lift each point to: its capture `heights` (N, F) raised by a smooth
    envelope over how far it sinks below its `level` (F,), so that a point that sinks is lifted
    from before it touches to after it leaves, without a kink. The envelope of a point's depth
    d (N,) is d's running maximum over +-w frames smoothed by a Hann window of half width w
    (its end values held beyond the clip's ends), which is >= d everywhere; w grows until the
    envelope's second difference is at most LIFT_SHARE x the point's largest in the capture,
    `peaks` (F,) (length units per frame^2): the lift adds at most that share to the point's
    acceleration."""
    N, F = heights.shape
    depth = np.maximum(np.broadcast_to(level, (N, F)) - heights, 0.0)
    out = np.broadcast_to(level, (N, F)).astype(float).copy()
    widths = [w for w in LIFT_WIDTHS if 2 * w + 1 <= N] or [0]  # a window no longer than the clip
    for f in np.flatnonzero(depth.max(axis=0) > 0):
        for w in widths:
            envelope = _hann(running_max(depth[:, f], w), w)
            if N < 3 or np.abs(np.diff(envelope, 2)).max() <= LIFT_SHARE * peaks[f]:
                break
        out[:, f] = np.maximum(out[:, f], heights[:, f] + envelope)
    return out


def rigid_bodies(skeleton: Skeleton, movable: np.ndarray) -> np.ndarray:
    """(F,) a label per joint and site of `skeleton` (frame_names): the joint's own index for a
    joint and for every site fixed in its frame (a foot's toe tip and soles with its ankle); a
    joint none of whose DOFs is `movable` (D,) bool (a toe the capture never bends) moves with
    its parent, and shares its label."""
    moves = np.zeros(skeleton.n_joints, bool)
    np.logical_or.at(moves, skeleton.dof_joint, np.asarray(movable, bool))
    label = joined_to_parents(skeleton, ~moves)
    return np.concatenate([label, label[skeleton.site_joint]])


def whole_lifts(
    lifted: np.ndarray, heights: np.ndarray, level: np.ndarray, bodies: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(heights (N, F), raised (N, F) bool): the `lifted` (N, F) heights of floor_lifts (over
    the capture `heights` (N, F) and the floor `level`, (F,) or (N, F)) with every point of a
    body (`bodies` (F,) labels, rigid_bodies) one of whose points is lifted in a frame kept at
    least at its capture height there, and where that raised it (module notes: a body lifted
    whole)."""
    level = np.broadcast_to(level, heights.shape)
    floored = np.isfinite(level).all(axis=0)  # a point with no floor is lifted by none
    up = lifted > heights  # where a point is lifted above its capture
    raised = np.zeros(heights.shape, bool)
    for body in np.unique(bodies[up.any(axis=0)]):
        members = (bodies == body) & floored
        raised |= up[:, members].any(axis=1)[:, None] & members[None, :] & (heights > lifted)
    return np.where(raised, heights, lifted), raised


def _hann(values: np.ndarray, w: int) -> np.ndarray:
    """(N,) `values` (N,) averaged by a Hann window of half width w frames, the end values held
    beyond the clip's ends: what a point did before the clip began is unknown, and taking it as
    resting on the floor made a point that sinks in the first frame rise steeply there, so its
    envelope widened to the whole clip (a jump's heel lifted through the flight)."""
    window = 1.0 + np.cos(np.pi * np.arange(-w, w + 1) / (w + 1))
    return np.convolve(np.pad(values, w, mode="edge"), window / window.sum(), mode="valid")


def floor_rows(
    x: np.ndarray,
    jac: np.ndarray,
    up: np.ndarray,
    level: np.ndarray | float,
    margin: float,
    hold: np.ndarray | float = 2.0,
) -> tuple[np.ndarray, np.ndarray]:
    """(errors (N, F), Jacobian rows (N, F, D)): each joint or site at positions x (N, F, 3) lower
    than its `level` ((N, F), (F,) or a number: floor_levels, floor_lifts) is lifted to it, and
    one less than `hold` `margin`s above that ((N, F) or a number) is held where it is (a
    step's spring, pulling a lifted point back towards the capture, would drop it through the
    floor again)."""
    height = x @ up
    low = height < level + (hold - 1.0) * margin
    return np.where(low, np.maximum(level - height, 0.0), 0.0), np.einsum("k,nfkd->nfd", up, jac) * low[..., None]


def roll_targets(
    x0: np.ndarray, up: np.ndarray, held_rows: tuple, soles: np.ndarray, floors: list, reach: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(index (R,) into x0's points, heights (N, R), resting (N, R) bool) of the feet's roll
    (module notes): the held rows (_rows) of the `soles` (H,) bool among them, each resting sole
    at its height in the capture positions x0 (N, F, 3), each frame's raised by the depth below
    its floor level ((N, F) or (F,) each of `floors`) of the deepest of it and the soles rigidly
    linked to it resting then (plants.lifted_heights; `reach` the body's)."""
    index = held_rows[0][soles]
    resting = held_rows[2][:, soles]
    N, F = x0.shape[:2]
    level = np.max([np.broadcast_to(level, (N, F))[:, index] for level in floors], axis=0)
    heights = lifted_heights(x0[:, index] @ up, resting, rigid_pairs(x0[:, index], reach, resting), level)
    return index, heights, resting


def _roll_rows(x, jac, up, roll) -> tuple[np.ndarray, np.ndarray]:
    """(errors (N, R), rows (N, R, D)) of the roll rows `roll` (roll_targets) at positions x and
    Jacobian jac."""
    index, targets, active = roll
    error = np.where(active, targets - x[:, index] @ up, 0.0)
    return error, np.einsum("k,nhkd->nhd", up, jac[:, index]) * active[..., None]


def _goal_rows(x, jac, skeleton, held_rows, floors, balance, ground, longest):
    """(errors (N, H), rows (N, H, D)) of the contacts (along the ground: a contact holds a point
    still there, while the floor rows keep it out of the floor and the spring near its height in
    the capture), floor (`floors`: a (level, hold) of floor_rows each) and balance
    (ComOverSupport goals: two rows, the COM's ground position onto its point) rows at the
    positions `x` and Jacobian `jac`."""
    error, rows = _position_rows(x, jac, held_rows, longest, ground)
    errors, parts = [error], [rows]
    for level, hold in floors:
        F, margin = skeleton.n_frames, FLOOR_MARGIN * body_reach(skeleton)
        error, rows = floor_rows(x[:, :F], jac[:, :F], skeleton.up, level, margin, hold)
        errors.append(at_most(error[..., None], longest)[..., 0])
        parts.append(rows)
    for goal in balance:
        on = active_frames(goal, len(x))
        com = x[:, -1] @ ground.T
        track = np.broadcast_to(np.asarray(goal.point, float), x[:, -1].shape) @ ground.T
        errors.append(np.where(on[:, None], at_most(track - com, longest), 0.0))
        parts.append(np.einsum("ij,njd->nid", ground, jac[:, -1]) * on[:, None, None])
    return np.concatenate(errors, axis=1), np.concatenate(parts, axis=1)


class Lifting(NamedTuple):
    """How a warm start keeps the body above a Floor: `lift` a point that sinks in the capture
    along a smooth envelope of its depth (else only in the frames it sinks), lift each bone
    `whole`, and keep the joints or sites `soles` (each foot's heel and toe) at their capture
    heights while in contact (the feet's roll); the `surface` sites (trunk centres) are kept
    above it as any point, but count in no DOF's stiffness."""

    lift: bool = True
    whole: bool = False
    soles: tuple[str, ...] = ()
    surface: tuple[str, ...] = ()


LIFTING = Lifting()  # points lifted along envelopes, bones not whole, no soles


def warm_start(
    skeleton: Skeleton,
    original: np.ndarray,
    goals: Sequence[Goal],
    movable: np.ndarray,
    weights: np.ndarray,
    fade: float = FADE,
    lifting: Lifting = LIFTING,
) -> np.ndarray:
    """(N, D) displacement from the `original` poses (N, D), moving only the `movable` (N, D)
    DOFs, that meets the Position goals above REACH_LEVEL active in each frame (contacts),
    keeps every joint and site above a Floor, steers the centre of mass onto the points of its
    ComOverSupport goals (a balance track, cleanup/balance.py) and, below those, meets the
    Position goals on REACH_LEVEL (reach tracks), each change counted by `weights` (D,)
    (dof_weights). At most STEPS space-time steps over the whole clip (cleanup/spacetime.py,
    module notes): every frame's rows weighted (HELD_WEIGHT, REACH_WEIGHT) against the spring
    energy of the displacement with fade `fade` frames, so corrections start, stop and hand
    over between DOFs smoothly; with reach tracks, as many more that add them, moving only the
    frames of their (eased) windows, so a reach changes nothing outside them. A step moves a
    site or the COM at most LONGEST_STEP x reach, so an unreachable target is approached, not
    chased. With `lifting.lift`, a point that sinks through the floor in the capture is lifted
    along a smooth envelope of its depth (floor_lifts), from before it touches to after it
    leaves; without, only in the frames it sinks. With a Floor, the joints or sites
    `lifting.soles` (each foot's heel and toe) keep their height in the capture while in contact
    (module notes: the feet's roll). With `lift` and `whole`, a body is lifted whole (module
    notes). Limits are not applied here (fix_clip does)."""
    lift, whole, soles = lifting.lift, lifting.whole, lifting.soles
    held = [goal for goal in goals if isinstance(goal, Position) and goal.level < REACH_LEVEL]
    reach = [goal for goal in goals if isinstance(goal, Position) and goal.level == REACH_LEVEL]
    balance = [goal for goal in goals if isinstance(goal, ComOverSupport)]
    floors = [goal for goal in goals if isinstance(goal, Floor)]
    N, D = original.shape
    d = np.zeros((N, D))
    if not (held or reach or balance or floors):
        return d
    names = list(skeleton.frame_names) if floors else []
    names += [name for name in dict.fromkeys(goal.frame for goal in held + reach) if name not in names]
    held_rows, reach_rows = _rows(held, N, names), _rows(reach, N, names)
    ground = horizontal_axes(skeleton)
    movable = np.broadcast_to(np.asarray(movable, bool), (N, D))
    scale = np.where(weights > 0, 1.0 / np.where(weights > 0, weights, 1.0), 0.0)
    size = body_reach(skeleton)
    longest = LONGEST_STEP * size
    stiffness = motion_stiffness(skeleton, original, weights, lifting.surface)
    margin = FLOOR_MARGIN * size
    x0 = forward_kinematics(skeleton, original).p_world_frame if floors else None
    holds = [FLOOR_HOLD] * len(floors)
    if floors and not lift:
        floors = [floor_levels(g.height, margin, g.clearance) for g in floors]
    elif floors:
        # acceleration peaks per frame^2 (a frame time of 1): the lifts need no clock
        peaks = point_motion(x0, 1.0)[1].max(axis=0, initial=0.0)
        heights = x0 @ skeleton.up
        levels = [floor_levels(g.height, margin, g.clearance) for g in floors]
        floors = [floor_lifts(heights, level, peaks) for level in levels]
        if whole:
            bodies = rigid_bodies(skeleton, movable.any(axis=0))
            wholes = [whole_lifts(lifted, heights, level, bodies) for lifted, level in zip(floors, levels)]
            floors = [lifted for lifted, _ in wholes]
            holds = [np.where(raised, 1.0, FLOOR_HOLD) for _, raised in wholes]
    rolling = np.isin([names[i] for i in held_rows[0]], list(soles))
    roll = roll_targets(x0, skeleton.up, held_rows, rolling, floors, size) if floors and rolling.any() else None

    def rows_at(d, free, rolling=True):
        x, jac = position_jacobian(skeleton, original + d, names, centre_of_mass=bool(balance))
        floor_goals = list(zip(floors, holds))
        error, rows = _goal_rows(x, jac, skeleton, held_rows, floor_goals, balance, ground, longest)
        counted = np.ones(error.shape[1], bool)
        if roll is not None and rolling:
            roll_error, roll_part = _roll_rows(x, jac, skeleton.up, roll)
            error = np.concatenate([error, at_most(roll_error[..., None], longest)[..., 0]], axis=1)
            rows = np.concatenate([rows, roll_part], axis=1)
            counted = np.concatenate([counted, np.zeros(roll_error.shape[1], bool)])
        return x, jac, error, rows * (scale * free)[:, None, :], counted

    # first the contacts, floor and balance; then the reach tracks, moving only the frames of
    # their eased windows: outside them the fix is the same as without the reach
    phases = [(False, movable)] if (held or balance or floors) else []
    if reach:
        window = np.any([active_frames(goal, N) for goal in reach], axis=0)
        phases.append((True, movable & window[:, None]))
    for with_reach, free in phases:
        before = np.inf
        for k in range(STEPS):
            x, jac, error, rows, counted = rows_at(d, free, not with_reach)
            row_weights = np.where(counted, HELD_WEIGHT, ROLL_WEIGHT) * np.ones(error.shape)
            if with_reach:
                reach_error, reach_part = _position_rows(x, jac, reach_rows, longest)
                error = np.concatenate([error, reach_error], axis=1)
                rows = np.concatenate([rows, reach_part * (scale * free)[:, None, :]], axis=1)
                row_weights = np.concatenate([row_weights, np.full(reach_error.shape, REACH_WEIGHT)], axis=1)
                counted = np.concatenate([counted, np.ones(reach_error.shape[1], bool)])
            # the roll rows may stay unmet (a soft preference): the steps end on the others
            judged = error[:, counted]
            now = np.sqrt(np.mean(judged**2)) if judged.size else 0.0
            if np.abs(judged).max(initial=0.0) <= SETTLED * size or (k >= FIRST_STEPS and now >= before):
                break
            before = now
            damping = HELD_WEIGHT * DAMPING**2
            step = spacetime_step((rows, error, row_weights / size**2), d * weights, free, fade, damping, stiffness)
            d += step * scale * free
    return d


def at_most(vectors: np.ndarray, longest: float) -> np.ndarray:
    """vectors (..., k), each cut to a length of at most `longest`."""
    length = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors * np.minimum(1.0, longest / np.maximum(length, longest))

"""fix_clip(): fix every frame of a clip at once: a warm start, then DE repairs.

1. Warm start (warmstart.py, tried and calmed three ways in warm_tries.py): space-time least
   squares meets every frame's contacts, floor and reach targets and steers the centre of mass
   over the support (balance.py) with a displacement from the capture that is smooth over the
   whole clip (spacetime.py): a correction begins before its goal does and fades after it,
   nothing pops, and an idle arm keeps its performance.
2. DE passes repair the frames that still miss a floor, self-collision, contact, balance or
   reach goal (goals the warm start cannot all meet, such as balance over a single contact
   point, or self-collision, which lets a frame's repair move every DOF). Each pass is one
   batched solve of all N frame problems (one kernel launch on the CPU or the GPU): a frame
   that meets its goals gets a population of copies of its pose, which DE cannot move, and
   stops at once; the others are seeded around their current pose, moving only the DOFs their
   goals need, until every such goal is within tolerance (stop_on_converged), the fidelity and
   coherence terms (the last level) choosing among the poses that are.

The fix works on the body (cleanup/body.py): the clip's skeleton with the soles of its feet,
every tolerance a share of its span, the floor kept under the surface of each joint and site
(its clearance, cleanup/ground.py), the position channels the clip holds never moved. Last,
calm.py takes the change back wherever it makes a joint or site accelerate beyond its own peak
in the capture (no new pops); those frames are reported.

Time: the warm start (a block-banded solve per step, O(N D^3)), then per pass population x
(generations + 1) pose evaluations per repaired frame, about population per frame left alone.
Planted feet and reach tracks rarely need a repair (CLIP_SETTINGS, PASSES: a small budget);
balance leaves a few frames to DE (6 of the walk's 39): BALANCE_SETTINGS, BALANCE_PASSES.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable

import numpy as np

from deik.cleanup.balance import BalanceTrack
from deik.cleanup.body import Body, body_of, on_body, short_levers
from deik.cleanup.calm import calm
from deik.cleanup.clip_goals import (
    ClipGoals,
    clip_problem,
    fixed_goals,
    goal_errors,
    goal_names,
    met_frames,
    plants_at_heights,
    plants_moved,
    sized_goals,
)
from deik.cleanup.coherence import ease, hinge_channels, searched_dofs
from deik.cleanup.dynamics import newly_jolted, widened
from deik.cleanup.ground import clearances
from deik.cleanup.verdict import SLIDING_TOLERANCE
from deik.cleanup.warm_tries import calmed_warm_start, captured, ease_frames, inside_limits, longest_slides
from deik.cleanup.warmstart import dof_weights
from deik.errors import InputError
from deik.io.motion import held_translations, message_prefix
from deik.io.trajectory import Motion, Trajectory
from deik.memory import check_memory
from deik.model.joints import ROTATE
from deik.model.rotations import wrap_rotations
from deik.objectives.self_collision import SelfCollision
from deik.solver.footprint import solve_bytes
from deik.solver.seeding import poses_around
from deik.solver.settings import Settings
from deik.solver.solve import merge_settings, solve

# a repair is a local search among the DOFs its goals need: no restart from random poses (it
# would lose the performance), no LM polish (it moves the DOFs held still, hinge channels
# included, and met 21 of the walk's 39 balance frames against 39 without it)
LOCAL = {"stop_on_converged": True, "restarts": 0, "polish": 0}
CLIP_SETTINGS = {"population": 24, "generations": 60, "patience": 20, **LOCAL}
PASSES = 1
BALANCE_SETTINGS = {"population": 48, "generations": 300, "patience": 60, **LOCAL}
BALANCE_PASSES = 3
SPREAD = (0.001, 0.05)  # radians (x reach for translations): the finest and widest seed
MAX_PASSES = 1000  # a pass that repairs nothing leaves the next as hard: more is a typo


@dataclasses.dataclass(frozen=True)
class ClipFix:
    """The outcome of fix_clip: `clip` the fixed clip (same layout as the input, its Euler
    channels continuous from frame to frame: Clip.with_continuous_channels), `original`,
    `labels` of the goals (problem.goal_names), their `tolerances` (T,) (-1: none) and raw
    errors `before`/`after` (N, T) in length units or radians (NaN where a goal does not
    apply to a frame), `met` (N,) whether every floor, contact, balance and reach goal of each
    frame is within tolerance and no planted point steps further than the verdict's sliding
    tolerance from or to it (cleanup/verdict.py), `passes`, `wall_time` seconds, `settings`,
    and `stages`: where the time went,
    one dict per stage (the warm start, then each DE pass with the frames it repaired, their
    generations, mean and max, pose evaluations: population x (generations + 1) summed over
    them, and the failed repairs refused because they would make a frame jolt); `balance` the
    centre-of-mass track with --balance (its balanced and skipped frames, cleanup/balance.py),
    else None; `body` the body it was fixed on (cleanup/body.py), `calmed` (N,) the frames whose
    change was taken back so that nothing jolts (cleanup/calm.py), and `goals` the goals as
    fixed (every tolerance sized, the floor's clearance set)."""

    clip: object
    original: object
    labels: tuple[str, ...]
    tolerances: np.ndarray
    before: np.ndarray
    after: np.ndarray
    met: np.ndarray
    passes: int
    wall_time: float
    settings: Settings
    stages: tuple[dict, ...]
    balance: BalanceTrack | None = None
    body: Body | None = None
    calmed: np.ndarray | None = None
    goals: ClipGoals | None = None

    def on_body(self) -> tuple[Trajectory, Trajectory]:
        """(original, fixed) on the body's skeleton, soles included: what the reports measure."""
        return on_body(self.original, self.body), on_body(self.clip, self.body)


def _seeds(skeleton, poses: np.ndarray, searched: np.ndarray, count: int, seed: int) -> np.ndarray:
    """(N, count, D) whole populations around each frame's pose (a clip fix is a local
    search), spreads from fine to wide so DE can both polish and travel; DOFs not `searched`
    (N, D) are the same in every member, so DE never moves them."""
    spreads = np.geomspace(SPREAD[0], SPREAD[1], max(count - 1, 1))[: count - 1]
    seeds = poses_around(skeleton, poses, count, spreads, seed=seed)
    return np.where(searched[:, None, :], seeds, poses[:, None, :])


def _check_memory(clip: Motion, settings: Settings, n_terms: int = 1, n_levels: int = 1) -> None:
    """SolveError (deik.memory) when the warm start's point Jacobians (float64, 2 x N x F x 3 x D)
    or a DE pass's seeds (float64, 2 x N x population x D) and buffers would not fit the limit."""
    N, P, D, F = clip.n_frames, settings.population, clip.skeleton.n_dofs, clip.skeleton.n_frames
    fix = "clean fewer frames at a time, or a rig with fewer joints"
    check_memory(6 * N * F * D * 8, settings.memory_limit, f"the warm start of {N} frames x {F} joints and sites", fix)
    itemsize = np.dtype(settings.dtype).itemsize
    needed = 2 * N * P * D * 8 + solve_bytes(N, P, D, n_terms, n_levels, itemsize, settings.generations)
    fix = "use a smaller population or generation budget (--population, --generations)"
    check_memory(needed, settings.memory_limit, f"a clip fix of {N} frames x population {P}", fix)


def _time_left(settings: Settings, deadline: float) -> Settings:
    """`settings` with the time left until `deadline` (perf_counter seconds) as its time limit."""
    return dataclasses.replace(settings, time_limit=max(deadline - time.perf_counter(), 1e-3))


def _pass_progress(progress, met: int, stage: str):
    """solve()'s progress callback during a DE pass: progress(met, "STAGE, generation G")."""
    return lambda generation, best: progress(met, f"{stage}, generation {generation}")


def _colliding(problem, errors: np.ndarray) -> np.ndarray:
    """(N,) frames whose self-collision goal (if any) misses its tolerance."""
    terms = [t for t, goal in enumerate(problem.goals) if isinstance(goal, SelfCollision)]
    return (errors[:, terms] > problem.table.term_float[terms, 3]).any(axis=1)


def _without_jolts(clip, displacement, found, repaired, searched, body, goals) -> tuple[np.ndarray, int]:
    """(displacement (N, D), refused): the `repaired` (N,) frames take the DE's displacements
    `found` (N, D) on their `searched` (N, D) DOFs; only that change is eased into the DOFs and
    frames no search moved (coherence.ease), so outside a repair's easing `displacement` stays
    as it was. A repair is refused where it would make a frame jolt (dynamics.newly_jolted: in a
    frame that jolted already, turn a joint more than FAR_DEGREES from the pose it repairs); a
    DE search starts each frame afresh and may land a pose apart from its neighbours'. The
    repairs within an easing of a new jolt are refused and the rest tried again, until none
    jolts (all of them when a new jolt lies beyond every repair's easing). `refused` counts them
    (they are listed unmet). Jolts are measured against the capture (captured(clip, goals))."""
    sk, original = clip.skeleton, clip.poses()
    reach = int(np.ceil(ease_frames(clip)))
    reference = captured(clip, goals)

    def taken(frames):
        change = np.where(frames[:, None] & searched, found - displacement, 0.0)
        return inside_limits(sk, original, displacement + ease(change, searched, ease_frames(clip)))

    current = clip.with_frames(clip.frames + displacement)
    kept = repaired.copy()
    while kept.any():
        candidate = taken(kept)
        new = newly_jolted(reference, current, clip.with_frames(clip.frames + candidate), body.points)
        if not new.any():
            return candidate, int((repaired & ~kept).sum())
        near = widened(new, reach)
        kept &= ~near if (kept & near).any() else np.zeros_like(kept)  # a jolt beyond every repair's reach: none
    return displacement, int(repaired.sum())


def fix_clip(
    clip: Motion,
    goals: ClipGoals,
    passes: int | None = None,
    settings: Settings | None = None,
    *,
    progress: Callable[[int, str], object] | None = None,
    body: Body | None = None,
    **overrides: object,
) -> ClipFix:
    """Fix every frame of `clip` (a deik.Clip) for `goals` on its `body` (default body_of(clip);
    contacts may name its sole sites): the warm start (run a second time on plants moved where
    the first tipped a foot out of the floor, clip_goals.plants_at_heights), then up to
    `passes` >= 0 DE passes (default PASSES, BALANCE_PASSES with balance or self-collision)
    over the frames that still miss a floor, self-collision, contact, balance or reach goal;
    settings default to CLIP_SETTINGS (BALANCE_SETTINGS with balance) and may be overridden
    by keyword (population, generations, seed, device, ...). `time_limit` (seconds) bounds the
    DE passes: none starts after it, and each gets the time left (the warm start always runs);
    a pass over more memory than `memory_limit` allows is refused (SolveError) before the
    warm start.
    `wall_time` counts all but measuring the result; `passes` those that ran. `progress(met,
    stage)`, if given, is called with the number of frames that meet their goals after the
    warm start and each DE pass, during a pass every 100 generations, and once at the end.
    Last, the change is taken back wherever it makes a joint or site jolt (cleanup/calm.py)."""
    if not isinstance(goals, ClipGoals):
        raise TypeError(f"goals must be a deik.cleanup.clip_goals.ClipGoals, got {type(goals).__name__}")
    if passes is None:  # a collision repair eased into its neighbours can push them into collision
        passes = BALANCE_PASSES if goals.balance or goals.self_collision is not None else PASSES
    if isinstance(passes, bool) or not (isinstance(passes, int) and 0 <= passes <= MAX_PASSES):
        raise InputError(f"passes must be a whole number from 0 to {MAX_PASSES}, got {passes!r}")
    if clip.n_frames == 0:
        raise InputError(f"{message_prefix(clip)}the clip has no frames (Frames: 0) to fix; give one with motion")
    if goals.captured is not None and goals.captured.frames.shape != clip.frames.shape:
        raise InputError(f"goals.captured has frames {goals.captured.frames.shape}, not the clip's: give its capture")
    if clip.skeleton.n_dofs == 0:
        raise InputError(f"{message_prefix(clip)}the clip has no channels: no joint moves, nothing to fix")
    defaults = BALANCE_SETTINGS if goals.balance else CLIP_SETTINGS
    settings = merge_settings("fix_clip()", settings, overrides, defaults)
    _check_memory(clip, settings)  # before any work: the smallest a pass can take
    start = time.perf_counter()
    deadline = None if settings.time_limit is None else start + settings.time_limit
    written, body = clip, body_of(clip) if body is None else body
    clip = on_body(written, body)
    goals = sized_goals(goals, body.span)
    if goals.captured is not None:  # on the body once: its kinematics and peaks are then computed once
        goals = dataclasses.replace(goals, captured=on_body(goals.captured, body))
    if goals.floor is not None and goals.floor_clearance is None:
        goals = dataclasses.replace(goals, floor_clearance=clearances(body))
    sk = clip.skeleton
    rotation = sk.dof_kind == ROTATE
    original = clip.poses()
    weights = dof_weights(clip, body.own)
    fixed_dofs = hinge_channels(clip) | held_translations(sk, clip.frames)
    movable = np.broadcast_to(~fixed_dofs & ~short_levers(body, clip), original.shape)
    displacement, first_calmed, fixed_part, balance, reached = calmed_warm_start(clip, goals, weights, movable, body)
    if goals.contacts is not None:  # the warm start holds contacts along the ground: so does DE
        fix_alone = displacement if reached is None else displacement - reached  # a reach drags no plant
        fitted = plants_at_heights(clip, goals, original + fix_alone)
        if plants_moved(clip, goals, fitted):  # a foot tipped out of the floor: again, on plants it can meet
            displacement, first_calmed, fixed_part, balance, reached = calmed_warm_start(
                clip, fitted, weights, movable, body
            )
            goals = fitted
        goals = plants_at_heights(clip, goals, original + displacement)
        fixed_part = fixed_goals(clip, goals, weights, balance)
    searched = searched_dofs(clip, fixed_part)
    stages = [{"stage": "warm start", "seconds": time.perf_counter() - start, "calmed": int(first_calmed.sum())}]
    report = progress or (lambda met, stage: None)
    for k in range(passes):
        began = time.perf_counter()
        problem = clip_problem(clip, goals, displacement, weights, fixed_part)
        # wrapping rounds: a DOF at a limit short of a whole turn (a robot's) may land an ulp outside
        current = np.clip(wrap_rotations(original + displacement, rotation), sk.lower, sk.upper)
        errors, met = met_frames(problem, current)
        unmet = ~met
        report(int(met.sum()), stages[-1]["stage"])
        if not unmet.any() or (deadline is not None and time.perf_counter() >= deadline):
            break
        _check_memory(clip, settings, problem.table.n_terms, problem.table.n_levels)
        # a frame in collision may move every DOF but the hinge channels
        searched = searched | (_colliding(problem, errors)[:, None] & ~fixed_dofs[None, :])
        # a frame that meets its goals keeps one pose in every member: DE cannot move it
        initial = _seeds(sk, current, searched & unmet[:, None], settings.population, settings.seed + 7919 * k)
        stage = f"DE pass {k + 1}"
        during = _pass_progress(progress, int((~unmet).sum()), stage) if progress else None
        budget = settings if deadline is None else _time_left(settings, deadline)
        result = solve(problem, budget, initial=initial, progress=during)
        found = wrap_rotations(result.angles - original, rotation)
        displacement, refused = _without_jolts(clip, displacement, found, unmet, searched, body, goals)
        generations = result.generations[unmet]
        stages.append(
            {
                "stage": stage,
                "seconds": time.perf_counter() - began,
                "frames": int(unmet.sum()),
                "generations_mean": float(generations.mean()),
                "generations_max": int(generations.max()),
                "evaluations": int(settings.population * (generations + 1).sum()),
                "refused": refused,
            }
        )
    began = time.perf_counter()
    reference = captured(clip, goals)
    if reached is None:
        displacement, calmed = calm(clip, displacement, body.points, captured=reference)
    else:  # what the reach tracks add is the user's motion: calm the rest on top of it
        rest, calmed = calm(clip, displacement - reached, body.points, base=reached, captured=reference)
        displacement = reached + rest
    calmed |= first_calmed
    stages.append({"stage": "calm", "seconds": time.perf_counter() - began, "calmed": int(calmed.sum())})
    wall = time.perf_counter() - start
    logging.getLogger(__name__).debug(
        "clip fix of %d frames: %s", clip.n_frames, "; ".join(f"{s['stage']} {s['seconds']:.2f} s" for s in stages)
    )
    problem = clip_problem(clip, goals, displacement, weights, fixed_part)
    after, met = met_frames(problem, wrap_rotations(original + displacement, rotation))
    if goals.contacts is not None:  # a plant that moves (a rolling heel's) may be met in two frames a step apart
        met &= longest_slides(clip, displacement, (goals.contacts, None)) <= SLIDING_TOLERANCE * body.span
    report(int(met.sum()), "done")
    return ClipFix(
        clip=written.with_frames(written.frames + displacement).with_continuous_channels(),
        original=written,
        labels=tuple(goal_names(goals)),
        tolerances=problem.table.term_float[: len(problem.goals), 3].copy(),
        before=goal_errors(problem, original),
        after=after,
        met=met,
        passes=len(stages) - 2,
        wall_time=wall,
        settings=settings,
        stages=tuple(stages),
        balance=balance,
        body=body,
        calmed=calmed,
        goals=goals,
    )

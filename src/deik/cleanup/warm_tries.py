"""The warm start of a clip fix (cleanup/fix.py), tried and calmed: the space-time warm start
(warmstart.py) with the floor lifted along envelopes, lifted with each bone whole, and on the
plain floor; each calmed (calm.py) by cutting its change back and, where that takes something
back, by smoothing it first, the smoothed stretches kept where they do better; and the try kept
as warm_choice.py says. A try is judged as the report's verdict judges a frame
(cleanup/verdict.py): its goals, and no point that rests in the capture sliding.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from deik.cleanup.body import Body
from deik.cleanup.bone_points import BonePoints
from deik.cleanup.calm import calm
from deik.cleanup.clip_goals import (
    FLOOR_LEVEL,
    ClipGoals,
    clip_balance,
    clip_problem,
    fixed_goals,
    floor_depths,
    frames_within,
    met_frames,
    plants_at_heights,
)
from deik.cleanup.contacts import Contacts
from deik.cleanup.dynamics import jolted_frames, widened
from deik.cleanup.verdict import SLIDING_TOLERANCE, capture_grounding, resting_slides
from deik.cleanup.warm_choice import DEEP, Tried, chosen, far_frames, smoothed_stretches
from deik.cleanup.warmstart import Lifting, warm_start
from deik.io.trajectory import Motion
from deik.model.joints import ROTATE
from deik.model.rotations import wrap_rotations
from deik.model.skeleton import Skeleton

EASE_SECONDS = 0.25  # how long a displacement takes to decay where no goal holds it
GUARD_ROUNDS = 4  # balanced warm starts: the first, then those skipping balance where it made frames jolt
GUARD_REACH = 2  # frames either side of a jolt whose balance is skipped


def inside_limits(skeleton: Skeleton, original: np.ndarray, displacement: np.ndarray) -> np.ndarray:
    """`displacement` (N, D) from `original` (N, D) cut back to the joint limits, except on
    rotations free over a whole turn (they wrap)."""
    inside = np.clip(original + displacement, skeleton.lower, skeleton.upper) - original
    return np.where(skeleton.full_turns, displacement, inside)


def _warm_start(
    clip, goals: ClipGoals, weights: np.ndarray, movable: np.ndarray, body: Body, lift: bool, roll: bool, whole=False
):
    """(displacement (N, D), the fixed goals, the balance track or None): the warm start of
    `goals` on `body`, with or without floor `lift`s (each bone lifted `whole` or not) and the
    feet's `roll` (warmstart.warm_start: the heel and toe of each of body.feet keep their
    heights in the capture). With balance, the track is
    planned on the motion with its contacts met (a first warm start without it), and where the
    balanced warm start makes a frame jolt or turns a joint far from the capture
    (cleanup/dynamics.py), balance cannot hold there: those frames and their neighbours are
    skipped and the track planned again, up to GUARD_ROUNDS warm starts."""
    sk, original, points = clip.skeleton, clip.poses(), body.points
    soles = [name for foot in body.feet for name in (foot.heel, foot.toe)] if roll else []

    def warm(plain: ClipGoals, track):
        fixed = fixed_goals(clip, plain, weights, track)
        fade = ease_frames(clip)
        lifting = Lifting(lift, whole, tuple(soles), body.centres)
        d = warm_start(sk, original, fixed, movable, weights, fade=fade, lifting=lifting)
        return inside_limits(sk, original, d), fixed

    if not goals.balance:
        return *warm(goals, None), None
    displacement, _ = warm(dataclasses.replace(goals, balance=False), None)
    unbalanced = clip.frames + displacement
    balance = clip_balance(clip, goals, frames=unbalanced)
    for round_ in range(GUARD_ROUNDS):
        displacement, fixed = warm(goals, balance)
        jolted = jolted_frames(captured(clip, goals), clip.with_frames(clip.frames + displacement), points=points)
        jolting = widened(jolted, GUARD_REACH) & balance.balanced
        if round_ == GUARD_ROUNDS - 1 or not jolting.any():
            break
        balance = clip_balance(clip, goals, skip=balance.skipped | jolting, frames=unbalanced)
    return displacement, fixed, balance


def captured(clip: Motion, goals: ClipGoals) -> Motion:
    """The capture whose peaks a fix of `clip` keeps within: goals.captured (on its body), or the clip."""
    return clip if goals.captured is None else goals.captured


def calmed_warm_start(clip: Motion, goals: ClipGoals, weights: np.ndarray, movable: np.ndarray, body: Body) -> tuple:
    """(displacement (N, D), taken back (N,) bool, the fixed goals, the balance track or None,
    what the reach tracks add (N, D) or None): the warm start, calmed (cleanup/calm.py: each
    try cut back, and where that takes something back also smoothed first; DE repairs what is
    taken back). With a floor it is tried with the floor lifted along smooth
    envelopes and the feet rolling as captured, so lifted with each bone lifted whole
    (warmstart.whole_lifts), and on the plain floor without either, and kept as
    cleanup/warm_choice.py says (contacts judged along the ground, as the warm start holds
    them: _judged): an envelope lets a landing foot slow down before the floor, and a bone
    lifted whole lands without tipping, but on a body lying on the floor for long either can
    ask more than the joints give without a jolt. Reach tracks are the user's motion: what
    they add on the plain floor (the feet rolling if they do in the fix) is added, not
    calmed, on top of the fix without them, so outside a reach's window the clip is the same as
    without it (and an unreachable reach drags no planted foot: on the lifted floor it dragged
    a toe 10 mm)."""
    alone = goals.contacts or goals.balance or goals.floor is not None or goals.self_collision is not None
    plain, outcomes = dataclasses.replace(goals, reach=()) if alone else None, {}
    tried = ((True, False), (True, True), (False, False)) if goals.floor is not None else ((False, False),)

    def rated(warm: tuple, calmed: tuple, smoothed: bool = False) -> tuple:
        """(Tried, (displacement, taken back, fixed goals, balance track, None), the warm
        displacement) of the warm start `warm` (its displacement, fixed goals, balance track)
        `calmed` to (displacement (N, D), taken back (N,))."""
        displacement, taken = calmed
        poses = wrap_rotations(clip.poses() + displacement, clip.skeleton.dof_kind == ROTATE)
        problem = _judged(clip, plain, displacement, weights, *warm[1:])
        errors, met = met_frames(problem, poses)
        on_floor = frames_within(problem, errors, lambda level: level == FLOOR_LEVEL)
        slides = longest_slides(clip, displacement, rests)
        met &= slides <= SLIDING_TOLERANCE * body.span
        sunk = floor_depths(problem, errors) > DEEP * body.span
        how = Tried(on_floor, met, taken, far_frames(clip, displacement), slides, smoothed, sunk)
        return how, (displacement, taken, *warm[1:], None), warm[0]

    reference, rests = captured(clip, goals), _rests(clip, goals, body)
    for lift, whole in tried if alone else ():
        warm = _warm_start(clip, plain, weights, movable, body, lift, lift, whole)
        outcomes[lift, whole, False] = rated(warm, calm(clip, warm[0], body.points, captured=reference))
        if outcomes[lift, whole, False][0].perfect():  # none can do better, and the first wins a tie
            break
    # smoothed where that does better, a try is kept only where it puts more frames on the floor
    if outcomes and max(outcome[0].counts()[0] for outcome in outcomes.values()) < clip.n_frames:
        for (lift, whole, _), (cut, (cut_back, taken, fixed, balance, _), warm) in list(outcomes.items()):
            if not taken.any():  # nothing jolts: smoothing changes nothing
                continue
            start = (warm, fixed, balance)
            smoothed = calm(clip, warm, body.points, captured=reference, smooth=True)
            every = rated(start, smoothed, smoothed=True)
            better = smoothed_stretches(cut, every[0], SLIDING_TOLERANCE * body.span)
            if (better | ~(taken | smoothed[1])).all():  # every stretch smoothed: that is the try
                outcomes[lift, whole, True] = every
            elif better.any():
                mixed = (np.where(better[:, None], smoothed[0], cut_back), np.where(better, smoothed[1], taken))
                outcomes[lift, whole, True] = rated(start, mixed, smoothed=True)
    tries = {key: outcome[0] for key, outcome in outcomes.items()}
    kept = chosen(tries) if outcomes else (False, False, False)
    best, lifted = outcomes.get(kept), kept[0]
    if not goals.reach:
        return best[1]
    displacement, fixed, balance = _warm_start(clip, goals, weights, movable, body, False, lifted)
    if not alone:  # reach tracks only: all of the change is theirs
        return displacement, np.zeros(clip.n_frames, bool), fixed, balance, displacement
    # what the reach adds on the plain floor, with the feet rolling as in the fix it is added to
    plain_floor = outcomes.get((False, False, False))
    base = plain_floor[2] if not lifted else _warm_start(clip, plain, weights, movable, body, False, True)[0]
    added = displacement - base
    held, calmed = best[1][:2]
    return held + added, calmed, fixed, balance, added


def _rests(clip, goals: ClipGoals, body: Body) -> tuple[Contacts, BonePoints | None] | None:
    """(points, points along the bones) of `clip` (on the `body`) that rest in the capture, as
    the report's verdict counts them (verdict.capture_grounding): with no floor, the planted
    contacts; None where nothing rests."""
    if goals.floor is None:
        return None if goals.contacts is None else (goals.contacts, None)
    grounding = capture_grounding(clip, body, goals.floor)
    return grounding.resting, grounding.along


def longest_slides(clip: Motion, displacement: np.ndarray, rests: tuple | None) -> np.ndarray:
    """(N,) the longest step along the ground to or from each frame of `clip` moved by
    `displacement` (N, D) of a point that `rests` (_rests) in both (verdict.resting_slides), as
    the report's verdict counts it: a point can meet a plant that moves (a rolling heel's) in
    two frames and step further between them, and a point no contact holds slides where a fix
    turns the limb that carries it."""
    if rests is None:
        return np.zeros(clip.n_frames)
    return resting_slides(clip.with_frames(clip.frames + displacement), *rests)


def _judged(clip, goals: ClipGoals, displacement: np.ndarray, weights: np.ndarray, fixed, balance):
    """The clip problem that judges a warm start's `displacement` (N, D) of `goals` (their
    `fixed` goals, with `balance`'s track): its contacts at the heights the displacement gives
    them (clip_goals.plants_at_heights), since a warm start holds them still along the ground only."""
    if goals.contacts is None:
        return clip_problem(clip, goals, displacement, weights, fixed)
    judged = plants_at_heights(clip, goals, clip.poses() + displacement)
    return clip_problem(clip, judged, displacement, weights, fixed_goals(clip, judged, weights, balance))


def ease_frames(clip: Motion) -> float:
    """EASE_SECONDS in frames of `clip` (at least 2, at most its length: longer is the same)."""
    return min(max(EASE_SECONDS / clip.frame_time, 2.0), max(clip.n_frames, 2))

"""The feet's roll and lift-off (cleanup/warmstart.py, cleanup/ground.py), on motions whose answer
is known: the procedural walk (benchmarks/clip_walk.py: each foot flat and still through its
stance) raised 1 cm, so its resting soles sit above the floor where nothing but the fix holds
their height, and skating (the whole body swaying 2 cm back and forth along the walk), so each
plant holds a foot where the capture slides it; and resting runs made of points whose motion is
given frame by frame."""

import dataclasses

import numpy as np

from benchmarks.clip_rigs import format_rig
from benchmarks.clip_walk import procedural_walk
from deik.cleanup.body import on_body
from deik.cleanup.clip_goals import ClipGoals, fixed_goals, sized_goals
from deik.cleanup.coherence import hinge_channels
from deik.cleanup.ground import GAP, clearances, rest_runs, resting_body
from deik.cleanup.warmstart import Lifting, dof_weights, warm_start
from deik.io.bvh import parse_bvh
from deik.model.kinematics import forward_kinematics

RAISED, SWAY, SWAY_PERIOD = 0.01, 0.02, 0.55  # metres, metres, seconds


def skating_walk():
    """The procedural walk raised RAISED and swaying SWAY along X (a sine of SWAY_PERIOD), as a Clip."""
    walk = procedural_walk()
    rig = walk.rig
    frames = rig.frames.copy()
    t = np.arange(len(frames)) * rig.frame_time
    frames[:, rig.columns.index((0, "Xposition"))] += SWAY * np.sin(2 * np.pi * t / SWAY_PERIOD)
    frames[:, rig.columns.index((0, "Yposition"))] += RAISED
    return parse_bvh(format_rig(dataclasses.replace(rig, frames=frames)), "skating.bvh")


def warm_sole_heights(soles: bool):
    """(capture, warm start) heights (N, S) of the contact sites, the contacts, and which of them
    are a foot's heel or toe: the skating walk's default contacts and floor, warm-started with
    the feet rolling (`soles`) or without."""
    clip = skating_walk()
    body, floor, contacts = resting_body(clip)
    motion = on_body(clip, body)
    goals = sized_goals(ClipGoals(contacts, floor=floor.height, floor_clearance=clearances(body)), body.span)
    weights = dof_weights(motion)
    names = [name for foot in body.feet for name in (foot.heel, foot.toe)]
    movable = np.broadcast_to(~hinge_channels(motion), motion.frames.shape)
    d = warm_start(body.skeleton, motion.poses(), fixed_goals(motion, goals, weights), movable, weights,
                   lifting=Lifting(soles=tuple(names) if soles else ()))  # fmt: skip
    index = [body.skeleton.frame_index(site) for site in contacts.sites]
    heights = [forward_kinematics(body.skeleton, frames).p_world_frame[:, index] @ body.skeleton.up
               for frames in (motion.frames, motion.frames + d)]  # fmt: skip
    return *heights, contacts, np.isin(contacts.sites, names)


def test_resting_heels_and_toes_keep_their_height_where_their_plants_hold_them_against_a_slide():
    before, after, contacts, sole = warm_sole_heights(soles=True)
    assert sole.sum() == 4  # each foot's heel and toe
    resting = contacts.mask[:, sole]
    assert resting.any(axis=0).all() and before[:, sole][resting].min() > 0.5 * RAISED  # above the floor
    change = np.abs(after - before)[:, sole][resting]
    assert change.max() < 5e-4  # within half a millimetre of the capture
    # the plant alone leaves their height to the spring: it drifts by millimetres
    _, drifting, _, _ = warm_sole_heights(soles=False)
    assert np.abs(drifting - before)[:, sole][resting].max() > 3e-3


def test_a_resting_run_ends_before_the_frames_a_lift_off_moves_into_at_more_than_resting_speed():
    dt, step, n = 1 / 30, 0.005, 30  # s; metres a resting point may move in a frame; frames
    gap = int(round(GAP / dt))
    assert gap == 2  # frames: the most a run loses at its end
    x = np.zeros(n)
    x[:5] = 0.05 - 0.01 * np.arange(5)  # arriving fast: 10 mm a frame into the rest's first frame
    x[20:] = np.cumsum(np.full(n - 20, 3 * step))  # still, then away at three times resting speed
    positions = np.stack([x, np.zeros(n), np.zeros(n)], axis=-1)[:, None, :]
    mask = np.zeros((n, 1), bool)
    mask[5:22] = True  # a speed averaged over neighbouring frames would still call 20 and 21 slow
    kept = rest_runs(mask, dt, positions, step)[:, 0]
    assert np.flatnonzero(kept).tolist() == list(range(5, 20))  # the landing keeps its first frame
    # at most `gap` frames go: a point that never stops keeps the rest of its run
    moving = np.stack([np.cumsum(np.full(n, 3 * step)), np.zeros(n), np.zeros(n)], axis=-1)[:, None, :]
    assert np.flatnonzero(rest_runs(mask, dt, moving, step)[:, 0]).tolist() == list(range(5, 22 - gap))
    # slower than `step`, or without positions, nothing goes
    assert (rest_runs(mask, dt, positions, 4 * step)[:, 0] == mask[:, 0]).all()
    assert (rest_runs(mask, dt)[:, 0] == mask[:, 0]).all()

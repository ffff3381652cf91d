"""The feet's roll and lift-off (cleanup/warmstart.py, cleanup/ground.py), on motions whose answer
is known: the procedural walk (judging/walk.py: each foot flat and still through its
stance) raised 1 cm, so its resting soles sit above the floor where nothing but the fix holds
their height, and skating (the whole body swaying 2 cm back and forth along the walk), so each
plant holds a foot where the capture slides it; the walk with one foot swivelling on its heel
(its toe creeping, then moving 2 cm in a frame); and resting runs made of points whose motion
is given frame by frame."""

import dataclasses

import numpy as np

import deik
from deik.cleanup.body import on_body
from deik.cleanup.clip_goals import ClipGoals, fixed_goals, sized_goals
from deik.cleanup.coherence import hinge_channels
from deik.cleanup.ground import GAP, clearances, rest_runs, resting_body
from deik.cleanup.warmstart import Lifting, dof_weights, warm_start
from deik.io.bvh import parse_bvh
from deik.model.kinematics import forward_kinematics
from judging.rigs import format_rig
from judging.walk import procedural_walk

RAISED, SWAY, SWAY_PERIOD = 0.01, 0.02, 0.55  # metres, metres, seconds
CREEP, SWIVEL, SWIVEL_FRAME = 0.5, 8.0, 9  # degrees a frame, degrees in one frame, its frame


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
    # a run to the clip's last frame keeps it: a step into it may be noise, and what follows unknown
    mask[22:] = True
    assert rest_runs(mask, dt, positions, step)[-1, 0]


def swivelling_walk():
    """The procedural walk whose right foot, standing from frame 0 to 20, turns on its ankle
    (about up) CREEP degrees a frame and SWIVEL more into frame SWIVEL_FRAME, as a Clip."""
    rig = procedural_walk().rig
    frames = rig.frames.copy()
    k = np.arange(len(frames))
    yaw = CREEP * np.minimum(k, 20) + SWIVEL * (k >= SWIVEL_FRAME)
    frames[:, rig.columns.index((rig.names.index("RightAnkle"), "Yrotation"))] += yaw
    return parse_bvh(format_rig(dataclasses.replace(rig, frames=frames)), "swivelling.bvh")


def test_a_toe_swivelling_between_two_rests_moves_as_far_as_captured():
    """The toe rests before and after its swivel (a move, not a step: ground.py) while creeping
    1.2 mm a frame: the cleaned toe holds still in both rests and moves between them as far as
    the capture does (22 mm); planted at each rest's own median it moved 32 mm, faster than
    captured (the shared punch's front toe lost its rest before such a move so)."""
    clip = swivelling_walk()
    body, _, contacts = resting_body(clip)
    toe = body.feet[0].toe if "Right" in body.feet[0].ankle else body.feet[1].toe
    (a, b), (c, d) = contacts.intervals(toe)[:2]
    assert b <= SWIVEL_FRAME < c and c - b <= round(GAP / clip.frame_time)  # a move between two rests
    cleaned = deik.clean_clip(clip)
    f = body.skeleton.frame_index(toe)
    before, after = (
        forward_kinematics(body.skeleton, on_body(motion, body).frames).p_world_frame[:, f][:, [0, 2]]
        for motion in (clip, cleaned.clip)
    )
    captured, moved = (np.linalg.norm(x[c] - x[b - 1]) for x in (before, after))
    assert captured > 0.02 and abs(moved - captured) < 1e-3
    steps = np.linalg.norm(np.diff(after, axis=0), axis=1)  # steps[n]: from frame n to n + 1
    assert steps[a + 5 : b - 1].max() < 1e-4 and steps[c : d - 1].max() < 1e-3  # still (the first frames ease in)

"""Which frames a report calls met (cleanup/verdict.py), on the procedural walk (benchmarks/clip_walk.py:
each foot flat and still on the floor at 0 through its stance) changed in known frames: the body
shifted along the ground from one frame on (every resting point slides in that step), the body
lowered in one frame (its soles under the floor), a shin turned about the knee while it lies on
the floor. The verdict must list exactly those frames, and none of the capture's own."""

import numpy as np
import pytest

from benchmarks.clip_rigs import format_rig
from benchmarks.clip_walk import procedural_walk
from deik.cleanup.body import PALM, body_of, on_body
from deik.cleanup.clip_goals import CONTACT_TOLERANCE, FLOOR_TOLERANCE
from deik.cleanup.ground import clearances, detect_resting
from deik.cleanup.summary import Grounding
from deik.cleanup.verdict import SLIDING_TOLERANCE, bone_sliding_frames, frame_verdict
from deik.io.bvh import parse_bvh
from deik.model.joints import TRANSLATE


@pytest.fixture(scope="module")
def walk():
    """(the walk on its body, the body, the grounding at the floor 0)."""
    case = procedural_walk()
    clip = parse_bvh(format_rig(case.rig), "walk.bvh")
    body = body_of(clip)
    motion = on_body(clip, body)
    return motion, body, Grounding(0.0, clearances(body), detect_resting(motion, body, 0.0))


def root_channel(motion, axis: int) -> int:
    """The root's translation DOF along world axis `axis` (0 X, 1 Y)."""
    sk = motion.skeleton
    dofs = [d for d in range(sk.n_dofs) if sk.dof_kind[d] == TRANSLATE and sk.dof_joint[d] == 0]
    return dofs[axis]


def verdict(walk, frames):
    motion, body, grounding = walk
    return frame_verdict(np.ones(motion.n_frames, bool), motion, motion.with_frames(frames), body, grounding)


def test_the_capture_itself_is_clean(walk):
    motion, _, grounding = walk
    assert grounding.resting.sites and grounding.resting.mask.any()
    outcome = verdict(walk, motion.frames)
    assert outcome.met.all() and not outcome.sliding.any() and not outcome.sunk.any()


def test_a_step_along_the_ground_lists_exactly_its_two_frames(walk):
    motion, body, grounding = walk
    resting = grounding.resting.mask.any(axis=1)
    k = int(np.flatnonzero(resting[1:] & resting[:-1])[len(resting) // 3]) + 1  # rests in k-1 and k
    frames = motion.frames.copy()
    frames[k:, root_channel(motion, 0)] += 3 * SLIDING_TOLERANCE * body.span
    outcome = verdict(walk, frames)
    assert np.flatnonzero(~outcome.met).tolist() == [k - 1, k] == np.flatnonzero(outcome.sliding).tolist()
    assert not outcome.sunk.any()
    small = motion.frames.copy()
    small[k:, root_channel(motion, 0)] += 0.5 * SLIDING_TOLERANCE * body.span  # within tolerance
    assert verdict(walk, small).met.all()


def test_a_body_lowered_in_one_frame_lists_that_frame(walk):
    motion, body, _ = walk
    m = motion.n_frames // 2
    frames = motion.frames.copy()
    frames[m, root_channel(motion, 1)] -= 3 * FLOOR_TOLERANCE * body.span
    outcome = verdict(walk, frames)
    assert np.flatnonzero(~outcome.met).tolist() == [m] == np.flatnonzero(outcome.sunk).tolist()
    assert not outcome.sliding.any()


def test_the_goals_missed_stay_listed(walk):
    motion, body, grounding = walk
    goals = np.ones(motion.n_frames, bool)
    goals[[2, 5]] = False
    outcome = frame_verdict(goals, motion, motion, body, grounding)
    assert np.flatnonzero(~outcome.met).tolist() == [2, 5]


def test_a_bone_turning_about_its_resting_end_is_sliding(walk):
    """A foot flat on the floor that turns about its ankle by a small angle in one frame: the
    ankle hardly moves, its toe and the points along the foot's bone slide. The frames of the two
    steps (into and out of the turned frame) are listed, by the bone's points alone too."""
    motion, body, grounding = walk
    sk = motion.skeleton
    ankle = body.feet[0].ankle
    resting = grounding.resting.mask[:, grounding.resting.sites.index(body.feet[0].toe)]
    m = int(np.flatnonzero(resting[:-2] & resting[1:-1] & resting[2:])[0]) + 1
    yaw = [d for d in range(sk.n_dofs) if sk.dof_joint[d] == sk.frame_index(ankle) and sk.dof_kind[d] != TRANSLATE]
    frames = motion.frames.copy()
    foot = np.linalg.norm(motion.kinematics.position(body.feet[0].toe)[m] - motion.kinematics.position(ankle)[m])
    turned = None
    for d in yaw:  # the channel that swings the toe along the ground
        trial = frames.copy()
        trial[m, d] += 6 * SLIDING_TOLERANCE * body.span / foot
        p = motion.with_frames(trial).kinematics.position(body.feet[0].toe)[m]
        q = motion.kinematics.position(body.feet[0].toe)[m]
        if abs((p - q) @ sk.up) < 0.2 * np.linalg.norm(p - q):
            turned = trial
            break
    assert turned is not None
    outcome = verdict(walk, turned)
    assert np.flatnonzero(outcome.sliding).tolist() == [m - 1, m, m + 1]
    tolerance = SLIDING_TOLERANCE * body.span
    along = bone_sliding_frames(motion, motion.with_frames(turned), body, 0.0, tolerance)
    assert np.flatnonzero(along).tolist() == [m - 1, m, m + 1]


def test_a_hand_is_as_broad_as_a_palm(walk):
    _, body, _ = walk
    radius = dict(zip(body.skeleton.frame_names, body.radius))
    p = body.skeleton
    elbow_to_wrist = np.linalg.norm([o for n, o in zip(p.site_names, p.site_offset) if n == "RightElbow_end"][0])
    assert radius["RightElbow_end"] == pytest.approx(max(PALM * elbow_to_wrist, radius["RightElbow"]), rel=1e-6)
    assert radius["RightElbow_end"] > radius["RightElbow"]
    assert CONTACT_TOLERANCE * 2 == SLIDING_TOLERANCE

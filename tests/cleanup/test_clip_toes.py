"""Toes the capture bends (a game rig's, judging/cases.py: toes): the foot gets sites under its
ball on the foot's rigid part (cleanup/soles.py), the warm start leaves such short levers as
captured (cleanup/body.short_levers), and the judge's foot box bends with the toe
(judging/clips.py). Judged by the benchmarks' own kinematics and body."""

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from deik.cleanup.body import body_of, on_body, short_levers, with_helpers
from deik.cleanup.plants import rigid_pairs
from deik.io.bvh import parse_bvh
from deik.model.kinematics import forward_kinematics
from helpers import shared_path
from judging.cases import digits, noisy, source_case, toes
from judging.clips import contact_points, deepest, judge
from judging.rigs import format_rig, world_frames
from tests.cleanup.test_clip_any_rig import sunk_walk
from tests.cleanup.test_clip_fingers import _cleaned

MM = 1e-3


def _body(case):
    return body_of(with_helpers(parse_bvh(format_rig(case.rig), f"{case.name}.bvh")))


def test_a_toe_the_capture_bends_puts_a_ball_under_its_joint_and_a_still_one_none():
    bent, still = _body(toes(sunk_walk())), _body(digits(sunk_walk()))
    assert [len(foot.soles) for foot in still.feet] == [6, 6]
    assert [len(foot.soles) for foot in bent.feet] == [9, 9]
    sk = bent.skeleton
    stand = forward_kinematics(sk, np.zeros(sk.n_dofs)[None]).p_world_frame[0]
    for foot in bent.feet:
        toe_joint = sk.frame_index(foot.chain[1])
        heel, tip, ball = (stand[sk.frame_index(name)] for name in (foot.heel, foot.toe, foot.soles[6]))
        carrier = sk.site_joint[sk.frame_index(foot.soles[6]) - sk.n_joints]
        assert carrier == sk.frame_index(foot.ankle)  # on the foot's rigid part
        assert ball @ sk.up == pytest.approx(heel @ sk.up, abs=1e-9)  # on the sole
        flat = np.eye(3) - np.outer(sk.up, sk.up)
        # under the toe joint along the ground, between the heel and the toe tip
        forward = flat @ (tip - heel) / np.linalg.norm(flat @ (tip - heel))
        assert (ball - heel) @ forward == pytest.approx((stand[toe_joint] - heel) @ forward, abs=1e-9)
        assert 0 < (ball - heel) @ forward < (tip - heel) @ forward


def test_the_warm_start_leaves_a_toe_as_captured_but_not_an_ankle():
    case = toes(sunk_walk())
    clip = with_helpers(parse_bvh(format_rig(case.rig), "toes.bvh"))
    body = body_of(clip)
    short = short_levers(body, on_body(clip, body))
    sk = body.skeleton
    joints = {sk.joint_names[j] for j in sk.dof_joint[short]}
    assert {"RightAnkle_toe", "LeftAnkle_toe"} <= joints
    assert not joints & {"RightAnkle", "LeftAnkle", "RightKnee", "RightElbow", "Chest", "Neck"}


def test_the_judge_s_foot_box_bends_at_the_toe_joint():
    """A toe bent 30 degrees down in one frame turns the judge's toe point and the front of its
    box about the toe joint (its own kinematics against a rotation about the joint), into the
    floor; the heel stays."""
    case = toes(sunk_walk())
    rig = case.rig
    frames = rig.frames.copy()
    column = rig.columns.index((rig.names.index(case.names["RightToe"]), "Xrotation"))
    frames[5, column] -= 30.0
    bent = dataclasses.replace(rig, frames=frames)
    names, before, _ = contact_points(case, rig)
    after = contact_points(case, bent)[1]
    heel, toe = names.index("Right heel"), names.index("Right toe")
    np.testing.assert_allclose(after[:, heel], before[:, heel], atol=1e-12)
    changed = np.flatnonzero(np.abs(after[:, toe] - before[:, toe]).max(axis=1) > 1e-12)
    assert changed.tolist() == [5]
    R, p = world_frames(rig)
    joint = rig.names.index(case.names["RightToe"])
    axis = R[5, joint] @ np.array([1.0, 0.0, 0.0])
    turn = Rotation.from_rotvec(np.radians(-30.0) * axis).as_matrix()
    expected = p[5, joint] + turn @ (before[5, toe] * case.unit - p[5, joint])
    np.testing.assert_allclose(after[5, toe] * case.unit, expected, atol=1e-9)
    deeper = deepest(case, bent) - deepest(case, rig)
    assert deeper[5] > 10 * MM and np.abs(np.delete(deeper, 5)).max() == 0.0


@pytest.mark.shared_data
def test_the_shared_kick_with_bending_toes_and_noise_keeps_its_toes_and_stays_out_of_the_floor(tmp_path):
    # the warm start turned a toe 584 degrees and the fix left the foot 73 mm under the floor,
    # a toe 71 degrees from the capture, in frames it listed as unmet
    case = noisy(toes(source_case(shared_path("humanoid", "humanoid3d_kick.bvh"))))
    report, rig = _cleaned(case, tmp_path)
    row = judge(case, case.rig, rig, ~np.array(report["met_per_frame"], bool), case.truth)
    assert row["depth_mm"] <= 2.0, row
    assert row["peak_ratio"] <= 1.1, row
    assert row["steps_matched"] == row["steps"], row
    toe_columns = [k for k, (j, _) in enumerate(rig.columns) if rig.names[j].endswith("_toe")]
    turned = np.abs(rig.frames[:, toe_columns] - case.rig.frames[:, toe_columns]).max()
    assert turned <= 10.0, turned


def test_a_heel_and_a_toe_tip_a_bending_toe_carries_stay_linked_but_two_feet_do_not():
    """plants.rigid_pairs: the distance from a heel to a toe tip that turns 5 degrees about a toe
    joint varies by far less than RIGID_TOLERANCE, so their plants are placed that far apart
    (the distance in the frames both rest); a toe flexing 40 degrees, or a second foot resting
    beside the first, is no rigid link."""
    t = np.linspace(0.0, 2.0, 61)
    heel = np.zeros((61, 3))
    joint = np.array([0.14, 0.015, 0.0])

    def tip(degrees):
        angle = np.radians(degrees)
        return joint + 0.043 * np.stack([np.cos(angle), -np.sin(angle), 0 * angle], axis=-1)

    bent, flexed = tip(5.0 * np.sin(2 * np.pi * 0.7 * t)), tip(20.0 - 20.0 * np.cos(2 * np.pi * t))
    other = np.where((t < 1.0)[:, None], [0.0, 0.0, 0.3], [0.4, 0.0, 0.3]) + 0 * heel
    resting = np.zeros((61, 4), bool)
    resting[10:40] = True
    pairs = {(s, u): d for s, u, d in rigid_pairs(np.stack([heel, bent, flexed, other], axis=1), 2.0, resting)}
    assert set(pairs) == {(0, 1)}
    assert pairs[0, 1] == pytest.approx(np.linalg.norm(bent[10:40], axis=-1).mean(), rel=1e-12)


@pytest.mark.shared_data
def test_the_shared_kick_with_bending_toes_meets_its_plants_without_sliding(tmp_path):
    # the heel and the toe tip were unlinked (the toe bends), their plants placed alone could not
    # both be met: 18 of 47 frames unmet, the heel sliding 1.5 mm a frame
    case = toes(source_case(shared_path("humanoid", "humanoid3d_kick.bvh")))
    report, rig = _cleaned(case, tmp_path)
    row = judge(case, case.rig, rig)
    assert row["sliding_mm_per_frame"] <= 1.0 and row["depth_mm"] <= 2.0, row
    assert report["frames"] - report["frames_met"] <= 2, report["frames_met"]

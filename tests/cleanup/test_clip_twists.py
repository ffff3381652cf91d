"""Twist and corrective bones riding on a limb (a game rig's, judging/cases.py: twists) are no
part of the body the clip fix keeps on the floor (model.capsules.rider_joints): the limb keeps
its own thickness and taper, the clip cleans as on the rig without them, and they are left as
captured. Judged by the benchmarks' own kinematics and body."""

import numpy as np
import pytest

import deik
from deik.model.capsules import rider_joints
from helpers import shared_path
from judging.cases import TRANSFORMS, source_case, twists
from judging.clips import judge
from judging.walk import procedural_walk
from tests.cleanup.test_clip_any_rig import _written, sunk_walk
from tests.cleanup.test_clip_fingers import _canonical, _cleaned, bodies


def test_twist_bones_ride_on_their_limb_and_nothing_else_does(tmp_path):
    twisted = twists(procedural_walk())
    sk = deik.read_bvh(_written(twisted, tmp_path)).skeleton
    marked = {sk.joint_names[j] for j in np.flatnonzero(rider_joints(sk))}
    assert marked == {name for name in sk.joint_names if "_twist" in name}
    assert len(marked) == 16
    # no joint of any other rig family rides on a bone: each starts where its parent's bone ends
    # or at its origin, or carries a limb
    for name in ("studio", "anon", "limbs", "tpose", "laid", "seats", "digits"):
        case = TRANSFORMS[name](procedural_walk())
        rig = deik.read_bvh(_written(case, tmp_path)).skeleton
        assert not rider_joints(rig).any(), name


def test_a_walk_with_twist_bones_cleans_as_without_them_and_leaves_them_as_captured(tmp_path):
    walk = sunk_walk()
    twisted = twists(walk)
    plain_body, body = bodies((walk, twisted), tmp_path)
    names = body.skeleton.frame_names
    assert not any(body.part[f] for f, name in enumerate(names) if "_twist" in name)
    for joint in ("RightHip", "RightKnee", "LeftShoulder", "LeftElbow"):  # a limb as thick, its top tapered
        mine, plain = body.radius[names.index(joint)], plain_body.radius[plain_body.skeleton.frame_index(joint)]
        assert mine == pytest.approx(plain, rel=0.1), joint
    _, plain_out = _cleaned(walk, tmp_path)
    _, out = _cleaned(twisted, tmp_path)
    gap = np.linalg.norm(_canonical(twisted, out) - _canonical(walk, plain_out), axis=-1)
    assert gap.max() <= 1e-3, f"{gap.max() * 1000:.2f} mm apart"
    mine = [k for k, (j, _) in enumerate(twisted.rig.columns) if "_twist" in twisted.rig.names[j]]
    np.testing.assert_allclose(out.frames[:, mine], twisted.rig.frames[:, mine], atol=1e-6)


@pytest.mark.shared_data
def test_the_shared_crawl_with_twist_bones_cleans_as_the_crawl(tmp_path):
    # counted as the body, the twist joints on the thighs got radii of 9.7 cm and the crawl was
    # left 91 mm under the floor, 12 of its 177 frames met
    crawl = source_case(shared_path("humanoid", "humanoid3d_crawl.bvh"))
    rows = []
    for case in (crawl, twists(crawl)):
        report, out = _cleaned(case, tmp_path)
        rows.append(judge(case, case.rig, out, ~np.array(report["met_per_frame"], bool)))
    plain, twisted = rows
    assert twisted["depth_mm"] <= plain["depth_mm"] + 0.5, rows
    assert twisted["sliding_mm_per_frame"] <= plain["sliding_mm_per_frame"] + 0.1, rows
    assert twisted["misses_listed"], twisted


@pytest.mark.shared_data
def test_the_report_of_the_shared_walk_with_twist_bones_is_the_walk_s(tmp_path):
    """Where the pose jumps (the shared walk's loop after frame 18 comes close) is read from the
    body's points alone: counted, the 16 twist joints and their tips moved the average over the
    line, the report's measure split the heel's rest there and listed 2 frames of a walk the fix
    had cleaned exactly as without them."""
    walk = source_case(shared_path("humanoid", "humanoid3d_walk.bvh"))
    reports = [_cleaned(case, tmp_path)[0] for case in (walk, twists(walk))]
    for key in ("frames_met", "sliding_frames", "sunk_frames", "cuts"):
        assert reports[0][key] == reports[1][key], key

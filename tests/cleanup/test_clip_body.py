"""The body a clean-up works on (cleanup/body.py), checked against independent computations on the
procedural walk (judging/walk.py) and its other rig families: the span as the longest
path between two ends of the rig, the feet found without a name to go by, the soles flat on the
rest pose's lowest point, the carrier joint above a studio rig's hips, the radii."""

import dataclasses

import numpy as np
import pytest

from deik.cleanup.body import PALM, TAPER, TOP, body_of, median_pose
from deik.io.bvh import parse_bvh
from deik.model.kinematics import forward_kinematics
from judging.cases import anon, studio
from judging.rigs import format_rig
from judging.walk import procedural_walk


def read(case):
    return parse_bvh(format_rig(case.rig), f"{case.name}.bvh")


def longest_path(case) -> float:
    """The longest path along the bones between two ends, from the rig's own OFFSETs (none of its
    joints translates below the root), by brute force over every pair of points."""
    rig = case.rig
    parents = list(rig.parents) + [j for _, j, _ in rig.sites]
    lengths = [np.linalg.norm(o) if p >= 0 else 0.0 for o, p in zip(rig.offsets, rig.parents)]
    lengths += [np.linalg.norm(o) for _, _, o in rig.sites]

    def to_root(k):
        path = [k]
        while parents[path[-1]] >= 0:
            path.append(parents[path[-1]])
        return path

    best = 0.0
    for a in range(len(parents)):
        for b in range(a + 1, len(parents)):
            pa, pb = to_root(a), to_root(b)
            common = set(pa) & set(pb)
            best = max(best, sum(lengths[k] for k in pa + pb if k not in common))
    return best


@pytest.mark.parametrize("family", ["source", "anon"])
def test_the_span_is_the_longest_path_between_two_ends_and_the_feet_are_found_by_shape(family):
    walk = procedural_walk()
    case = walk if family == "source" else anon(walk)
    body = body_of(read(case))
    assert body.span == pytest.approx(longest_path(case), rel=1e-6)
    ankles = {case.names["RightAnkle"], case.names["LeftAnkle"]}
    assert {foot.ankle for foot in body.feet} == ankles  # J03 and J06 for the anonymous rig
    assert all(foot.chain == (foot.ankle, f"{foot.ankle}_end") for foot in body.feet)


def test_the_soles_lie_flat_under_the_foot_heel_behind_the_ankle():
    clip = read(procedural_walk())
    body = body_of(clip)
    kin = forward_kinematics(body.skeleton, median_pose(clip)[None])
    up = body.skeleton.up
    for foot in body.feet:
        tip = kin.position(foot.chain[-1])[0]
        heights = [kin.position(site)[0] @ up for site in foot.soles]
        np.testing.assert_allclose(heights, tip @ up, atol=1e-9)  # the rest pose's lowest point: the toe tip
        heel, toe, ankle = (kin.position(name)[0] for name in (foot.heel, foot.toe, foot.ankle))
        forward = (tip - ankle) - ((tip - ankle) @ up) * up
        assert (heel - ankle) @ forward < 0 < (toe - ankle) @ forward  # heel behind, toe ahead
        width = np.linalg.norm(kin.position(foot.soles[1])[0] - kin.position(foot.soles[2])[0])
        assert 0.3 < width / np.linalg.norm(toe - heel) < 0.7  # a foot a third to a half as wide as long
    assert (body.radius[[body.skeleton.frame_index(name) for name in body.sole_names]] == 0).all()


def test_a_root_above_the_hips_carries_the_body_and_is_no_part_of_it():
    clip = read(studio(procedural_walk()))
    body = body_of(clip)
    k = body.skeleton.frame_index("Reference")
    assert not body.part[k] and body.radius[k] == 0.0
    assert body.part[body.skeleton.frame_index("pelvis")]
    masses = np.bincount(clip.skeleton.mass_joint, clip.skeleton.mass_value, clip.skeleton.n_joints)
    assert masses[k] == 0.0  # no estimated mass on the carrier
    assert 150 < body.span < 300  # centimetres: a span of about 2 m
    assert {foot.ankle for foot in body.feet} == {"foot_r", "foot_l"}


def test_a_point_is_as_thick_as_the_thinnest_bone_it_holds():
    body = body_of(read(procedural_walk()))
    radius = dict(zip(body.skeleton.frame_names, body.radius))
    # the chest is thicker than the upper arm; the shoulder joint between them is the arm's
    assert radius["Chest"] > radius["RightShoulder"]
    assert radius["RightShoulder"] == pytest.approx(radius["RightElbow"], rel=0.5)
    assert 0.02 < radius["RightKnee"] < 0.08 and 0.02 < radius["RightElbow_end"] < 0.06
    assert radius["RightAnkle"] == pytest.approx(0.05, abs=1e-6)  # the ankle joint 5 cm above the sole


def test_a_limb_is_thickest_at_its_top_and_a_hand_as_broad_as_a_palm():
    """The knee and elbow, tops of the shin and forearm, are TOP times their bone's cylinder,
    a frustum tapering to TAPER of its top with the cylinder's volume; a hand is half a palm
    broad from its forearm's length; the chest, which starts three bones, keeps its own."""
    clip = read(procedural_walk())
    body = body_of(clip)
    names = body.skeleton.frame_names
    radius = dict(zip(names, body.radius))
    bone = dict(zip(names, body.bone_radius))  # the cylinder of the bone ending at each frame
    top, far = TOP, TOP * TAPER  # the frustum's ends over the cylinder's radius: same volume
    assert (top**2 + top * far + far**2) / 3.0 == pytest.approx(1.0)
    assert radius["RightKnee"] == pytest.approx(TOP * bone["RightAnkle"], rel=1e-9)
    assert radius["RightElbow"] == pytest.approx(TOP * bone["RightElbow_end"], rel=1e-9)
    forearm = np.linalg.norm(
        clip.kinematics.position("RightElbow_end") - clip.kinematics.position("RightElbow"), axis=1
    )
    assert radius["RightElbow_end"] == pytest.approx(max(PALM * np.median(forearm), bone["RightElbow_end"]), rel=1e-9)
    assert radius["RightElbow_end"] > bone["RightElbow_end"]
    assert radius["Chest"] == pytest.approx(min(bone["Chest"], bone["Neck"]), rel=1e-9)


def test_the_points_a_pop_is_measured_on_are_the_clips_own_joints_and_sites_of_the_body():
    case = studio(procedural_walk())
    clip = read(case)
    body = body_of(clip)
    names = body.skeleton.frame_names
    own = set(clip.skeleton.frame_names)
    chosen = {name for name, on in zip(names, body.points) if on}
    assert chosen == {name for name, on in zip(names, body.part) if on and name in own}
    assert not chosen & set(body.sole_names) and "Reference" not in chosen


def test_a_head_is_a_ball_holding_its_segment_s_volume():
    """An end of the body whose segment is as wide as a ball of its volume as it is long (a
    head; a forearm with its hand is not) is that ball around its end: lying on its back the
    head's centre stays a ball's radius above the floor, where its volume as a cylinder along
    the bone left it 16 mm lower (the DeepMimic humanoid's head sphere is 10.25 cm)."""
    clip = read(procedural_walk())
    body = body_of(clip)
    names = body.skeleton.frame_names
    radius = dict(zip(names, body.radius))
    cylinder = dict(zip(names, body.bone_radius))  # each bone's volume as a cylinder along it
    p = clip.kinematics
    head = np.median(np.linalg.norm(p.position("Neck_end") - p.position("Neck"), axis=1))
    volume = np.pi * cylinder["Neck_end"] ** 2 * head
    ball = (3.0 * volume / (4.0 * np.pi)) ** (1.0 / 3.0)
    assert 2.0 * ball >= head and radius["Neck_end"] == pytest.approx(ball, rel=1e-9)
    assert radius["Neck_end"] > cylinder["Neck_end"] + 0.01
    forearm = np.median(np.linalg.norm(p.position("RightElbow_end") - p.position("RightElbow"), axis=1))
    assert radius["RightElbow_end"] == pytest.approx(max(PALM * forearm, cylinder["RightElbow_end"]), rel=1e-9)


def _lying_on_its_back(sunk: float):
    """The procedural walk's rig lying still on its back (every rotation 0 but the root's, 90
    degrees about its side axis) for a second, its lowest surface by the judge's DeepMimic
    shapes `sunk` metres under the floor: a capture laid a little through the floor."""
    from judging.clips import deepest

    case = procedural_walk()
    rig = case.rig
    frames = np.zeros((30, len(rig.columns)))
    frames[:, rig.columns.index((0, "Zrotation"))] = 90.0
    laid = dataclasses.replace(rig, frames=frames)
    frames[:, rig.columns.index((0, "Yposition"))] += deepest(case, laid).max() - sunk
    return dataclasses.replace(case, name="lying", rig=dataclasses.replace(rig, frames=frames))


def test_a_body_lying_on_its_back_is_kept_out_of_the_floor_by_its_chest(tmp_path):
    """A chest is thicker than the joints that bound it: its centre, halfway from the chest
    joint to its bones' ends, is a point of the body as thick as the chest's segment. The walk's
    rig laid on its back 15 mm through the floor (the judge's chest sphere, 11 cm around a point
    12 cm up the spine from the chest joint, deepest) comes out of it, the frames listed where
    it does not; measured on its joints alone the body read 3 mm above the floor and was left
    15 mm under it with every frame called met."""
    from tests.cleanup.test_clip_any_rig import cleaned_and_judged

    body = body_of(read(procedural_walk()))
    assert body.centres == ("Chest_centre",)
    sk = body.skeleton
    centre = sk.frame_index("Chest_centre")
    assert body.radius[centre] == pytest.approx(body.bone_radius[sk.frame_index("Neck")])
    assert "Chest_centre" not in body.contact_points() and not body.points[centre]
    report, measured = cleaned_and_judged(_lying_on_its_back(0.015), tmp_path)
    assert measured["depth_mm"] <= 2.0 and measured["misses_listed"], measured

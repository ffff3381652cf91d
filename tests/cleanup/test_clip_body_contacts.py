"""Contacts anywhere on the body, the floor and its goal: hand-made motions with known answers
(a body whose foot dips through the floor for one frame, a bone lying flat then tilting), and
the shared clips (hands, elbows and knees of the crawl and the get-up; longer legs; penetration,
sliding and floating after a fix; an unreachable reach that must not drag the contacts)."""

import dataclasses

import numpy as np
import pytest

from deik.cleanup.body_contacts import bone_contacts, bone_ends, detect_body_contacts, detect_floor, merge_contacts
from deik.cleanup.clip_goals import ClipGoals, Reach
from deik.cleanup.contacts import contacts_from_ranges
from deik.cleanup.fix import fix_clip
from deik.cleanup.plants import planted_targets
from deik.cleanup.summary import clip_report
from deik.io.bvh import Clip, read_bvh
from deik.model.build import build_skeleton
from deik.model.joints import Joint, Site, hinge, translation
from deik.model.kinematics import forward_kinematics
from helpers import shared_path


def body(heights, frame_time=0.1) -> Clip:
    """A body moved up and down (Y up) carrying a foot site at its origin and a head 1.7 m up."""
    joints = [Joint("body", None, dofs=translation("XYZ"), mass=1.0)]
    sites = [Site("foot", "body"), Site("head", "body", (0.0, 1.7, 0.0))]
    poses = np.zeros((len(heights), 3))
    poses[:, 1] = heights
    return Clip.from_poses(build_skeleton(joints, sites), poses, frame_time)


def test_the_floor_ignores_a_one_frame_dip_and_plants_sit_on_it():
    heights = [0.0] * 20 + [-0.05] + [0.002] * 19  # one frame 5 cm through, then 2 mm up
    clip = body(heights)
    assert detect_floor(clip) == pytest.approx(0.0)  # the 5th percentile of 40 lowest points
    contacts = merge_contacts([contacts_from_ranges(clip, {"foot": [(0, 40)]})], 0.0)
    target = planted_targets(clip, contacts)[:, 0]
    # the median height over the contact (2 mm up) is within the snap distance: on the floor
    np.testing.assert_allclose(target[:, 1], 0.0, atol=1e-12)


def test_a_plant_is_the_median_height_not_the_lowest():
    clip = body([0.05] * 9 + [0.0] + [0.05] * 9)  # resting 5 cm up, one frame down at the floor
    contacts = merge_contacts([contacts_from_ranges(clip, {"foot": [(0, 19)]})], -1.0)
    assert planted_targets(clip, contacts)[0, 0, 1] == pytest.approx(0.05)


def test_a_foot_sunk_through_the_floor_plants_on_it():
    clip = body([-0.08] * 10)  # legs made longer: the foot 8 cm under the floor at 0
    contacts = merge_contacts([contacts_from_ranges(clip, {"foot": [(0, 10)]})], 0.0)
    assert planted_targets(clip, contacts)[0, 0, 1] == pytest.approx(0.0)


def test_body_contacts_are_slow_points_near_their_resting_height():
    heights = [0.3] * 5 + [0.0] * 6 + [0.3] * 5  # jumps down, stays, jumps up (fast in between)
    contacts = detect_body_contacts(body(heights), floor=0.0)
    assert contacts.sites == ("body", "foot")  # the head (1.7 m up) never comes near the floor
    # frames 5 and 10 border the jumps: fast by central differences
    assert contacts.intervals("foot") == contacts.intervals("body") == [(6, 10)]
    assert contacts.ground == 0.0


def lever(angles) -> Clip:
    """A bone from `hip` (0.1 above the floor) to its end site 1 m along X, turned about Z."""
    joints = [Joint("hip", None, (0.0, 0.1, 0.0), hinge((0, 0, 1)))]
    return Clip.from_poses(build_skeleton(joints, [Site("tip", "hip", (1.0, 0.0, 0.0))]), np.c_[angles], 0.1)


def test_a_bone_touches_at_its_lowest_end_and_at_both_lying_flat():
    clip = lever([0.0, 0.0, -0.3, -0.3])  # flat, then the tip lower
    assert bone_ends(clip.skeleton, "hip-tip") == ("hip", "tip")
    assert bone_ends(clip.skeleton, "tip-hip") is None  # not a parent and its child
    masks = bone_contacts(clip, "hip", "tip", np.ones(4, bool))
    np.testing.assert_array_equal(masks["hip"], [True, True, False, False])
    np.testing.assert_array_equal(masks["tip"], [True, True, True, True])


def humanoid(name):
    return read_bvh(shared_path("humanoid", f"humanoid3d_{name}.bvh"))


def excerpt(clip, first, stop):
    return dataclasses.replace(clip, frames=clip.frames[first:stop])


@pytest.mark.shared_data
@pytest.mark.parametrize(
    "name, points",
    [
        ("crawl", ("RightKnee", "LeftKnee", "RightElbow", "LeftElbow", "RightElbow_end", "LeftElbow_end")),
        ("getup_facedown", ("LeftKnee", "RightElbow", "LeftElbow", "RightElbow_end", "LeftElbow_end")),
    ],
)
def test_hands_elbows_and_knees_on_the_floor_are_contacts(name, points):
    clip = humanoid(name)
    contacts = detect_body_contacts(clip)
    heights = forward_kinematics(clip.skeleton, clip.frames).p_world_frame @ clip.skeleton.up
    for point in points:
        mask = contacts.mask[:, contacts.sites.index(point)]
        assert mask.sum() >= 4, point
        # in contact it is low: within 8.6 cm (reach x NEAR_FRACTION) + 5.4 cm of the floor
        assert heights[mask, clip.skeleton.frame_index(point)].max() < contacts.ground + 0.14, point


def fixed(clip, floor=None, reach=()):
    """The clip fixed as `deik clip --contact auto` fixes it, and its contacts."""
    floor = detect_floor(clip) if floor is None else floor
    contacts = detect_body_contacts(clip, floor=floor)
    return fix_clip(clip, ClipGoals(contacts, reach, floor=floor), seed=0), contacts


@pytest.mark.shared_data
def test_longer_legs_end_with_the_feet_on_the_floor_not_under_it():
    clip = excerpt(humanoid("walk"), 0, 20)
    floor = detect_floor(clip)
    sk = clip.skeleton
    offsets = sk.offsets.copy()
    for name in ("RightKnee", "RightAnkle", "LeftKnee", "LeftAnkle"):
        offsets[sk.frame_index(name)] *= 1.1  # thigh and shin 10 % longer: the feet 8 cm lower
    long = dataclasses.replace(clip, skeleton=dataclasses.replace(sk, offsets=offsets))
    toes = [sk.frame_index(name) for name in ("RightAnkle_end", "LeftAnkle_end")]
    sunk = (forward_kinematics(long.skeleton, long.frames).p_world_frame[:, toes] @ sk.up).min(axis=1)
    assert sunk.max() < floor - 0.06  # 6 to 8 cm under the floor
    fix, contacts = fixed(long, floor)
    heights = forward_kinematics(long.skeleton, fix.clip.frames).p_world_frame @ sk.up
    assert heights.min() >= floor - 1e-3  # nothing below the floor
    lowest_toe = heights[:, toes].min(axis=1)
    assert np.abs(lowest_toe - floor).max() < 0.01  # a foot on the floor in every frame


@pytest.mark.shared_data
def test_an_unreachable_reach_is_reported_and_does_not_drag_the_contacts():
    clip = excerpt(humanoid("walk"), 0, 20)
    mask = np.zeros(clip.n_frames, bool)
    mask[6:12] = True
    targets = np.full((clip.n_frames, 3), np.nan)
    targets[mask] = (3.0, 1.0, 0.0)  # 3 m ahead of a body planted on its feet
    alone, contacts = fixed(clip)
    reaching, _ = fixed(clip, reach=(Reach("RightElbow_end", mask, targets),))
    slide = [
        np.nanmax(clip_report(clip, f.clip, contacts)["foot_sliding_max_mm_per_frame"]["after"])
        for f in (alone, reaching)
    ]
    assert slide[1] <= max(slide[0], 1.0)
    column = reaching.labels.index("reach RightElbow_end")
    missed = reaching.after[:, column] > reaching.tolerances[column]
    assert missed[mask].all() and not reaching.met[mask].any()

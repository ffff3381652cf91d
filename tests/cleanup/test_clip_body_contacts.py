"""Plants and bones: hand-made motions with known answers (a foot that dips through the floor for
one frame, one resting above it, one sunk under it, a bone lying flat then tilting), and the
shared clips (hands and knees of the crawl and the get-up found resting; longer legs lifted out
of the floor; an unreachable reach that must not drag the contacts)."""

import dataclasses

import numpy as np
import pytest

from deik.cleanup.body_contacts import bone_contacts, bone_ends, merge_contacts
from deik.cleanup.clip_goals import ClipGoals, Reach
from deik.cleanup.contacts import contacts_from_ranges
from deik.cleanup.fix import fix_clip
from deik.cleanup.ground import resting_body
from deik.cleanup.plants import planted_targets
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


def test_a_plant_ignores_a_one_frame_dip_and_sits_on_the_floor():
    heights = [0.0] * 20 + [-0.05] + [0.002] * 19  # one frame 5 cm through, then 2 mm up
    clip = body(heights)
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


def test_a_point_with_a_clearance_plants_that_far_up_and_is_never_lowered_onto_it():
    sunk, floating = body([-0.02] * 10), body([0.06] * 10)  # a knee joint 2 cm down, one 6 cm up
    for clip, expected in ((sunk, 0.05), (floating, 0.06)):
        given = contacts_from_ranges(clip, {"foot": [(0, 10)]})
        contacts = dataclasses.replace(given, ground=0.0, clearance=np.array([0.05]))  # a 5 cm radius
        assert planted_targets(clip, contacts)[0, 0, 1] == pytest.approx(expected)


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
        ("crawl", ("RightKnee", "LeftKnee", "RightElbow", "LeftElbow")),
        ("getup_facedown", ("RightKnee", "LeftKnee", "Hips", "RightElbow_end", "LeftElbow_end")),
    ],
)
def test_hands_elbows_and_knees_on_the_floor_are_contacts(name, points):
    clip = humanoid(name)
    body, floor, contacts = resting_body(clip)
    heights = forward_kinematics(body.skeleton, clip.frames).p_world_frame @ clip.skeleton.up
    assert floor.height == 0.0 and floor.how == "ground plane"  # the capture's ground plane
    for point in points:
        mask = contacts.mask[:, contacts.sites.index(point)]
        assert mask.sum() >= 4, point
        # in contact its surface is low: within 4.3 cm (2 % of the body's 2.13 m span) of the floor
        f = body.skeleton.frame_index(point)
        assert heights[mask, f].max() - body.radius[f] < floor.height + 0.044, point


def fixed(clip, reach=()):
    """The clip fixed as `deik clip` fixes it with no flags, and its contacts."""
    body, floor, contacts = resting_body(clip)
    return fix_clip(clip, ClipGoals(contacts, reach, floor=floor.height), seed=0, body=body), contacts


@pytest.mark.shared_data
def test_longer_legs_end_with_the_feet_on_the_floor_not_under_it():
    clip = excerpt(humanoid("walk"), 0, 20)
    floor = 0.0  # the shared clips stand on their ground plane
    sk = clip.skeleton
    offsets = sk.offsets.copy()
    for name in ("RightKnee", "RightAnkle", "LeftKnee", "LeftAnkle"):
        offsets[sk.frame_index(name)] *= 1.1  # thigh and shin 10 % longer: the feet 8 cm lower
    long = dataclasses.replace(clip, skeleton=dataclasses.replace(sk, offsets=offsets))
    toes = [sk.frame_index(name) for name in ("RightAnkle_end", "LeftAnkle_end")]
    sunk = (forward_kinematics(long.skeleton, long.frames).p_world_frame[:, toes] @ sk.up).min(axis=1)
    assert sunk.max() < floor - 0.05  # 5 to 7 cm under the floor
    fix, contacts = fixed(long)
    before, after = fix.on_body()
    surface = forward_kinematics(after.skeleton, after.frames).p_world_frame @ sk.up - fix.body.radius
    lifted = fix.met  # frames whose change was taken back, so as not to jolt, are listed unmet
    assert lifted.sum() >= 15 and surface[lifted].min() >= floor - 1e-3  # nothing below the floor
    lowest_toe = surface[:, toes].min(axis=1)
    assert np.abs(lowest_toe - floor)[lifted].max() < 0.02  # a foot on the floor


@pytest.mark.shared_data
def test_an_unreachable_reach_is_reported_and_does_not_drag_the_contacts():
    clip = excerpt(humanoid("walk"), 0, 20)
    mask = np.zeros(clip.n_frames, bool)
    mask[6:12] = True
    targets = np.full((clip.n_frames, 3), np.nan)
    targets[mask] = (3.0, 1.0, 0.0)  # 3 m ahead of a body planted on its feet
    alone, contacts = fixed(clip)
    reaching, _ = fixed(clip, reach=(Reach("RightElbow_end", mask, targets),))
    held = [t for t, label in enumerate(reaching.labels) if label.startswith("contact ")]
    within = reaching.after[:, held] <= 0.001  # a millimetre of drag at most, where they held alone
    assert (np.isnan(reaching.after[:, held]) | within)[alone.met].all()
    column = reaching.labels.index("reach RightElbow_end")
    missed = reaching.after[:, column] > reaching.tolerances[column]
    assert missed[mask].all() and not reaching.met[mask].any()

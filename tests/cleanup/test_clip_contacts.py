"""Contact detection on the real humanoid clips, user contact ranges and planted targets."""

from itertools import combinations

import numpy as np
import pytest

from deik.cleanup.body import on_body
from deik.cleanup.clip_goals import CONTACT_TOLERANCE
from deik.cleanup.contacts import (
    HEIGHT_FRACTION,
    SPEED_FRACTION,
    Contacts,
    contacts_from_ranges,
    detect_contacts,
    fill_gaps,
    foot_sites,
)
from deik.cleanup.ground import resting_body
from deik.cleanup.plants import SNAP_FRACTION, planted_targets
from deik.io.bvh import Clip, read_bvh
from deik.model.build import build_skeleton
from deik.model.joints import Joint, Site, translation
from deik.model.kinematics import forward_kinematics
from helpers import shared_path

FEET = {"Right": ("RightAnkle", "RightAnkle_end"), "Left": ("LeftAnkle", "LeftAnkle_end")}


def humanoid(name: str) -> Clip:
    return read_bvh(shared_path("humanoid", f"humanoid3d_{name}.bvh"))


def foot_intervals(contacts: Contacts) -> list[tuple[int, int, str]]:
    """(start, stop, foot) of every run of frames where any site of a foot is in contact."""
    out = []
    for foot, sites in FEET.items():
        planted = contacts.mask[:, [contacts.sites.index(s) for s in sites]].any(axis=1)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], planted.astype(int), [0]])))
        out += [(int(a), int(b), foot) for a, b in zip(edges[::2], edges[1::2])]
    return sorted(out)


def point_clip(heights, frame_time=0.1) -> Clip:
    """A free-floating point named 'toe' (the root of a skeleton with reach 1) at these heights."""
    skeleton = build_skeleton([Joint("root", None, dofs=translation("XYZ"))], [Site("toe", "root")])
    poses = np.zeros((len(heights), 3))
    poses[:, 1] = heights
    return Clip.from_poses(skeleton, poses, frame_time)


@pytest.mark.shared_data
def test_foot_sites_of_the_humanoid_group_each_ankle_with_its_toe():
    assert foot_sites(humanoid("walk").skeleton) == ("RightAnkle", "RightAnkle_end", "LeftAnkle", "LeftAnkle_end")


def test_a_skeleton_without_feet_asks_for_contact_sites():
    skeleton = build_skeleton([Joint("root", None, dofs=translation("XYZ"))], [Site("hand", "root")])
    with pytest.raises(ValueError, match="--contact"):
        foot_sites(skeleton)


@pytest.mark.shared_data
@pytest.mark.parametrize("name", ["walk", "run"])
def test_walk_and_run_contacts_alternate_between_the_feet(name):
    clip = humanoid(name)
    contacts = detect_contacts(clip)
    assert contacts.detected
    assert contacts.height == pytest.approx(HEIGHT_FRACTION * clip.skeleton.reach)
    assert contacts.speed == pytest.approx(SPEED_FRACTION * clip.skeleton.reach)
    spans = foot_intervals(contacts)
    feet = [foot for _, _, foot in spans]
    assert all(a != b for a, b in zip(feet, feet[1:])), spans
    for foot in FEET:
        assert max(b - a for a, b, f in spans if f == foot) >= 3, spans
        planted = sum(b - a for a, b, f in spans if f == foot) / clip.n_frames
        assert 0.15 <= planted <= 0.75, (foot, planted)


@pytest.mark.shared_data
def test_jump_has_a_flight_phase_with_no_contact_between_two_stances():
    contacts = detect_contacts(humanoid("jump"))
    airborne = np.flatnonzero(~contacts.mask.any(axis=1))
    assert len(airborne) >= 10
    assert contacts.mask[: airborne[0]].any(axis=1).all()  # standing until take-off
    assert contacts.mask[-1].all()  # both feet flat at the end
    toes = [contacts.sites.index("RightAnkle_end"), contacts.sites.index("LeftAnkle_end")]
    assert contacts.mask[0, toes].all()


@pytest.mark.shared_data
def test_ground_ignores_a_fast_foot_that_dips_through_the_floor():
    clip = humanoid("run")  # its last frame drops the moving right toe about 5 cm down
    contacts = detect_contacts(clip)
    kin = forward_kinematics(clip.skeleton, clip.frames)
    lowest = min((kin.position(s) @ clip.skeleton.up).min() for s in contacts.sites)
    assert contacts.ground > lowest + 0.03
    assert not contacts.mask[-1].any()


def test_height_threshold_and_single_frame_runs():
    heights = [1.0, 0.0, 1.0, 1.0, 0.02, 0.0, 0.01, 1.0, 1.0, 0.0]
    contacts = detect_contacts(point_clip(heights), sites=["toe"], height=0.05, speed=100.0)
    assert contacts.ground == 0.0
    expected = np.zeros((10, 1), bool)
    expected[4:7] = True  # frames 1 and 9 touch the floor alone: runs under 2 frames are dropped
    np.testing.assert_array_equal(contacts.mask, expected)
    assert contacts.intervals(0) == contacts.intervals("toe") == [(4, 7)]


def test_speed_threshold():
    still = point_clip(np.zeros(6))  # 1 unit per frame along the floor is 10 units/s
    moving = still.with_frames(still.frames + np.arange(6)[:, None] * [1.0, 0.0, 0.0])
    assert not detect_contacts(moving, ["toe"], height=0.05, speed=9.9).mask.any()
    assert detect_contacts(moving, ["toe"], height=0.05, speed=10.0).mask.all()


@pytest.mark.shared_data
def test_unknown_sites_and_bad_thresholds():
    clip = humanoid("walk")
    with pytest.raises(KeyError, match="did you mean 'RightAnkle'"):
        detect_contacts(clip, sites=["RightAnkel"])
    with pytest.raises(ValueError, match="height threshold"):
        detect_contacts(clip, height=-1.0)
    with pytest.raises(ValueError, match="speed threshold"):
        detect_contacts(clip, speed=float("nan"))


@pytest.mark.shared_data
def test_user_ranges_and_describe():
    clip = humanoid("walk")
    contacts = contacts_from_ranges(clip, {"RightAnkle_end": [(0, 8), (27, 39)], "LeftAnkle": []})
    assert not contacts.detected and contacts.height is None and contacts.speed is None
    assert contacts.mask[:, 0].sum() == 20 and not contacts.mask[:, 1].any()
    assert contacts.intervals("RightAnkle_end") == [(0, 8), (27, 39)]
    assert contacts.describe().splitlines() == [
        "RightAnkle_end: 20 frames in 2 contacts (0-7, 27-38)",
        "LeftAnkle: no contact",
    ]
    with pytest.raises(ValueError):
        contacts.mask[0, 0] = False
    with pytest.raises(KeyError, match="not a contact site"):
        contacts.intervals("Neck_end")


@pytest.mark.shared_data
@pytest.mark.parametrize("span", [(30, 40), (-1, 3), (5, 5)])
def test_user_ranges_outside_the_clip(span):
    with pytest.raises(ValueError, match=rf"\({span[0]}, {span[1]}\) of site 'LeftAnkle_end'.*0\.\.38"):
        contacts_from_ranges(humanoid("walk"), {"LeftAnkle_end": [span]})


@pytest.mark.shared_data
def test_user_ranges_name_unknown_sites():
    with pytest.raises(KeyError, match="did you mean 'LeftAnkle_end'"):
        contacts_from_ranges(humanoid("walk"), {"LeftAnkle_ned": [(0, 3)]})


@pytest.mark.shared_data
def test_planted_targets_are_the_mean_position_on_the_floor():
    clip = humanoid("walk")
    contacts = detect_contacts(clip)
    s = contacts.sites.index("RightAnkle_end")
    start, stop = contacts.intervals(s)[0]
    targets = planted_targets(clip, contacts)
    assert targets.shape == (clip.n_frames, len(contacts.sites), 3)
    kin = forward_kinematics(clip.skeleton, clip.frames)
    x, y, z = kin.position("RightAnkle_end")[start:stop].T
    target = targets[start:stop, s]
    assert (target == target[0]).all()
    # Y is up: the toe's median height lies within the snap distance of the floor, so on it
    assert abs(np.median(y) - contacts.ground) <= SNAP_FRACTION * clip.skeleton.reach
    assert target[0, 1] == pytest.approx(contacts.ground, abs=1e-12)
    # along the ground, the mean, moved a little to keep the ankle at the toe's distance
    assert np.hypot(target[0, 0] - x.mean(), target[0, 2] - z.mean()) < 2e-3
    outside = ~contacts.mask[:, s]
    assert outside.any() and np.isnan(targets[outside, s]).all()


CLIPS = ("walk", "run", "jump", "crawl", "getup_facedown", "kick", "punch", "dance_a")


@pytest.mark.shared_data
@pytest.mark.parametrize("name", CLIPS)
def test_planted_points_a_bone_apart_keep_the_bone_length_between_them(name):
    """Every two contact points a fixed distance apart (an ankle and its toe, an elbow and its
    wrist) get plants that distance apart in the frames both are planted, also where one of
    them lifts and lands again while the other stays down."""
    body, floor, contacts = resting_body(humanoid(name))
    floor = floor.height
    clip = on_body(humanoid(name), body)
    targets = planted_targets(clip, contacts)
    p = forward_kinematics(clip.skeleton, clip.frames).p_world_frame
    checked = 0
    for a, b in combinations(range(len(contacts.sites)), 2):
        lengths = np.linalg.norm(
            p[:, clip.skeleton.frame_index(contacts.sites[a])] - p[:, clip.skeleton.frame_index(contacts.sites[b])],
            axis=-1,
        )
        both = contacts.mask[:, a] & contacts.mask[:, b]
        if np.ptp(lengths) < 1e-9 and both.any():
            gap = np.linalg.norm(targets[both, a] - targets[both, b], axis=-1)
            # exact along the links placed; a link closing a loop of three (the pelvis and both
            # hip joints resting together) within a tenth of the contact tolerance
            close = 0.1 * CONTACT_TOLERANCE * body.span
            np.testing.assert_allclose(gap, lengths[0], atol=close, err_msg=f"{contacts.sites[a]}-{contacts.sites[b]}")
            checked += 1
    assert checked >= 1 or name == "crawl"  # a foot at least (the crawl rests on knees and elbows)
    # every plant lies on or above its floor: the floor plus the point's clearance (its radius)
    heights = np.where(contacts.mask, targets @ clip.skeleton.up, np.inf)
    assert (heights >= floor + contacts.clearance - 1e-12).all()


def test_a_toe_that_lands_as_the_heel_lifts_keeps_the_foot_where_the_heel_left_it():
    """Plants of rigidly linked points that hand over (the ankle planted for frames 0-4, the toe
    from frame 6): the toe is planted at the ankle's plant plus the foot's offset when the ankle
    left, not at its own mean, so the foot does not jump between the two plants."""
    joints = [Joint("body", None, dofs=translation("XYZ", -1.0, 1.0))]
    sk = build_skeleton(joints, [Site("ankle", "body", (0.0, 0.05, 0.0)), Site("toe", "body", (0.15, 0.0, 0.0))])
    poses = np.zeros((11, 3))
    poses[:, 0] = 0.01 * np.arange(11)  # the whole foot slides 1 cm a frame
    clip = Clip.from_poses(sk, poses, 0.1)
    contacts = contacts_from_ranges(clip, {"ankle": [(0, 5)], "toe": [(6, 11)]})
    targets = planted_targets(clip, contacts)
    ankle, toe = targets[0, 0], targets[6, 1]
    np.testing.assert_allclose(ankle, [0.02, 0.05, 0.0])  # the ankle's mean over frames 0-4
    # the toe 15 cm ahead of that along the ground (not at its own mean, 0.23), at its own height
    np.testing.assert_allclose(toe, [0.17, 0.0, 0.0], atol=1e-12)


def test_a_one_frame_gap_between_two_contacts_is_filled_and_a_longer_one_kept():
    mask = np.zeros((12, 2), bool)
    mask[[0, 1, 2, 4, 5], 0] = True  # down, up for one frame, down again
    mask[[0, 1, 2, 5, 6], 1] = True  # down, up for two frames, down again
    filled = fill_gaps(mask)
    np.testing.assert_array_equal(np.flatnonzero(filled[:, 0]), [0, 1, 2, 3, 4, 5])
    np.testing.assert_array_equal(filled[:, 1], mask[:, 1])


def test_a_gap_the_point_moves_across_faster_than_resting_speed_is_a_move_and_stays():
    mask = np.zeros((10, 3), bool)
    mask[[0, 1, 2, 4, 5, 6], :] = True  # down, up for frame 3, down again
    p = np.zeros((10, 3, 3))
    p[4:, 0, 0] = 0.02  # point 0 shuffles 2 cm across the gap: 1 cm a frame on average
    p[3, 1, 0] = 0.02  # point 1 jitters out in the gap and comes back where it was
    p[4:, 2, 0] = 0.02  # point 2 moves as point 0 but may move 1.5 cm a frame at rest
    filled = fill_gaps(mask, 2, p, np.array([0.005, 0.005, 0.015]))
    np.testing.assert_array_equal(filled[:, 0], mask[:, 0])  # two rests: the sole went somewhere
    np.testing.assert_array_equal(np.flatnonzero(filled[:, 1]), np.arange(7))
    np.testing.assert_array_equal(np.flatnonzero(filled[:, 2]), np.arange(7))
    np.testing.assert_array_equal(fill_gaps(mask, 2, p, 0.005)[:, 0], mask[:, 0])  # one step for every point


def test_a_heel_resting_while_its_toe_moves_between_two_rests_keeps_the_toe_s_lift():
    from deik.cleanup.plants import lifted_heights

    heights = np.array([[0.005, -0.02]] * 8)  # a heel 5 mm over the floor at 0, its toe 2 cm under it
    mask = np.ones((8, 2), bool)
    mask[4, 1] = False  # the toe moves between two rests in frame 4
    mask[6:, 0] = False  # the heel lifts at frame 6, the toe rests on
    raised = lifted_heights(heights, mask, [(0, 1, 0.15)], np.zeros(2))
    np.testing.assert_allclose(raised[:, 0], 0.025)  # the heel rises with its toe in every frame, 4 included
    np.testing.assert_allclose(raised[mask[:, 1], 1], 0.0)
    mask[:, 1] = [True, True, False, False, False, False, False, False]  # the toe lifts for good at 2
    assert lifted_heights(heights, mask, [(0, 1, 0.15)], np.zeros(2))[4, 0] == 0.005  # no longer sunk


def creeping_toe(frame_time: float, gap: float) -> tuple[Clip, Contacts, np.ndarray]:
    """(clip, contacts, toe positions (N, 3)): a toe on the floor creeping along X at 3 mm per
    30th of a second through a rest of 0.1 s, shuffling 2 cm forward over the next `gap` seconds
    and creeping on through a rest of 0.4 s, at `frame_time` seconds a frame (the contacts are
    the two rests)."""
    rate, first, second = 0.09, round(0.1 / frame_time), round(0.4 / frame_time)
    between = round(gap / frame_time)
    n = first + between + second
    speed = np.full(n, rate * frame_time)
    speed[first : first + between] += 0.02 / between
    poses = np.zeros((n, 3))
    poses[1:, 0] = np.cumsum(speed[1:])
    sk = build_skeleton([Joint("root", None, dofs=translation("XYZ", -1.0, 1.0))], [Site("toe", "root")])
    clip = Clip.from_poses(sk, poses, frame_time)
    contacts = contacts_from_ranges(clip, {"toe": [(0, first), (first + between, n)]})
    return clip, contacts, poses


@pytest.mark.parametrize("frame_time", [1 / 30, 1 / 120])
def test_two_rests_a_move_apart_plant_the_capture_s_move_apart(frame_time):
    """A creeping toe's rests either side of a shuffle (a gap of at most ground.GAP seconds):
    their plants lie as far apart as the toe moves across the gap in the capture, at any frame
    rate, where each rest's own median would put them farther apart (the second rest's median
    lies halfway through its creep) and the toe would move faster between them than captured."""
    clip, contacts, p = creeping_toe(frame_time, gap=0.034)
    (a, b), (c, d) = contacts.intervals("toe")
    assert c - b == round(0.034 / frame_time) and c - b >= 1  # a gap of one frame at 30 fps, four at 120
    targets = planted_targets(clip, contacts)[:, 0]
    move = p[c] - p[b - 1]
    np.testing.assert_allclose(targets[c] - targets[a], move, atol=1e-12)
    alone = np.median(p[c:d], axis=0) - np.median(p[a:b], axis=0)
    assert alone[0] > move[0] + 0.005  # what each rest's median alone gives: 5 mm or more farther
    # both rests count as they would alone: the first plant is the median over both, the
    # second's positions moved back by the move
    shifted = np.concatenate([p[a:b], p[c:d] - move])
    np.testing.assert_allclose(targets[a], np.median(shifted, axis=0), atol=1e-12)
    assert (targets[a:b] == targets[a]).all() and (targets[c:d] == targets[c]).all()


def test_two_rests_a_step_apart_plant_where_each_rests():
    """A gap longer than ground.GAP (the toe lifted and stepped) leaves each rest's own plant:
    the median of its own positions."""
    clip, contacts, p = creeping_toe(1 / 30, gap=0.2)
    (a, b), (c, d) = contacts.intervals("toe")
    targets = planted_targets(clip, contacts)[:, 0]
    np.testing.assert_allclose(targets[a], np.median(p[a:b], axis=0), atol=1e-12)
    np.testing.assert_allclose(targets[c], np.median(p[c:d], axis=0), atol=1e-12)

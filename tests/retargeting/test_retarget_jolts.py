"""repair_jolts (deik.retargeting.ik): frames of a retarget's per-frame IK that settled in another
of two equally good compromises than their neighbours (an elbow bent the other way) are brought
back to their neighbours' side, and a clip without such frames is left as it was."""

import numpy as np

import deik
from deik.cleanup.dynamics import jolted_points
from deik.retargeting.ik import KeypointGoals, repair_flips, repair_jolts, solve_keypoints, worst_errors

DT = 1 / 30
FRAMES = 16


def two_basin_goals(seed: int) -> tuple[KeypointGoals, np.ndarray, np.ndarray]:
    """(goals, elbow-up poses, elbow-down poses) of a planar two-link arm (links of 1) whose hand
    sweeps slowly along an arc within reach and whose elbow is asked to lie on the line from the
    shoulder to the hand: it cannot, and bent either way it is equally far off (mirror
    compromises)."""
    arm = deik.chain(2)
    rng = np.random.default_rng(seed)
    heading = rng.uniform(-1, 1) + np.linspace(0.0, rng.uniform(-0.3, 0.3), FRAMES)
    distance = np.full(FRAMES, rng.uniform(1.2, 1.5))
    hand = np.stack([distance * np.cos(heading), distance * np.sin(heading), np.zeros(FRAMES)], axis=1)
    targets = np.stack([hand, 0.5 * hand], axis=1)  # (N, 2, 3): the tip, the elbow (link1's origin)
    goals = KeypointGoals(arm, ["tip", "link1"], targets, np.ones(2, bool), np.ones(2))
    bend = np.arccos((distance**2 - 2) / 2)  # the elbow angle that puts the hand at `distance`
    start = np.stack([heading - bend / 2, bend], axis=1)
    up = solve_keypoints(goals, solve_keypoints(goals, start))
    down = solve_keypoints(goals, solve_keypoints(goals, np.stack([heading + bend / 2, -bend], axis=1)))
    return goals, up, down


def test_frames_in_the_mirror_compromise_come_back_to_their_neighbours_side():
    for seed in range(3):
        goals, up, down = two_basin_goals(seed)
        assert np.allclose(worst_errors(goals, up), worst_errors(goals, down), atol=1e-6)  # equally good
        poses = up.copy()
        flipped = [6, 7] if seed else [9]  # a run of two frames, a single frame
        poses[flipped] = down[flipped]
        kin = deik.forward_kinematics(goals.skeleton, poses)
        points = np.stack([kin.position("tip"), kin.position("link1")], axis=1)
        assert jolted_points(goals.targets, points, DT, goals.length)[flipped].all()

        repaired = repair_jolts(goals, poses, DT)

        assert (repaired[:, 1] > 0).all(), seed  # every elbow bent the way its neighbours' are
        assert np.allclose(repaired, up, atol=0.01), seed
        kin = deik.forward_kinematics(goals.skeleton, repaired)
        points = np.stack([kin.position("tip"), kin.position("link1")], axis=1)
        assert not jolted_points(goals.targets, points, DT, goals.length).any()


def test_a_clip_without_jolts_is_left_as_it_was():
    goals, up, _ = two_basin_goals(5)
    kin = deik.forward_kinematics(goals.skeleton, up)
    points = np.stack([kin.position("tip"), kin.position("link1")], axis=1)
    assert not jolted_points(goals.targets, points, DT, goals.length).any()
    assert np.array_equal(repair_jolts(goals, up, DT), up)


def mirror_goals(seed: int) -> tuple[KeypointGoals, np.ndarray, np.ndarray]:
    """(goals, poses, their mirror images) of a planar three-link arm whose tip alone is a key
    point, sweeping slowly along an arc within reach: a pose and its mirror image about the line
    from the base to the tip reach it alike, so a frame may swap to the mirror with no key point
    moving."""
    arm = deik.chain(3)
    rng = np.random.default_rng(seed)
    heading = rng.uniform(-1, 1) + np.linspace(0.0, rng.uniform(-0.3, 0.3), FRAMES)
    distance = rng.uniform(1.6, 2.2) + np.linspace(0.0, 0.2, FRAMES)
    tip = np.stack([distance * np.cos(heading), distance * np.sin(heading), np.zeros(FRAMES)], axis=1)
    goals = KeypointGoals(arm, ["tip"], tip[:, None], np.ones(3, bool), np.ones(3))
    poses = solve_keypoints(goals, np.stack([heading - 0.5, np.full(FRAMES, 0.6), np.full(FRAMES, 0.4)], axis=1))
    mirror = np.stack([2 * heading - poses[:, 0], -poses[:, 1], -poses[:, 2]], axis=1)
    return goals, poses, mirror


def test_frames_swapped_to_a_pose_that_reaches_as_well_follow_their_neighbours_back():
    for seed in range(3):
        goals, poses, mirror = mirror_goals(seed)
        assert np.allclose(worst_errors(goals, poses), worst_errors(goals, mirror), atol=1e-9)
        assert worst_errors(goals, poses).max() < 1e-4
        swapped = poses.copy()
        swapped[5] = mirror[5]  # one frame, and every frame from 10 on
        swapped[10:] = mirror[10:]
        kin = deik.forward_kinematics(goals.skeleton, swapped)
        assert not jolted_points(goals.targets, kin.position("tip")[:, None], DT, goals.length).any()

        repaired = repair_flips(goals, swapped, 0.2)

        assert np.abs(np.diff(repaired, axis=0)).max() < 0.2, seed  # no joint turns past the limit
        # the basin of the frames before: the same bends, a little along the self-motion at most
        assert (np.sign(repaired[:, 1:]) == np.sign(poses[:, 1:])).all(), seed
        assert np.allclose(repaired, poses, atol=0.1), seed
        assert worst_errors(goals, repaired).max() < 1e-4


def test_a_clip_without_swaps_is_left_as_it_was():
    goals, poses, _ = mirror_goals(4)
    assert np.array_equal(repair_flips(goals, poses, 0.2), poses)

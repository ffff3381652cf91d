"""The retarget's self-penetration measure and its space-time pass: capsule overlaps against
points sampled along the bones, the collision rows against finite differences, and the pass on
a jittered FK-made clip (contacts held, key points nearer, accelerations back to the truth's,
limits kept, an arm pushed out of the torso)."""

from dataclasses import replace

import numpy as np
import pytest

import deik
from deik.cleanup.contacts import Contacts
from deik.cleanup.dynamics import jolted_points, point_peak_ratios
from deik.cleanup.warmstart import dof_weights, position_jacobian
from deik.io.trajectory import Trajectory
from deik.model.capsules import bone_starts
from deik.retargeting.capsule_overlaps import BonePairs, body_pairs, collision_rows, parting_sides, penetration_depths
from deik.retargeting.ik import KeypointGoals, rebasin, solve_keypoints
from deik.retargeting.measures import retarget_report
from deik.retargeting.smooth import MotionGoals, eased_offsets, smooth_motion, spring_reference

POINTS = ("head", "left_wrist", "right_wrist", "left_elbow", "right_elbow", "left_toe_tip", "right_toe_tip")
POINTS += ("left_knee", "right_knee", "chest", "pelvis")
DT = 1 / 30


def sampled_distance(a0, a1, b0, b1, samples=401):
    """The least distance between points sampled evenly along two segments (3,)."""
    s = np.linspace(0.0, 1.0, samples)[:, None]
    on_a, on_b = a0 + s * (a1 - a0), b0 + s * (b1 - b0)
    return np.sqrt(((on_a[:, None] - on_b[None]) ** 2).sum(axis=-1)).min()


def test_two_capsules_placed_by_hand_overlap_by_their_radii_less_their_distance():
    # frames 0-1 one bone along x, frames 2-3 another along y, 0.2 above its middle
    p = np.array([[[0.0, 0, 0], [1.0, 0, 0], [0.5, -1.0, 0.2], [0.5, 1.0, 0.2]]])
    pairs = BonePairs(np.array([1]), np.array([3]), np.array([-1, 0, -1, 2]), np.array([0.3]))
    s, t, gap, distance = pairs.closest(p)
    assert s[0, 0] == pytest.approx(0.5) and t[0, 0] == pytest.approx(0.5)
    assert gap[0, 0] == pytest.approx([0.0, 0.0, -0.2])
    assert np.maximum(pairs.reach - distance, 0.0)[0, 0] == pytest.approx(0.1)


def test_crossing_capsules_are_pushed_apart_across_both_bones():
    # bone 1 along x, bone 3 along y through its middle: no gap between the closest points
    x = np.array([[[0.0, 0, 0], [1.0, 0, 0], [0.5, -1.0, 0.0], [0.5, 1.0, 0.0]]])
    jac = np.zeros((1, 4, 3, 3))
    jac[0, 2:] = np.eye(3)  # three DOFs moving the second bone along x, y, z
    pairs = BonePairs(np.array([1]), np.array([3]), np.array([-1, 0, -1, 2]), np.array([0.3]))
    errors, rows = collision_rows(x, jac, pairs, 0.01)
    assert errors[0, 0] == pytest.approx(0.31)
    assert np.abs(rows[0, 0]) == pytest.approx([0.0, 0.0, 1.0])  # along z, across both


def _crossing(heights) -> tuple[np.ndarray, BonePairs]:
    """Positions (N, 4, 3) of bone 1 along x and bone 3 along z through x = 0.5, at `heights`
    (N,) along y, and the pair of them (radii 0.1 each)."""
    N = len(heights)
    x = np.zeros((N, 4, 3))
    x[:, 1] = [1.0, 0.0, 0.0]
    x[:, 2] = np.c_[np.full(N, 0.5), heights, np.full(N, -1.0)]
    x[:, 3] = np.c_[np.full(N, 0.5), heights, np.full(N, 1.0)]
    return x, BonePairs(np.array([1]), np.array([3]), np.array([-1, 0, -1, 2]), np.array([0.2]))


def test_a_lasting_deep_overlap_is_parted_to_one_side():
    """Bone 3 lies 1 cm above or below bone 1 in turn for eight frames, 19 cm inside its
    capsule: the closest points' line flips every frame, the side the pair is parted to does
    not; two frames that close are a pass and keep their own side (none given)."""
    wobble = [0.3, 0.3] + [0.01, -0.01] * 4 + [0.3, 0.3, -0.01, 0.01, -0.3]
    x, pairs = _crossing(np.array(wobble))
    gap = pairs.closest(x)[2][:, 0]
    assert (gap[2:9, 1] * gap[3:10, 1] < 0).all()  # the raw direction flips frame by frame
    sides = parting_sides(x, pairs, 0.001, shortest=4)[:, 0]
    assert np.abs(sides[2:10, 1]) == pytest.approx(np.ones(8))
    assert (np.sign(sides[2:10, 1]) == np.sign(sides[2, 1])).all()
    assert (sides[:2] == 0).all() and (sides[10:] == 0).all()


def test_a_lasting_overlap_that_passes_through_gets_no_side():
    """Above before it, below after it, six frames close: no side, so each frame is parted the
    way it lies (collision_rows); the same run coming back above keeps one side."""
    x, pairs = _crossing(np.array([0.3, 0.3, 0.05, 0.02, 0.01, -0.01, -0.02, -0.05, -0.3, -0.3]))
    assert (parting_sides(x, pairs, 0.001, shortest=4) == 0).all()
    x, pairs = _crossing(np.array([0.3, 0.3, 0.05, 0.02, 0.01, -0.01, -0.02, -0.05, 0.3, 0.3]))
    sides = parting_sides(x, pairs, 0.001, shortest=4)[:, 0]
    assert (np.abs(sides[2:8, 1]) > 0.9).all() and (np.sign(sides[2:8, 1]) == np.sign(sides[2, 1])).all()


def test_collision_rows_part_a_pair_to_its_side_through_the_other_capsule():
    """Where the given side disagrees with the closest points' line, the row asks the pair to
    move the other way by its radii, the margin and the distance it lies on the wrong side; a
    pair close for a frame between frames apart is parted to the side it came from."""
    x, pairs = _crossing(np.array([0.3, 0.3] + [0.01, -0.01] * 4 + [0.3, 0.3]))
    jac = np.zeros((len(x), 4, 3, 3))
    jac[:, 2:] = np.eye(3)  # the second bone moves along x, y, z
    sides = parting_sides(x, pairs, 0.001, shortest=4)
    errors, rows = collision_rows(x, jac, pairs, 0.001, sides)
    up = sides[2, 0, 1]  # the run's side along y: the first bone below (-1) or above (+1) the second
    for n in range(2, 10):
        wrong = np.sign(x[n, 1, 1] - x[n, 2, 1]) != np.sign(up)
        assert errors[n, 0] == pytest.approx(0.2 + 0.001 + (0.01 if wrong else -0.01))
        assert rows[n, 0] == pytest.approx([0.0, -up, 0.0])  # moving the second bone away from that side
    # passing: apart above, a frame 1 cm below, apart above again
    x, pairs = _crossing(np.array([0.3, 0.3, -0.01, 0.3, 0.3]))
    jac = np.zeros((len(x), 4, 3, 3))
    jac[:, 2:] = np.eye(3)
    errors, rows = collision_rows(x, jac, pairs, 0.001)
    assert errors[2, 0] == pytest.approx(0.2 + 0.001 + 0.01)  # back up through the first bone
    assert rows[2, 0] == pytest.approx([0.0, 1.0, 0.0])


def test_a_pair_passing_to_the_other_side_is_parted_along_its_own_line():
    """Above, three frames near that cross below off the run's middle, then below: each frame
    is parted the way it lies (no row pulls a frame back through the other bone), where a pair
    that leaves to the side it came from is still held to that side."""
    x, pairs = _crossing(np.array([0.3, 0.05, -0.02, -0.05, -0.08, -0.3]))
    jac = np.zeros((len(x), 4, 3, 3))
    jac[:, 2:] = np.eye(3)
    errors, rows = collision_rows(x, jac, pairs, 0.001)
    for n in range(1, 5):
        below = np.sign(x[n, 2, 1] - x[n, 1, 1])  # the second bone's side of the first along y
        assert errors[n, 0] == pytest.approx(0.2 + 0.001 - abs(x[n, 2, 1]))
        assert rows[n, 0] == pytest.approx([0.0, below, 0.0])
    x, pairs = _crossing(np.array([0.3, 0.05, -0.02, -0.05, 0.3]))  # back above: held above throughout
    errors, rows = collision_rows(x, jac[:5], pairs, 0.001)
    assert errors[3, 0] == pytest.approx(0.2 + 0.001 + 0.05) and rows[3, 0] == pytest.approx([0.0, 1.0, 0.0])


def test_penetration_depths_match_points_sampled_along_the_bones():
    h = deik.humanoid()
    rng = np.random.default_rng(3)
    poses = np.clip(h.reference + rng.uniform(-1.2, 1.2, (3, h.n_dofs)), h.lower, h.upper)
    pairs = body_pairs(h, h.frame_names)
    depths = penetration_depths(h, poses, pairs)
    assert (depths > 0.01).any()  # random in-limit poses put some capsules deep into others
    start = bone_starts(h)
    p = deik.forward_kinematics(h, poses).p_world_frame
    for n in range(len(poses)):
        for k in np.flatnonzero(depths[n] > 0)[:12].tolist() + [0, len(pairs.a) - 1]:
            a, b = pairs.a[k], pairs.b[k]
            d = sampled_distance(p[n, start[a]], p[n, a], p[n, start[b]], p[n, b])
            # sampling finds the least distance from above, within half a sample's spacing
            assert max(pairs.reach[k] - d, 0.0) == pytest.approx(depths[n, k], abs=3e-3)


def test_the_pairs_leave_out_the_steering_points_and_bones_overlapping_at_rest():
    h = deik.humanoid()
    body = [name for name in h.frame_names if name != "head_top"]
    pairs = body_pairs(h, body)
    top = h.frame_index("head_top")
    assert len(pairs.a) and top not in pairs.a and top not in pairs.b
    assert (penetration_depths(h, h.reference, pairs) == 0).all()  # pairs overlapping at rest are not tested


def test_collision_rows_are_the_distance_gradients():
    h = deik.humanoid()
    rng = np.random.default_rng(5)
    pose = np.clip(h.reference + rng.normal(0.0, 0.3, h.n_dofs), h.lower, h.upper)
    pose[h.dof_names.index("left_shoulder.Zrotation")] = -1.2  # the left arm swung across the chest
    pose[h.dof_names.index("left_elbow.flexion")] = 1.5
    pairs = body_pairs(h, h.frame_names)
    x, jac = position_jacobian(h, pose[None], h.frame_names)
    margin = 0.01
    errors, rows = collision_rows(x, jac, pairs, margin)
    distance = pairs.closest(x)[3][0]
    near = np.flatnonzero(distance < pairs.reach + 2 * margin)
    assert len(near) >= 3 and rows.shape[1] == len(near)
    np.testing.assert_allclose(errors[0], pairs.reach[near] + margin - distance[near], atol=1e-12)
    # the distance is differentiable where the closest points are unique: segments apart, not parallel
    start = bone_starts(h)
    u = x[0, pairs.a[near]] - x[0, start[pairs.a[near]]]
    v = x[0, pairs.b[near]] - x[0, start[pairs.b[near]]]
    sine = np.linalg.norm(np.cross(u, v), axis=-1) / np.linalg.norm(u, axis=-1) / np.linalg.norm(v, axis=-1)
    smooth = (distance[near] > 1e-3) & (sine > 0.05)
    assert smooth.sum() >= 3
    for d in range(h.n_dofs):
        moved = []
        for sign in (1, -1):
            q = pose.copy()
            q[d] += sign * 1e-6
            p = deik.forward_kinematics(h, q[None]).p_world_frame
            moved.append(pairs.closest(p)[3][0, near])
        np.testing.assert_allclose(rows[0, smooth, d], ((moved[0] - moved[1]) / 2e-6)[smooth], atol=1e-5)


def _clip(h, n=40, seed=0):
    """(truth (n, D), drifting (n, D), jittered (n, D)): the truth's arms, spine and right leg
    swing and its root and left leg stay still 0.1 above the floor (its toe planted); the
    drifting clip swings the left leg too, slowly, so the toe slides; the jittered one shakes
    every DOF frame by frame."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 2 * np.pi, n)[:, None]
    left_leg = np.array([name.startswith(("left_hip", "left_knee", "left_ankle", "left_toes")) for name in h.dof_names])
    moving = ~left_leg & (np.arange(h.n_dofs) >= 6)
    phase = rng.uniform(0, 2 * np.pi, h.n_dofs)
    span = np.where(moving, 0.1 * (h.upper - h.lower), 0.0)
    truth = np.clip(h.reference + span * np.sin(t + phase), h.lower, h.upper)
    truth[:, 1] = 0.1 - (deik.forward_kinematics(h, truth).p_world_frame @ h.up).min()
    drifting = np.clip(truth + np.where(left_leg, 0.15, 0.0) * np.sin(2 * t + phase), h.lower, h.upper)
    jitter = np.where(np.arange(h.n_dofs) < 3, 0.01, 0.06)  # metres at the root, radians elsewhere
    shaken = np.clip(truth + rng.normal(0.0, 1.0, truth.shape) * jitter, h.lower, h.upper)
    return truth, drifting, shaken


def _measured(h, poses, names, targets, dt=DT):
    """(the left toe's largest step (m/frame) over frames 10-29, mean key-point error (m),
    largest key-point acceleration (m/s^2), the left toe's largest acceleration (m/s^2))."""
    kin = deik.forward_kinematics(h, poses)
    points = np.stack([kin.position(name) for name in names], axis=1)
    toe = kin.position("left_toe_tip")
    slide = np.linalg.norm(np.diff(toe[10:30], axis=0), axis=-1).max()
    acceleration = np.linalg.norm(np.diff(points, 2, axis=0), axis=-1).max() / dt**2
    toe_acceleration = np.linalg.norm(np.diff(toe, 2, axis=0), axis=-1).max() / dt**2
    return slide, np.linalg.norm(points - targets, axis=-1).mean(), acceleration, toe_acceleration


def _toe_planted(h, truth, names, targets):
    """MotionGoals on the humanoid: the key points `names` on `targets` (N, K, 3) and the left
    toe planted in frames 10-29; no capsule pairs (the humanoid's hanging hands graze its
    thighs' capsules, and the swinging truth puts them in; the arm test below checks the pass's
    capsule rows)."""
    mask = np.zeros((len(truth), 1), bool)
    mask[10:30] = True
    contacts = Contacts(("left_toe_tip",), mask, False, None, None, 0.0)
    weights = dof_weights(Trajectory(h, truth, DT))
    pairs = BonePairs(np.zeros(0, int), np.zeros(0, int), bone_starts(h), np.zeros(0))
    return MotionGoals(h, names, targets, contacts, np.ones(h.n_dofs, bool), weights, h.frame_names, pairs, DT, h.reach)


def test_the_space_time_pass_plants_a_sliding_contact_without_a_jolt():
    h = deik.humanoid()
    truth, drifting, _ = _clip(h)
    names = [name for name in POINTS if not name.startswith("left_")]  # only the contact holds the left foot
    targets = np.stack([deik.forward_kinematics(h, truth).position(name) for name in names], axis=1)
    found = smooth_motion(_toe_planted(h, truth, names, targets), drifting)
    assert (found >= h.lower).all() and (found <= h.upper).all()
    slide, error, _, toe_acceleration = _measured(h, found, names, targets)
    slide_before, error_before, _, toe_acceleration_before = _measured(h, drifting, names, targets)
    assert slide_before > 0.01 and slide < 1e-3  # metres per frame: the drift slides the toe; planted
    assert error < error_before + 1e-3  # the other key points stay on their targets
    # the plant's correction fades in and out over the neighbouring frames: no jolt where it starts or ends
    assert toe_acceleration < toe_acceleration_before


def test_restarting_from_the_smoothed_clip_takes_out_jitter():
    h = deik.humanoid()
    truth, _, shaken = _clip(h)
    targets = np.stack([deik.forward_kinematics(h, truth).position(name) for name in POINTS], axis=1)
    weights = dof_weights(Trajectory(h, truth, DT))
    searched = np.ones(h.n_dofs, bool)
    goals = KeypointGoals(h, POINTS, targets, searched, weights)
    found = rebasin(goals, shaken)
    again = solve_keypoints(goals, shaken)  # the same IK from the shaken poses
    assert (found >= h.lower).all() and (found <= h.upper).all()
    assert _measured(h, found, POINTS, targets)[1] < 1e-3  # metres: the key points met
    assert _measured(h, again, POINTS, targets)[1] < 1e-3

    def turning(poses):  # the largest change of any joint's rate between frames, radians per frame^2
        return np.abs(np.diff(poses[:, 6:], 2, axis=0)).max()

    # key points leave DOFs free (wrists, toes, spine twists): from the shaken poses they keep the
    # shaking; from the smoothed clip they turn as the truth does
    assert turning(again) > 10 * turning(truth) and turning(found) < 1.5 * turning(truth)


def test_the_space_time_pass_pushes_an_arm_out_of_the_torso():
    h = deik.humanoid()
    pose = h.reference.copy()
    pose[h.dof_names.index("left_shoulder.Zrotation")] = -1.2  # the left forearm into the chest
    pose[h.dof_names.index("left_elbow.flexion")] = 1.5
    poses = np.tile(pose, (12, 1))
    pairs = body_pairs(h, h.frame_names)
    before = penetration_depths(h, poses, pairs).max(axis=1)
    assert before.min() > 0.02  # metres deep
    names = ["left_wrist", "head", "pelvis"]
    targets = np.stack([deik.forward_kinematics(h, poses).position(name) for name in names], axis=1)
    weights = dof_weights(Trajectory(h, poses, 1 / 30))
    goals = MotionGoals(
        h, names, targets, None, np.ones(h.n_dofs, bool), weights, h.frame_names, pairs, 1 / 30, h.reach
    )
    found = smooth_motion(goals, poses)
    assert penetration_depths(h, found, pairs).max() < 1e-3
    assert (found >= h.lower).all() and (found <= h.upper).all()


def test_key_point_peaks_and_jolts_against_their_targets():
    t = np.linspace(0.0, 2.0, 61)[:, None, None]
    source = np.concatenate([np.sin(t), np.cos(2 * t), 0.1 * t], axis=-1) * [1.0, 0.5, 1.0]  # (61, 1, 3) metres
    ratios = point_peak_ratios(source, 2.0 * source, DT)  # the same path twice as large: twice as fast
    assert ratios["position_velocity"] == pytest.approx(2.0) and ratios["position_acceleration"] == pytest.approx(2.0)
    spiked = source.copy()
    spiked[30, 0, 1] += 0.05  # one frame 5 cm off the path
    jolted = jolted_points(source, spiked, DT, reach=1.7)
    # its acceleration marks frames 29-31, its speeds from and to it frames 29-31
    assert np.flatnonzero(jolted).tolist() == [29, 30, 31]
    assert not jolted_points(source, source, DT, reach=1.7).any()


def test_the_report_gives_each_frame_s_deepest_capsule_overlap_in_mm():
    h = deik.humanoid()
    rng = np.random.default_rng(8)
    poses = np.clip(h.reference + rng.uniform(-1.0, 1.0, (4, h.n_dofs)), h.lower, h.upper)
    poses[0] = h.reference  # apart at rest
    names = ["left_wrist", "head"]
    kin = deik.forward_kinematics(h, poses)
    targets = np.stack([kin.position(name) for name in names], axis=1)
    report = retarget_report(Trajectory(h, poses, DT), names, targets, None, 1.0, 0.1)
    # independently: SelfCollision's pairs and radii, distances between points sampled on the bones
    goal, start = deik.SelfCollision(), bone_starts(h)
    radii = goal.joint_radii(h)
    expected = np.zeros(len(poses))
    for n, p in enumerate(kin.p_world_frame):
        for a, b, _ in goal.pairs(h):
            d = sampled_distance(p[start[a]], p[a], p[start[b]], p[b])
            expected[n] = max(expected[n], radii[start[a]] + radii[start[b]] - d)
    depth = np.array(report["per_frame"]["self_penetration_mm"])
    assert depth[0] == 0.0 and depth[1:].max() > 10  # millimetres: random poses put bones deep in others
    np.testing.assert_allclose(depth, 1000 * np.maximum(expected, 0.0), atol=3.0)
    assert report["summary"]["self_penetration_max_mm"] == pytest.approx(depth.max())
    assert report["summary"]["keypoint_velocity_peak_ratio"] == pytest.approx(1.0)  # on its targets


def _untouched_goals(h, truth) -> MotionGoals:
    """MotionGoals on the humanoid: the POINTS on `truth`'s positions, no contacts, no capsule pairs."""
    targets = np.stack([deik.forward_kinematics(h, truth).position(name) for name in POINTS], axis=1)
    weights = dof_weights(Trajectory(h, truth, DT))
    pairs = BonePairs(np.zeros(0, int), np.zeros(0, int), bone_starts(h), np.zeros(0))
    return MotionGoals(h, POINTS, targets, None, np.ones(h.n_dofs, bool), weights, h.frame_names, pairs, DT, h.reach)


def _largest_steps(h) -> np.ndarray:
    """(D,) 0.05 radians a frame for every joint but the root, whose steps are free."""
    largest = np.full(h.n_dofs, np.inf)
    largest[6:] = 0.05
    return largest


def test_the_space_time_pass_keeps_each_step_within_its_largest():
    h = deik.humanoid()
    truth, _, _ = _clip(h)
    twist = h.dof_names.index("left_wrist.Zrotation")
    jumpy = truth.copy()
    jumpy[20:, twist] = np.clip(jumpy[20:, twist] + 0.6, h.lower[twist], h.upper[twist])  # a wrist snaps round
    goals = _untouched_goals(h, truth)
    found = smooth_motion(replace(goals, largest_step=_largest_steps(h)), jumpy)
    free = smooth_motion(goals, jumpy)
    assert np.abs(np.diff(free[:, twist])).max() > 0.5  # without the rows the snap stays
    assert np.abs(np.diff(found[:, 6:], axis=0)).max() < 0.05 * 1.05  # each step within its largest (row margin 5 %)
    assert (found >= h.lower - 1e-12).all() and (found <= h.upper + 1e-12).all()


def test_a_basin_jump_is_averaged_in_the_spring_reference_and_a_fast_turn_is_not():
    n = np.arange(30.0)
    first = np.stack([0.3 * np.sin(n / 5.0), 0.3 * n], axis=1)  # the second DOF turns fast throughout
    first[12:18, 0] += 1.0  # the first swaps basin for six frames
    largest = np.array([0.1, 0.1])
    found = spring_reference(first, largest, np.full(2, -np.inf), np.full(2, np.inf))
    np.testing.assert_allclose(found[:4], first[:4])  # further than 3 + 3 frames from a jump
    np.testing.assert_allclose(found[26:], first[26:])
    np.testing.assert_allclose(found[:, 1], first[:, 1], atol=1e-9)  # an even turn is no jump, and averages to itself
    for k in (11, 17):  # the steps into and out of the swap are spread over the frames around them
        assert abs(found[k + 1, 0] - found[k, 0]) < 0.5 * abs(first[k + 1, 0] - first[k, 0])
    plain = first.copy()
    plain[12:18, 0] -= 1.0
    np.testing.assert_array_equal(spring_reference(plain, largest, np.full(2, -np.inf), np.full(2, np.inf)), plain)
    # within the limits it is given
    clipped = spring_reference(first, largest, np.full(2, -0.2), np.full(2, 0.9))
    assert (clipped >= -0.2).all() and (clipped <= 0.9).all()


def test_the_space_time_pass_does_not_zigzag_through_a_basin_jump():
    """A wrist twist the key points leave free swaps to another basin for six frames and back:
    measured from the jump itself, the pass held it and let it through only as steps at the
    largest, back and forth (four such zigzags before spring_reference)."""
    h = deik.humanoid()
    truth, _, _ = _clip(h)
    twist = h.dof_names.index("left_wrist.Zrotation")
    jumpy = truth.copy()
    jumpy[20:26, twist] = np.clip(jumpy[20:26, twist] + 0.6, h.lower[twist], h.upper[twist])
    goals = _untouched_goals(h, truth)
    found = smooth_motion(replace(goals, largest_step=_largest_steps(h)), jumpy)
    steps = np.diff(found[:, 6:], axis=0)
    at_largest = np.abs(steps) > 0.9 * 0.05
    zigzags = at_largest[1:] & at_largest[:-1] & (np.sign(steps[1:]) != np.sign(steps[:-1]))
    assert not zigzags.any()
    assert np.abs(steps).max() < 0.05 * 1.05  # each step still within its largest
    assert _measured(h, found, POINTS, goals.targets)[1] < 1e-3  # metres: the key points met


def test_eased_offsets_take_the_plant_inside_a_contact_and_fade_outside():
    N, frames = 60, 6.0
    mask = np.zeros((N, 1), bool)
    mask[10:20] = mask[23:30] = True  # a second contact 3 frames after the first
    gaps = np.random.default_rng(0).normal(size=(N, 1, 3))
    out = eased_offsets(mask, gaps, frames)
    np.testing.assert_array_equal(out[mask[:, 0], 0], gaps[mask[:, 0], 0])
    assert not out[:3].any() and not out[37:].any()  # further than `frames` from every contact
    # the first frames outside a contact keep nearly all of the gap at its edge
    x = 1.0 / (frames + 1.0)
    np.testing.assert_allclose(out[9, 0], gaps[10, 0] * (1 - x * x * (3 - 2 * x)))
    np.testing.assert_allclose(out[30, 0], gaps[29, 0] * (1 - x * x * (3 - 2 * x)))
    # between the close contacts: from the one's edge gap to the other's, each frame a blend of the two
    for n, u in zip((20, 21, 22), (0.25, 0.5, 0.75)):
        s = u * u * (3 - 2 * u)
        np.testing.assert_allclose(out[n, 0], (1 - s) * gaps[19, 0] + s * gaps[23, 0])


def test_a_key_point_that_rests_joins_its_plant_and_leaves_it_without_a_jump():
    h = deik.humanoid()
    truth, drifting, _ = _clip(h, 60)
    names = [name for name in POINTS if not name.startswith("left_")] + ["left_toe_tip"]
    # the toe's target drifts through its contact, as a source's sliding toe does
    targets = np.stack([deik.forward_kinematics(h, drifting).position(name) for name in names], axis=1)
    found = smooth_motion(_toe_planted(h, truth, names, targets), drifting)
    toe = deik.forward_kinematics(h, found).position("left_toe_tip")
    path = targets[:, -1]
    step, path_step = (np.linalg.norm(np.diff(p, axis=0), axis=-1) for p in (toe, path))
    assert step[10:29].max() < 1e-3  # planted
    drift = np.linalg.norm(path[29] - toe[29])  # how far the plant lies from the target as it ends
    assert drift > 0.02
    # it rejoins its path over the easing, not in the frame the plant ends
    assert step[29:45].max() < path_step[25:45].max() + 0.5 * drift
    assert np.linalg.norm(toe[45] - path[45]) < 0.003

"""The clip warm start and easing: Jacobians against finite differences, least-squares steps
that meet the goals, which DOFs a frame may move, and eased displacements and tracks."""

import numpy as np
import pytest

from deik.cleanup.clip_goals import REACH_LEVEL, ClipGoals, eased_track, fixed_goals
from deik.cleanup.coherence import ease, hinge_channels, moving_dofs, searched_dofs
from deik.cleanup.contacts import detect_contacts
from deik.cleanup.spacetime import spacetime_step, spring_bands, spring_energy, spring_product
from deik.cleanup.warmstart import (
    LIFT_SHARE,
    dof_weights,
    floor_lifts,
    position_jacobian,
    rigid_bodies,
    warm_start,
    whole_lifts,
)
from deik.io.bvh import read_bvh
from deik.model.joints import ROTATE
from deik.model.kinematics import forward_kinematics
from deik.objectives import goals as g
from helpers import shared_path


def walk():
    return read_bvh(shared_path("humanoid", "humanoid3d_walk.bvh"))


@pytest.mark.shared_data
def test_position_jacobian_matches_finite_differences():
    clip = walk()
    sk, poses = clip.skeleton, clip.poses()[::9]
    names = ["Hips", "RightAnkle", "RightAnkle_end", "LeftElbow_end", "Chest"]
    x, jac = position_jacobian(sk, poses, names)
    index = [sk.frame_index(n) for n in names]
    np.testing.assert_allclose(x, forward_kinematics(sk, poses).p_world_frame[:, index])
    h = 1e-6
    for d in range(sk.n_dofs):
        step = np.zeros(sk.n_dofs)
        step[d] = h
        ahead = forward_kinematics(sk, poses + step).p_world_frame[:, index]
        behind = forward_kinematics(sk, poses - step).p_world_frame[:, index]
        np.testing.assert_allclose(jac[..., d], (ahead - behind) / (2 * h), atol=1e-8)


@pytest.mark.shared_data
def test_moving_dofs_follow_the_chain_to_the_root():
    sk = walk().skeleton
    names = lambda mask: {sk.dof_names[d].split(".")[0] for d in np.flatnonzero(mask)}  # noqa: E731
    assert names(moving_dofs(sk, "RightAnkle_end")) == {"Hips", "RightHip", "RightKnee", "RightAnkle"}
    assert names(moving_dofs(sk, "RightAnkle")) == {"Hips", "RightHip", "RightKnee"}  # not its own turn
    root = moving_dofs(sk, "Hips")
    assert root.sum() == 3 and not (sk.dof_kind[root] == ROTATE).any()  # its translations only


@pytest.mark.shared_data
def test_hinges_and_the_dofs_each_frame_searches():
    clip = walk()
    sk = clip.skeleton
    hinges = {sk.dof_names[d] for d in np.flatnonzero(hinge_channels(clip))}
    assert hinges == {
        f"{side}{joint}.{axis}rotation" for side in ("Left", "Right") for joint in ("Knee", "Elbow") for axis in "XY"
    } | {f"Neck.{axis}rotation" for axis in "XYZ"}  # the walk never turns its neck: the fix keeps it still
    contacts = detect_contacts(clip)
    goals = fixed_goals(clip, ClipGoals(contacts), dof_weights(clip))
    searched = searched_dofs(clip, goals)
    right = sk.dof_names.index("RightKnee.Zrotation")
    planted = contacts.mask[:, :2].any(axis=1)  # right ankle or toe
    np.testing.assert_array_equal(searched[:, right], planted)
    assert not searched[:, sk.dof_names.index("RightKnee.Xrotation")].any()
    assert not searched[:, sk.dof_names.index("Chest.Zrotation")].any()  # no goal needs the arms
    balance = fixed_goals(clip, ClipGoals(contacts, balance=True), dof_weights(clip))
    assert searched_dofs(clip, balance)[:, sk.dof_names.index("Chest.Zrotation")].all()


@pytest.mark.shared_data
def test_dof_weights_count_radians_and_the_root_translation_by_the_body_size():
    clip = walk()
    w = dof_weights(clip)
    rotation = clip.skeleton.dof_kind == ROTATE
    assert (w[rotation] == 1.0).all()
    assert 1.5 < w[~rotation][0] < 4.0 and (w[~rotation] == w[~rotation][0]).all()  # 1 / (0.25..0.7 m)


@pytest.mark.shared_data
def test_warm_start_meets_contacts_and_a_reach_smoothly_with_small_changes():
    clip = walk()
    sk = clip.skeleton
    contacts = detect_contacts(clip)
    hand = forward_kinematics(sk, clip.frames).position("LeftElbow_end")
    mask = np.zeros(clip.n_frames, bool)
    mask[14:18] = True
    active, track = eased_track(hand, mask, hand + [0.0, 0.03, 0.02], 8)  # eased in and out as clips ease reaches
    track = np.where(active[:, None], track, 0.0)
    reach = g.Position("LeftElbow_end", track, active=active, tolerance=1e-3, level=REACH_LEVEL)
    goals = fixed_goals(clip, ClipGoals(contacts), dof_weights(clip)) + [reach]
    movable = ~hinge_channels(clip)
    d = warm_start(sk, clip.poses(), goals, np.broadcast_to(movable, d_shape := clip.frames.shape), dof_weights(clip))
    assert d.shape == d_shape and (d[:, ~movable] == 0).all()
    moved = forward_kinematics(sk, clip.poses() + d)
    ground = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # a contact holds its point still along the ground
    for goal in goals:
        if isinstance(goal, g.Position):
            miss = moved.position(goal.frame) - goal.target
            error = np.linalg.norm(miss @ ground.T if goal.level < REACH_LEVEL else miss, axis=-1)[goal.active]
            assert error.max() < (1e-4 if goal.level < REACH_LEVEL else 1e-3), goal.frame
    assert np.degrees(np.abs(d[:, sk.dof_kind == ROTATE])).max() < 20
    # the neck and the right arm serve no goal: they keep the capture exactly
    idle = [n for n, name in enumerate(sk.dof_names) if name.split(".")[0] in ("Neck", "RightShoulder", "RightElbow")]
    assert (d[:, idle] == 0).all()
    # the reach starts and stops with no kink: the hand accelerates away from the capture as its track does
    added, eased = (
        np.diff(path - hand, 2, axis=0) / clip.frame_time**2
        for path in (moved.position("LeftElbow_end"), np.where(active[:, None], track, hand))
    )
    assert np.linalg.norm(added, axis=-1).max() < 1.1 * np.linalg.norm(eased, axis=-1).max() + 0.1


def test_spacetime_step_is_the_dense_least_squares_solution():
    rng = np.random.default_rng(0)
    for N, D in [(1, 3), (2, 3), (3, 2), (17, 5)]:
        rows, errors = rng.normal(size=(N, 4, D)), rng.normal(size=(N, 4))
        weights, x = rng.random((N, 4)) * 1e4, rng.normal(size=(N, D))
        movable, stiffness = rng.random((N, D)) < 0.8, 1 + rng.random(D)
        step = spacetime_step((rows, errors, weights), x, movable, 3.0, damping=0.1, stiffness=stiffness)
        K = spring_product(spring_bands(N, 3.0), np.eye(N))  # the spring matrix, column by column
        first, second = np.diff(np.eye(N), axis=0), np.diff(np.eye(N), 2, axis=0)
        np.testing.assert_allclose(K, np.eye(N) / 81 + 2 / 9 * first.T @ first + second.T @ second, atol=1e-12)
        H = np.kron(K, np.diag(stiffness)) + 0.1 * np.eye(N * D)
        g = -np.kron(K, np.diag(stiffness)) @ x.ravel()  # E's gradient at x, held entries included
        for n in range(N):
            block = slice(n * D, (n + 1) * D)
            H[block, block] += rows[n].T @ np.diag(weights[n]) @ rows[n]
            g[block] += rows[n].T @ (weights[n] * errors[n])
        free = movable.ravel()
        expected = np.zeros(N * D)
        expected[free] = np.linalg.solve(H[np.ix_(free, free)], g[free])
        np.testing.assert_allclose(step, expected.reshape(N, D), atol=1e-9)
        spring = (x.ravel() @ np.kron(K, np.diag(stiffness)) @ x.ravel()).item()
        assert spring_energy(x, 3.0, stiffness) == pytest.approx(spring, rel=1e-12)


def test_ease_is_the_banded_least_squares_solution():
    rng = np.random.default_rng(0)
    values, known, length = rng.normal(size=(40, 3)), rng.random((40, 3)) < 0.3, 5.0
    eased = ease(values, known, length)
    N = len(values)
    first, second = np.diff(np.eye(N), axis=0), np.diff(np.eye(N), 2, axis=0)
    A = np.eye(N) / length**4 + 2 / length**2 * first.T @ first + second.T @ second
    for d in range(3):
        free, fixed = ~known[:, d], known[:, d]
        expected = values[:, d].copy()
        expected[free] = np.linalg.solve(A[np.ix_(free, free)], -A[np.ix_(free, fixed)] @ values[fixed, d])
        np.testing.assert_allclose(eased[:, d], expected, atol=1e-12)


def test_ease_continues_a_known_run_smoothly_and_fades():
    known = np.zeros((40, 1), bool)
    known[:10] = True
    values = np.where(known, 0.1 * np.arange(40)[:, None], 0.0)
    eased = ease(values, known, 4.0)[:, 0]
    np.testing.assert_array_equal(eased[:10], values[:10, 0])
    assert eased[10] > eased[9]  # carries on the way it was going, then turns back
    assert np.abs(np.diff(eased, 2)).max() < 0.1  # no kink where the known frames end
    assert abs(eased[-1]) < 0.01


@pytest.mark.parametrize("gap", [3, 30])
def test_eased_track_blends_from_the_path_to_each_run(gap):
    N, blend = 10 + gap + 10, 4
    path = np.zeros((N, 3))
    mask = np.zeros(N, bool)
    mask[:10] = mask[10 + gap :] = True
    targets = np.where(mask[:, None], 1.0, np.nan)
    widened, eased = eased_track(path, mask, targets, blend)
    np.testing.assert_array_equal(eased[mask], 1.0)
    between = eased[10 : 10 + gap, 0]
    if gap > 2 * blend:
        assert between[blend:-blend].size and np.isnan(between[blend:-blend]).all()
        assert not widened[10 + blend : 10 + gap - blend].any()
        np.testing.assert_array_less(np.diff(between[:blend]), 0.0)  # easing out of the run
    else:
        assert widened.all() and (between > 0.5).all() and (between <= 1.0).all()


def landing(n: int = 60, depth: float = 0.06, speed: float = 1.2, dt: float = 1 / 60) -> np.ndarray:
    """(n,) heights of a point falling at `speed` onto the floor (height 0), sinking `depth`
    below it, resting there and rising again: a sunk landing as captured."""
    t = np.arange(n) * dt
    fall = 0.3 - speed * t
    rest = np.full(n, -depth)
    rise = -depth + speed * (t - t[-1] + 0.3 / speed) * (t > t[-1] - 0.3 / speed)
    return np.maximum(np.maximum(fall, rest), rise)


@pytest.mark.parametrize("depth", [0.01, 0.06])
def test_a_floor_lift_covers_the_depth_and_bends_no_more_than_its_share_of_the_peak(depth):
    heights = np.stack([landing(depth=depth), np.full(60, 0.5)], axis=1)  # a sinking point and one above
    level = np.array([0.0, 0.0])
    peaks = np.abs(np.diff(heights, 2, axis=0)).max(axis=0) + 1e-12
    lifted = floor_lifts(heights, level, peaks)
    assert (lifted[:, 0] >= level[0] - 1e-12).all()  # never under the floor
    assert np.array_equal(lifted[:, 1], np.zeros(60))  # a point that never sinks keeps its level
    lift = lifted[:, 0] - heights[:, 0]
    assert (lift >= -1e-12).all()  # a lift, never a push down
    bend = np.abs(np.diff(lift, 2)).max()
    assert bend <= LIFT_SHARE * peaks[0] + 1e-12, (bend, peaks[0])
    # it begins before the point reaches the floor: the landing slows down before it
    touch = int(np.argmax(heights[:, 0] <= 0))
    assert lift[touch - 2] > 0
    # and the plain clamp (the lift only where it sinks) bends by the whole landing speed
    clamp = np.maximum(level[0] - heights[:, 0], 0.0)
    assert np.abs(np.diff(clamp, 2)).max() > 10 * bend


def test_the_running_maximum_and_hann_envelope_is_above_any_profile():
    rng = np.random.default_rng(3)
    heights = rng.normal(0.0, 0.02, (80, 5)).cumsum(axis=0)
    peaks = np.abs(np.diff(heights, 2, axis=0)).max(axis=0)
    lifted = floor_lifts(heights, np.zeros(5), peaks)
    assert (lifted >= -1e-12).all() and (lifted >= heights - 1e-12).all()
    sinks = heights < 0
    assert (lifted[sinks] - heights[sinks] >= -heights[sinks] - 1e-12).all()


@pytest.mark.parametrize("n", [1, 2, 3, 5, 40])
def test_a_floor_lift_on_a_short_clip_stays_as_long_as_the_clip(n):
    heights = -np.linspace(0.0, 0.05, n)[:, None]  # sinking from the first frame on
    lifted = floor_lifts(heights, np.zeros(1), np.full(1, 1e-9))
    assert lifted.shape == (n, 1) and (lifted >= -1e-12).all()


def test_a_point_still_sinking_at_the_clip_s_end_is_lifted_smoothly_to_the_last_frame():
    """A knee still 3 cm under the floor in the last frames (a crawl cut mid-motion): the envelope
    holds the depth beyond the clip's end instead of falling to nothing there, so the lift covers
    the last frames without a kink (one that would make the point jolt, and the fix give the lift
    back, leaving the knee under the floor)."""
    n = np.arange(100)
    heights = (0.05 * np.cos(2 * np.pi * n / 40) + 0.02 - 0.05 * np.clip((n - 80) / 19, 0, 1))[:, None]
    peaks = np.abs(np.diff(heights, 2, axis=0)).max(axis=0)
    lifted = floor_lifts(heights, np.zeros(1), peaks)
    assert heights[-1, 0] < -0.025 and (lifted >= -1e-12).all()
    lift = lifted[:, 0] - heights[:, 0]
    assert np.abs(np.diff(lift, 2)).max() <= LIFT_SHARE * peaks[0] + 1e-12  # no kink, the last frames included


def test_a_body_lifted_whole_keeps_its_other_points_at_least_at_their_capture_height():
    """A heel that lands 13 mm under the floor is lifted along its envelope; the toe on the same
    bone, dipping 6 mm in the air as the foot lands, keeps at least its capture height in the
    frames the heel is lifted (so the foot is carried up, not tipped toe down onto the floor),
    and is left to the floor elsewhere; a point of another bone is not touched."""
    n = 60
    heel = landing(depth=0.013)
    toe = 0.035 + 0.1 * np.clip((30 - np.arange(n)) / 10, 0, None) - 0.006 * (np.arange(n) == 30)
    knee = np.full(n, 0.45)
    heights = np.stack([heel, toe, knee], axis=1)
    level = np.zeros(3)
    peaks = np.abs(np.diff(heights, 2, axis=0)).max(axis=0) + 1e-12
    lifted = floor_lifts(heights, level, peaks)
    whole, raised = whole_lifts(lifted, heights, level, np.array([0, 0, 1]))
    heel_lifted = lifted[:, 0] > heights[:, 0]
    assert heel_lifted.any() and not heel_lifted.all()
    np.testing.assert_array_equal(whole[:, 0], lifted[:, 0])  # the heel keeps its own lift
    np.testing.assert_array_equal(whole[heel_lifted, 1], heights[heel_lifted, 1])  # the toe its height
    np.testing.assert_array_equal(whole[~heel_lifted, 1], lifted[~heel_lifted, 1])  # and only there
    np.testing.assert_array_equal(whole[:, 2], lifted[:, 2])  # another bone: untouched
    np.testing.assert_array_equal(raised, np.stack([0 * heel_lifted, heel_lifted, 0 * heel_lifted], axis=1) > 0)


@pytest.mark.shared_data
def test_each_site_belongs_to_the_body_of_the_joint_it_is_fixed_to():
    sk = walk().skeleton
    bodies = dict(zip(sk.frame_names, rigid_bodies(sk, np.ones(sk.n_dofs, bool))))
    ankle = bodies["RightAnkle"]
    assert bodies["RightAnkle_end"] == ankle and bodies["LeftAnkle"] != ankle
    assert len(set(bodies[name] for name in sk.joint_names)) == sk.n_joints  # one body per joint

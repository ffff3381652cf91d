"""Balance in the clip warm start: the support geometry against independent computations, the
COM Jacobian against finite differences, and whole clips balanced without new jolts."""

import numpy as np
import pytest
from scipy.spatial import ConvexHull, Delaunay

from deik.clips.balance import balance_track, inside_support, nearest_support_point, support_correction
from deik.clips.contacts import detect_contacts
from deik.clips.metrics import com_outside_support, velocity_spikes
from deik.clips.problem import ClipGoals
from deik.clips.solver import fix_clip
from deik.clips.warmstart import position_jacobian
from deik.io.bvh import read_bvh
from deik.model.kinematics import forward_kinematics
from helpers import shared_path


def _clouds(n=400, sites=4, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1, 1, (n, sites, 2)), rng.uniform(-1.5, 1.5, (n, 2))


def test_inside_support_matches_scipy_hulls():
    points, q = _clouds()
    expected = np.array([Delaunay(p).find_simplex(x) >= 0 for p, x in zip(points, q)])
    np.testing.assert_array_equal(inside_support(points, q), expected)


def test_nearest_support_point_is_the_nearest_point_of_the_segments():
    points, q = _clouds(n=100, sites=3)
    nearest = nearest_support_point(points, q)
    t = np.linspace(0, 1, 2001)
    for p, x, got in zip(points, q, nearest):
        dense = np.concatenate([p[a] + t[:, None] * (p[b] - p[a]) for a in range(3) for b in range(a + 1, 3)])
        assert np.linalg.norm(x - got) <= np.linalg.norm(dense - x, axis=1).min() + 1e-12


def test_support_correction_moves_outside_points_strictly_inside():
    points, q = _clouds()
    inside = inside_support(points, q)
    correction = support_correction(points, q, 0.05)
    assert (correction[inside] == 0).all() and (correction[~inside] != 0).all()
    moved = q + correction
    assert inside_support(points, moved).all()
    for p, after in zip(points[~inside], moved[~inside]):
        hull = ConvexHull(p)
        assert (hull.equations[:, :2] @ after + hull.equations[:, 2]).max() < 0  # inside every edge


def test_balance_track_eases_shifts_in_and_out():
    N = 40
    com = np.zeros((N, 2))
    square = np.broadcast_to(np.array([[-1.0, -1], [1, -1], [1, 1], [-1, 1]]), (N, 4, 2)).copy()
    assert not balance_track(com, [(square, np.ones(N, bool), 0.1)])[1].any()  # inside: nothing steered
    square[20:23] += [3.0, 0.0]  # three frames whose support lies to the side
    track, steered = balance_track(com, [(square, np.ones(N, bool), 0.1)])
    np.testing.assert_allclose(track[20:23, 0], 2.1)  # onto the support, 0.1 inside
    np.testing.assert_allclose(track[:, 1], 0.0, atol=1e-12)
    shift = track[:, 0]
    assert (np.diff(shift[:21]) > 0).all() and (np.diff(shift[22:]) < 0).all()  # fades away on both sides
    assert shift[5] < 0.05 * 2.1 and shift[37] < 0.05 * 2.1  # within 15 frames
    assert (np.abs(np.diff(shift, 2)) < 0.3).all()  # no step
    assert steered[shift > 0.05 * 2.1].all()  # every frame it moves noticeably is steered
    inactive = np.ones(N, bool)
    inactive[20:23] = False  # the goal is off where the support moved: nothing to do
    assert not balance_track(com, [(square, inactive, 0.1)])[1].any()


@pytest.mark.shared_data
def test_com_jacobian_matches_finite_differences():
    clip = read_bvh(
        shared_path("humanoid", "humanoid3d_walk.bvh"),
        segments=shared_path("humanoid", "humanoid3d_walk.segments.json"),
    )
    sk, poses = clip.skeleton, clip.poses()[::13]
    x, jac = position_jacobian(sk, poses, ["Hips"], centre_of_mass=True)
    np.testing.assert_allclose(x[:, 1], forward_kinematics(sk, poses).p_world_com, atol=1e-12)
    h = 1e-6
    for d in range(sk.n_dofs):
        step = np.zeros(sk.n_dofs)
        step[d] = h
        numeric = (
            forward_kinematics(sk, poses + step).p_world_com - forward_kinematics(sk, poses - step).p_world_com
        ) / (2 * h)
        np.testing.assert_allclose(jac[:, 1, :, d], numeric, atol=1e-8)


@pytest.mark.shared_data
@pytest.mark.parametrize("name", ["walk", "run"])
def test_balanced_clip_keeps_its_motion(name):
    """--balance: the COM stands over the support, and the fix neither bends joints far from the
    capture (mean deviation under 10 degrees) nor adds joint velocity or acceleration peaks (at
    most 2 % above the capture's). DE alone, searching each frame afresh, meets the goals with
    poses tens of degrees from the performance that jerk between frames; these bounds catch that."""
    path = shared_path("humanoid", f"humanoid3d_{name}.bvh")
    clip = read_bvh(path, segments=str(path).replace(".bvh", ".segments.json"))
    contacts = detect_contacts(clip)
    fix = fix_clip(clip, ClipGoals(contacts, balance=True), seed=0)
    assert fix.met.all()
    assert np.nanmean(com_outside_support(fix.clip, contacts)) < 0.1 * np.nanmean(com_outside_support(clip, contacts))
    deviation = np.degrees(np.abs(fix.clip.poses() - clip.poses())).mean()
    assert deviation < 10.0
    before, after = velocity_spikes(clip), velocity_spikes(fix.clip)
    assert after["max_dof_velocity"] <= 1.02 * before["max_dof_velocity"]
    assert after["max_dof_acceleration"] <= 1.02 * before["max_dof_acceleration"]

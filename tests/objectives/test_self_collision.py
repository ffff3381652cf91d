"""SelfCollision: segment distances against bounded least squares, the term's penetration on
random in-limit poses against a brute-force sum over independently measured pairs (CPU kernel
and NumPy oracle), which pairs are tested, default and user radii, and bad input."""

import numpy as np
import pytest
from scipy.optimize import lsq_linear

import deik
from deik.backends.targets import cpu as dev
from deik.model.geometry import segments_distance
from deik.objectives import reference
from helpers import kernel_fitness, random_poses


def lsq_distance(a0, a1, b0, b1):
    """Distance between two segments: min |a0 + s (a1 - a0) - b0 - t (b1 - b0)| over s, t in
    [0, 1], as a bounded linear least-squares problem (scipy)."""
    A = np.stack([a1 - a0, -(b1 - b0)], axis=1)
    fit = lsq_linear(A, b0 - a0, bounds=(0.0, 1.0), method="bvls")
    return float(np.linalg.norm(A @ fit.x - (b0 - a0)))


def _segment_cases(rng):
    cases = [rng.normal(size=(4, 3)) for _ in range(40)]
    a0, a1 = rng.normal(size=(2, 3))
    cases.append(np.stack([a0, a1, a0 + 0.3 * (a1 - a0) + [0, 0, 0.2], a0 + 1.7 * (a1 - a0) + [0, 0, 0.2]]))  # parallel
    cases.append(np.stack([a0, a1, a0 + 1.5 * (a1 - a0), a0 + 2.5 * (a1 - a0)]))  # collinear, apart
    cases.append(np.stack([a0, a0, a1, a1 + 0.1]))  # a point and a segment
    cases.append(np.stack([a0, a1, a1 + 0.5, a1 + 0.5]))  # a segment and a point
    cases.append(np.stack([a0, a0, a1, a1]))  # two points
    return np.array(cases)


def test_segment_distances_equal_bounded_least_squares():
    cases = _segment_cases(np.random.default_rng(0))
    expected = np.array([lsq_distance(*c) for c in cases])
    np.testing.assert_allclose(segments_distance(*cases.transpose(1, 0, 2)), expected, atol=1e-9)
    device = [dev.segments_distance(np.ascontiguousarray(c.ravel()), 0, 1, 2, 3) for c in cases]
    np.testing.assert_allclose(device, expected, atol=1e-9)


def brute_force_penetration(sk, goal, poses):
    """(N,) the summed penetration of every tested pair, each distance from lsq_distance."""
    kin = deik.forward_kinematics(sk, poses)
    radii = goal.joint_radii(sk)
    start = np.concatenate([[-1], sk.parents[1:], sk.site_joint])
    out = np.zeros(len(poses))
    for a, b, _ in goal.pairs(sk):
        for n, p in enumerate(kin.p_world_frame):
            d = lsq_distance(p[start[a]], p[a], p[start[b]], p[b])
            out[n] += max(radii[start[a]] + radii[start[b]] + goal.margin - d, 0.0)
    return out


@pytest.mark.parametrize("margin", [0.0, 0.03])
def test_penetration_equals_brute_force_on_random_in_limit_poses(margin):
    h = deik.humanoid()
    goal = deik.SelfCollision(margin=margin)
    problem = deik.Problem(h, [goal])
    rng = np.random.default_rng(11)
    near = np.clip(h.reference + rng.normal(0.0, 0.15, (4, h.n_dofs)), h.lower, h.upper)
    poses = np.vstack([h.reference, near, random_poses(h, 5, 12)])
    expected = brute_force_penetration(h, goal, poses)
    assert (expected[1:] > 0).any() and expected[-5:].min() > 0  # random in-limit poses collide
    np.testing.assert_allclose(kernel_fitness(problem, poses)[2][:, 0], expected, atol=1e-9)
    np.testing.assert_allclose(reference.raw_errors(problem, poses)[:, 0], expected, atol=1e-9)
    if margin == 0.0:
        assert expected[0] == 0.0  # the rest pose is free by construction


def _bone(sk, name):
    return sk.frame_index(name)


def test_tested_pairs_keep_arms_out_of_the_torso_and_legs_apart():
    h = deik.humanoid()
    pairs = {(a, b) for a, b, _ in deik.SelfCollision().pairs(h)}
    has = lambda x, y: (min(_bone(h, x), _bone(h, y)), max(_bone(h, x), _bone(h, y))) in pairs  # noqa: E731
    # bones are named by their end frame: left_elbow is the upper arm, chest the middle trunk
    for arm in ("left_elbow", "left_wrist", "left_hand", "right_hand"):
        assert has(arm, "chest") and has(arm, "spine"), arm
    assert has("left_knee", "right_knee") and has("left_ankle", "right_ankle")  # thighs, shanks
    assert has("left_hand", "right_hand")
    assert not has("left_shoulder", "left_elbow")  # parent and child
    assert not has("left_clavicle", "neck")  # siblings: both leave the chest
    assert not has("left_shoulder", "neck")  # two links: clavicle bone and upper trunk, across chest-clavicle
    assert has("left_elbow", "neck")  # three links: the upper arm and the upper trunk
    assert not has("left_knee", "chest")  # thigh and belly overlap at rest
    all_links = {(a, b) for a, b, _ in deik.SelfCollision(skip=1).pairs(h)}
    upper_arm_and_collarbone = (_bone(h, "left_clavicle"), _bone(h, "left_elbow"))  # two links apart
    assert pairs < all_links and upper_arm_and_collarbone in all_links - pairs


def test_default_radii_follow_the_segment_masses_and_scale_with_height():
    h = deik.humanoid()
    radii = dict(zip(h.joint_names, deik.SelfCollision().joint_radii(h)))
    assert 0.07 < radii["left_hip"] < 0.1 and 0.03 < radii["left_shoulder"] < 0.06  # thigh, upper arm (m)
    assert 0.1 < radii["spine"] < 0.16 and radii["left_clavicle"] == 0.0  # trunk; a massless joint
    tall = deik.SelfCollision().joint_radii(deik.humanoid(height=3.5))
    np.testing.assert_allclose(tall, 2 * np.array(list(radii.values())), rtol=1e-9)


def test_user_radii_override_the_default():
    h = deik.humanoid()
    default = deik.SelfCollision().joint_radii(h)
    given = deik.SelfCollision(radii={"left_wrist": 0.2}).joint_radii(h)
    k = h.joint_names.index("left_wrist")
    assert given[k] == 0.2 and np.array_equal(np.delete(given, k), np.delete(default, k))
    assert (deik.SelfCollision(radii=0.05).joint_radii(h) == 0.05).all()


@pytest.mark.parametrize(
    "goal, message",
    [
        (deik.SelfCollision(margin=-0.1), "margin must be a finite number >= 0"),
        (deik.SelfCollision(skip=0), "skip must be an integer >= 1"),
        (deik.SelfCollision(radii={"left_hand": 0.1}), "'left_hand' is a site; radii go on joints"),
        (deik.SelfCollision(radii={"left_wrsit": 0.1}), "did you mean 'left_wrist'"),
        (deik.SelfCollision(radii=float("nan")), "radii must be a finite number >= 0"),
        (deik.SelfCollision(skip=40), "no bone pair to test.*lower skip"),
    ],
)
def test_bad_input_names_the_problem(goal, message):
    with pytest.raises((ValueError, KeyError), match=message):
        deik.Problem(deik.humanoid(), [goal])

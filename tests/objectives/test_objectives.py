"""Objectives: the compiled evaluation against the NumPy oracle for every goal kind, raw errors
against independent computations, the normalisation, and strict-priority ordering."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import deik
from deik import Joint, Site, build_skeleton, translation
from deik.backends.targets import cpu as dev
from deik.objectives import reference
from deik.objectives.registry import KIND_NAMES
from helpers import every_goal_problem, kernel_fitness


def raw_of(problem, poses, label):
    """Raw error of the term `label` from both the kernel and the oracle."""
    t = problem.table.labels.index(label)
    k = kernel_fitness(problem, poses)[2][:, t]
    r = reference.raw_errors(problem, np.atleast_2d(poses))[:, t]
    return k, r


def mixed_poses(sk, n_random=12, seed=3):
    rng = np.random.default_rng(seed)
    span = sk.upper - sk.lower
    near = sk.reference + rng.normal(0.0, 0.05, (6, sk.n_dofs))
    wild = rng.uniform(sk.lower - 0.3 * span, sk.upper + 0.3 * span, (n_random, sk.n_dofs))
    return np.vstack([sk.reference[None], near, wild])


def test_every_goal_kind_kernel_equals_oracle():
    problem = every_goal_problem()
    kinds = set(problem.table.kinds.tolist())
    assert kinds == set(range(len(KIND_NAMES))), "the problem must exercise every term kind"
    poses = mixed_poses(problem.skeleton)
    lv_k, tot_k, raw_k = kernel_fitness(problem, poses)
    lv_r, tot_r, raw_r = reference.fitness(problem, poses)
    np.testing.assert_allclose(raw_k, raw_r, rtol=0, atol=1e-9)
    np.testing.assert_allclose(lv_k, lv_r, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tot_k, tot_r, rtol=0, atol=1e-9)
    # the comparison covers the interesting branches, not only zeros
    t = {label: k for k, label in enumerate(problem.table.labels)}
    for label in ("obstacle", "self collision", "floor", "com in support polygon", "joint limits"):
        assert (raw_r[:, t[label]] == 0).any() and (raw_r[:, t[label]] > 0).any(), label
    assert problem.table.n_levels == 4  # penalty level + 0, 1, 2


def test_batched_problem_kernel_equals_oracle_per_problem_index():
    problem = every_goal_problem(batch=True)
    assert problem.batch_size == 2
    poses = mixed_poses(problem.skeleton, n_random=5, seed=4)
    idx = np.arange(len(poses)) % 2
    lv_k, tot_k, raw_k = kernel_fitness(problem, poses, idx)
    lv_r, tot_r, raw_r = reference.fitness(problem, poses, idx)
    np.testing.assert_allclose(raw_k, raw_r, rtol=0, atol=1e-9)
    np.testing.assert_allclose(lv_k, lv_r, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tot_k, tot_r, rtol=0, atol=1e-9)
    # the two problems really differ: the same pose scores differently against each
    lv_0 = kernel_fitness(problem, poses[:1], [0])[2]
    lv_1 = kernel_fitness(problem, poses[:1], [1])[2]
    assert not np.allclose(lv_0, lv_1)


def test_orientation_error_equals_scipy_magnitude():
    h = deik.humanoid()
    rng = np.random.default_rng(20)
    target = Rotation.random(random_state=rng)
    problem = deik.Problem(h, [deik.Orientation("left_hand", target.as_matrix())])
    poses = rng.uniform(h.lower, h.upper, (10, h.n_dofs))
    frames = Rotation.from_matrix(deik.forward_kinematics(h, poses).rotation("left_hand"))
    expected = (target.inv() * frames).magnitude()
    k, r = raw_of(problem, poses, "orientation left_hand")
    np.testing.assert_allclose(r, expected, atol=1e-10)
    np.testing.assert_allclose(k, expected, atol=1e-10)


def test_aim_error_equals_independent_angle():
    h = deik.humanoid()
    rng = np.random.default_rng(21)
    point = np.array([0.5, 1.2, 2.0])
    axis = np.array([1.0, 1.0, 0.0])  # not unit length on purpose
    problem = deik.Problem(h, [deik.Aim("left_hand", point, axis=tuple(axis))])
    poses = rng.uniform(h.lower, h.upper, (10, h.n_dofs))
    kin = deik.forward_kinematics(h, poses)
    expected = []
    for n in range(len(poses)):
        u = kin.rotation("left_hand")[n] @ axis
        v = point - kin.position("left_hand")[n]
        expected.append(math.acos(np.clip(u @ v / (np.linalg.norm(u) * np.linalg.norm(v)), -1, 1)))
    k, r = raw_of(problem, poses, "aim left_hand")
    np.testing.assert_allclose(r, expected, atol=1e-7)
    np.testing.assert_allclose(k, expected, atol=1e-7)


def _square_feet_skeleton():
    """Four massless foot sites at (+-0.5, 0, +-0.5) and one point mass free to slide."""
    corners = [(0.5, 0.0, 0.5), (-0.5, 0.0, 0.5), (-0.5, 0.0, -0.5), (0.5, 0.0, -0.5)]
    return build_skeleton(
        [Joint("ground", None), Joint("body", "ground", (0, 0, 0), translation("XYZ", -3, 3), mass=10.0)],
        sites=[Site(f"foot{k}", "ground", c) for k, c in enumerate(corners)],
    )


@pytest.mark.parametrize(
    "com, expected",
    [
        ((0.0, 1.0, 0.0), 0.0),  # inside, any height
        ((0.45, -0.3, -0.49), 0.0),  # inside near a corner
        ((0.5, 0.7, 0.0), 0.0),  # on an edge
        ((0.8, 0.3, 0.1), 0.3),  # beside the x = 0.5 edge
        ((0.1, 2.0, -1.25), 0.75),  # beyond the z = -0.5 edge
        ((0.9, 0.0, 0.9), math.sqrt(0.32)),  # off a corner
        ((-2.5, 1.0, 1.5), math.hypot(2.0, 1.0)),
    ],
)
def test_support_polygon_distance_by_hand(com, expected):
    sk = _square_feet_skeleton()
    problem = deik.Problem(sk, [deik.ComInPolygon(("foot0", "foot1", "foot2", "foot3"))])
    pose = np.array(com)
    assert np.allclose(deik.forward_kinematics(sk, pose).p_world_com, com)
    k, r = raw_of(problem, pose, "com in support polygon")
    assert r[0] == pytest.approx(expected, abs=1e-12)
    assert k[0] == pytest.approx(expected, abs=1e-12)


def test_support_polygon_with_two_and_one_points():
    sk = _square_feet_skeleton()
    pose = np.array([0.0, 0.0, 0.2])
    segment = deik.Problem(sk, [deik.ComInPolygon(("foot0", "foot1"))])  # the z = 0.5 edge
    point = deik.Problem(sk, [deik.ComInPolygon(("foot2",))])
    for problem, expected in ((segment, 0.3), (point, math.hypot(0.5, 0.7))):
        k, r = raw_of(problem, pose, "com in support polygon")
        assert r[0] == pytest.approx(expected, abs=1e-12)
        assert k[0] == pytest.approx(expected, abs=1e-12)


def test_support_polygon_with_collinear_points():
    sk = build_skeleton(
        [Joint("ground", None), Joint("body", "ground", (0, 0, 0), translation("XY", -3, 3), mass=1.0)],
        sites=[Site(f"f{k}", "ground", (x, 0.0, 0.0)) for k, x in enumerate((-0.5, 0.0, 0.5))],
    )
    problem = deik.Problem(sk, [deik.ComInPolygon(("f0", "f1", "f2"))])
    pose = np.array([2.0, 0.7])  # COM at x = 2, its ground projection 1.5 beyond f2
    k, r = raw_of(problem, pose, "com in support polygon")
    assert r[0] == pytest.approx(1.5, abs=1e-12)
    assert k[0] == pytest.approx(1.5, abs=1e-12)


def test_com_over_support_ignores_height():
    sk = _square_feet_skeleton()
    problem = deik.Problem(sk, [deik.ComOverSupport((0.2, 5.0, -0.1))])
    k, r = raw_of(problem, np.array([0.5, -1.0, 0.3]), "com over support")
    assert r[0] == pytest.approx(0.5, abs=1e-12) and k[0] == pytest.approx(0.5, abs=1e-12)


@pytest.mark.parametrize(
    "pose, centre, radius, bone_radius, expected",
    [
        # straight chain along +X (bones [0,1], [1,2], [2,3]); sphere above the middle bone
        pytest.param((0, 0, 0), (1.5, 0.2, 0), 0.5, 0.0, 0.5 - 0.2),
        pytest.param((0, 0, 0), (1.5, 0.2, 0), 0.5, 0.1, (0.6 - 0.2) + 2 * (0.6 - math.hypot(0.5, 0.2))),
        pytest.param((0, 0, 0), (1.5, 0.0, 0.0), 0.3, 0.0, 0.3),  # centre on the bone
        ((0, 0, 0), (1.5, 1.2, 0), 0.5, 0.0, 0.0),  # clear of every bone
        # bent at link1 by 90 degrees: bones [0,0]-[1,0], [1,0]-[1,1], [1,1]-[1,2]
        pytest.param((0, math.pi / 2, 0), (1.3, 0.2, 0), 0.5, 0.0, (0.5 - math.hypot(0.3, 0.2)) + (0.5 - 0.3)),
    ],
)
def test_obstacle_penetration_by_hand(pose, centre, radius, bone_radius, expected):
    sk = deik.chain(3)
    problem = deik.Problem(sk, [deik.Obstacle(centre, radius, bone_radius=bone_radius)])
    k, r = raw_of(problem, np.array(pose, float), "obstacle")
    assert r[0] == pytest.approx(expected, abs=1e-12)
    assert k[0] == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize(
    "pose, height, expected",
    [
        ((0, 0, 0), 0.0, 0.0),  # the chain lies on the floor: nothing below it
        ((0, 0, 0), 0.25, 4 * 0.25),  # a floor above all four frames
        ((-math.pi / 2, 0, 0), -0.5, 0.5 + 1.5 + 2.5),  # hanging down: link1, link2, tip below -0.5
        ((0, math.pi / 2, 0), -0.1, 0.0),  # bent upwards at link1: all above
    ],
)
def test_floor_depth_by_hand(pose, height, expected):
    sk = deik.chain(3)  # y up, frames 1 apart along the chain
    problem = deik.Problem(sk, [deik.Floor(height)])
    k, r = raw_of(problem, np.array(pose, float), "floor")
    assert r[0] == pytest.approx(expected, abs=1e-12)
    assert k[0] == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize(
    "pose, clearance, expected",
    [
        ((0, 0, 0), (0.1, 0.1, 0.1, 0.1), 4 * 0.1),  # lying on the floor: each point's surface 0.1 under it
        ((0, 0, 0), (np.nan, 0.2, np.nan, 0.05), 0.25),  # only the listed points count
        ((-math.pi / 2, 0, 0), (0.0, 0.3, 0.3, 0.3), 0.5 + 1.5 + 2.5 + 3 * 0.3),  # hanging below -0.5
        ((math.pi / 2, 0, 0), (0.0, 0.3, 0.3, 0.3), 0.5),  # standing up: only the root is below
    ],
)
def test_floor_clearance_keeps_each_listed_point_that_far_above(pose, clearance, expected):
    sk = deik.chain(3)
    height = 0.5 if pose[0] > 0 else (-0.5 if pose[0] < 0 else 0.0)
    problem = deik.Problem(sk, [deik.Floor(height, clearance=np.array(clearance))])
    k, r = raw_of(problem, np.array(pose, float), "floor")
    assert r[0] == pytest.approx(expected, abs=1e-12)
    assert k[0] == pytest.approx(expected, abs=1e-12)
    with pytest.raises(ValueError, match="floor clearance must be"):
        deik.Problem(sk, [deik.Floor(0.0, clearance=np.ones(3))])


def test_a_floor_height_must_be_finite():
    with pytest.raises(ValueError, match="floor height must be a finite number"):
        deik.Problem(deik.chain(3), [deik.Floor(float("nan"))])


def test_obstacle_parameters_hold_radius_and_bone_radius():
    sk = deik.chain(3)
    params = deik.Obstacle((1.0, 2.0, 3.0), 0.5, bone_radius=0.1).row(sk).params
    np.testing.assert_array_equal(params[0, :5], [1.0, 2.0, 3.0, 0.5, 0.1])


def test_comfort_sum_and_max_by_hand():
    sk = deik.chain(4, dims=3)  # 8 DOFs, two per joint
    ref = np.array([0.1, -0.2, 0.0, 0.3, 0.5, 0.0, -0.4, 0.2])
    pose = np.array([0.4, -0.2, -0.6, 0.3, 0.0, 1.0, -0.4, -0.3])
    weights = {"link1": 2.0, "link3": 0.5}  # link0 and link2 weigh nothing
    dw = np.array([0, 0, 2, 2, 0, 0, 0.5, 0.5])
    diff = np.abs(pose - ref)  # [0.3, 0, 0.6, 0, 0.5, 1.0, 0, 0.5]
    problem = deik.Problem(
        sk,
        [
            deik.Comfort("sum", joint_weights=weights, reference=ref),
            deik.Comfort("max", joint_weights=weights, reference=ref),
            deik.Comfort("sum"),  # default weights 1 and the skeleton's reference (zeros)
        ],
    )
    for label, expected in (("comfort (sum)", 2 * 0.6 + 0.5 * 0.5), ("comfort (max)", 2 * 0.6)):
        k, r = raw_of(problem, pose, label)
        assert r[0] == pytest.approx(expected, abs=1e-12)
        assert k[0] == pytest.approx(expected, abs=1e-12)
    assert (dw * diff).sum() == pytest.approx(1.45)


def test_each_comfort_goal_uses_its_own_reference():
    sk = deik.chain(3)
    pose = np.zeros((1, 3))
    try:
        problem = deik.Problem(
            sk,
            [
                deik.Comfort(reference=[1.0, 1.0, 1.0]),
                deik.Comfort("sum"),
                deik.Comfort("max", reference=[0.5, -2.0, 0.0]),
            ],
        )
    except ValueError:
        return  # refusing conflicting references would be fine too
    raw_r = reference.raw_errors(problem, pose)[0]
    raw_k = kernel_fitness(problem, pose)[2][0]
    for raw in (raw_r, raw_k):
        np.testing.assert_allclose(raw, [3.0, 0.0, 2.0], atol=1e-12)


@pytest.mark.parametrize("mode, expected", [("start", [1, 2 / 3, 1 / 3, 0]), ("end", [0, 1 / 3, 2 / 3, 1])])
def test_comfort_ramps(mode, expected):
    sk = deik.chain(4)
    pose = np.array([0.5, -1.0, 2.0, 0.7])
    problem = deik.Problem(sk, [deik.Comfort("sum", joint_weights=mode)])
    k, r = raw_of(problem, pose, "comfort (sum)")
    assert r[0] == pytest.approx(np.dot(expected, np.abs(pose)), abs=1e-12)
    assert k[0] == pytest.approx(r[0], abs=1e-12)


def test_normalisation_is_one_minus_exp():
    sk = deik.chain(5)
    rng = np.random.default_rng(22)
    target = deik.forward_kinematics(sk, rng.uniform(-1, 1, 5)).position("tip")
    problem = deik.Problem(sk, [deik.Position("tip", target, weight=0.7, mu=2.5)])
    poses = rng.uniform(sk.lower, sk.upper, (6, 5))
    d = np.linalg.norm(deik.forward_kinematics(sk, poses).position("tip") - target, axis=1)
    expected = 0.7 * (1.0 - np.exp(-2.5 * d / 5.0))
    levels, total, raw = kernel_fitness(problem, poses)
    np.testing.assert_allclose(raw[:, 0], d, atol=1e-12)
    np.testing.assert_allclose(total, expected, atol=1e-12)
    np.testing.assert_allclose(levels[:, 0], expected, atol=1e-12)  # one level: level = total
    np.testing.assert_allclose(problem.table.normalise(raw)[:, 0] * 0.7, expected, atol=1e-12)
    assert (problem.table.normalise(np.array([[1e6]])) <= 1.0).all()


def test_priority_level_counts_only_the_excess_over_tolerance():
    sk = deik.chain(3)
    q = np.array([0.5, 0.5, 0.5])
    tip = deik.forward_kinematics(sk, q).position("tip")
    inward = -tip / np.linalg.norm(tip)
    f = lambda x: -math.expm1(-x / 3.0)  # noqa: E731  (mu 1, scale = reach 3)
    for d in (0.05, 0.2, 0.5, 1.0):
        problem = deik.Problem(
            sk, [deik.Position("tip", tip + d * inward, tolerance=0.2, weight=0.6), deik.Comfort(level=1)]
        )
        assert problem.table.n_levels == 2
        levels, total, raw = kernel_fitness(problem, q)
        assert raw[0, 0] == pytest.approx(d, abs=1e-12)
        assert levels[0, 0] == pytest.approx(0.6 * max(f(d) - f(0.2), 0.0), abs=1e-12)
        assert total[0] == pytest.approx(0.6 * f(d) + f_comfort(q), abs=1e-12)  # plain weighted sum


def f_comfort(q, mu=0.1):
    return -math.expm1(-mu * np.abs(q).sum())


def test_float32_keeps_tiny_errors_non_zero():
    sk = deik.chain(3)
    problem = deik.Problem(sk, [deik.Comfort("sum")])  # mu 0.1, scale 1
    pose = np.array([1e-8, 0.0, 0.0])
    # naive float32 1 - exp(-x) loses this completely; the kernels must not
    assert np.float32(1.0) - np.exp(np.float32(-1e-9)) == 0.0
    levels, total, raw = kernel_fitness(problem, pose, dtype=np.float32)
    assert total.dtype == np.float32
    assert raw[0, 0] == pytest.approx(1e-8, rel=1e-6)
    assert total[0] > 0 and total[0] == pytest.approx(1e-9, rel=1e-5)
    assert levels[0, 0] == pytest.approx(1e-9, rel=1e-5)
    assert problem.table.normalise(np.float32([[1e-8]]))[0, 0] == pytest.approx(1e-9, rel=1e-5)


def test_float32_evaluation_close_to_float64_oracle():
    problem = every_goal_problem()
    poses = mixed_poses(problem.skeleton, n_random=4, seed=5)
    lv32, tot32, raw32 = kernel_fitness(problem, poses, dtype=np.float32)
    lv, tot, raw = reference.fitness(problem, poses.astype(np.float32).astype(np.float64))
    np.testing.assert_allclose(tot32, tot, atol=2e-4)
    np.testing.assert_allclose(lv32, lv, atol=2e-4)


def _two_target_problem(weight0=0.5):
    sk = deik.chain(3)
    a = deik.forward_kinematics(sk, np.array([0.3, 0.4, -0.2])).position("tip")
    b = deik.forward_kinematics(sk, np.array([-0.5, 0.6, 0.3])).position("tip")
    problem = deik.Problem(
        sk, [deik.Position("tip", a, tolerance=0.05, weight=weight0), deik.Position("tip", b, level=1)]
    )
    return problem, np.array([0.3, 0.4, -0.2]), np.array([-0.5, 0.6, 0.3]), np.linalg.norm(a - b)


def test_strict_priority_meeting_level_zero_beats_a_better_lower_level():
    problem, at_a, at_b, gap = _two_target_problem()
    assert gap > 0.5
    poses = np.stack([at_a, at_b])
    levels, total, raw = reference.fitness(problem, poses)
    np.testing.assert_allclose(raw[0], [0.0, gap], atol=1e-12)
    np.testing.assert_allclose(raw[1], [gap, 0.0], atol=1e-12)
    assert levels[0, 0] == 0.0 and levels[0, 1] > levels[1, 1]
    # the weighted sum would prefer the pose at B ...
    assert total[1] < total[0]
    # ... but strict priority prefers the pose that meets level 0
    assert dev.not_worse(levels[0], levels[1])
    assert not dev.not_worse(levels[1], levels[0])
    # ties are accepted (DE may drift on plateaus) and are symmetric
    assert dev.not_worse(levels[0], levels[0].copy())
    # within tolerance of A, level 0 is zero and only level 1 decides
    near_a = at_a + np.array([0.0, 0.0, 0.005])
    lv_near = reference.fitness(problem, near_a[None])[0][0]
    assert reference.raw_errors(problem, near_a[None])[0, 0] < 0.05
    assert lv_near[0] == 0.0
    assert dev.not_worse(lv_near, levels[1]) and not dev.not_worse(levels[1], lv_near)
    # and on level 0 ties, level 1 decides: nearer to B wins
    toward_b = reference.fitness(problem, (at_a + 0.02 * (at_b - at_a))[None])[0][0]
    assert toward_b[0] == 0.0 and toward_b[1] < levels[0, 1]
    assert dev.not_worse(toward_b, levels[0]) and not dev.not_worse(levels[0], toward_b)
    # the compiled levels agree with the oracle's
    np.testing.assert_allclose(kernel_fitness(problem, poses)[0], levels, atol=1e-12)

"""Clear errors for bad goals, problems, settings and solve() arguments."""

import math

import numpy as np
import pytest

import deik
from deik import Joint, Site, build_skeleton, euler, hinge, translation


@pytest.fixture(scope="module")
def chain3():
    return deik.chain(3)


@pytest.fixture(scope="module")
def tip_target(chain3):
    q = np.random.default_rng(0).uniform(chain3.lower, chain3.upper)
    return deik.forward_kinematics(chain3, q).position("tip")


def problem(skeleton, *goals, **kw):
    return deik.Problem(skeleton, list(goals), **kw)


# --- targets ---------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_position_target(chain3, bad):
    with pytest.raises(ValueError, match=r"tip target contains NaN or infinite values"):
        problem(chain3, deik.Position("tip", [0.5, bad, 0.0]))


@pytest.mark.parametrize("target", [[1.0, 2.0], 1.0, np.zeros((2, 2, 3)), np.zeros((3, 2))])
def test_wrong_position_target_shape(chain3, target):
    with pytest.raises(ValueError, match=r"tip target must have shape \(3,\) or \(batch, \*\(3,\)\)"):
        problem(chain3, deik.Position("tip", target))


def test_non_finite_or_misshapen_targets_of_other_goals(chain3):
    with pytest.raises(ValueError, match=r"centre-of-mass target contains NaN"):
        problem(chain3, deik.CentreOfMass([math.nan, 0, 0]))
    with pytest.raises(ValueError, match=r"aim target must have shape \(3,\)"):
        problem(chain3, deik.Aim("tip", [1.0, 0.0]))
    with pytest.raises(ValueError, match=r"orientation target for 'tip' in form 'matrix' must have shape \(3, 3\)"):
        problem(chain3, deik.Orientation("tip", np.eye(2)))
    with pytest.raises(ValueError, match=r"support point contains NaN"):
        problem(chain3, deik.ComOverSupport([0, math.inf, 0]))
    with pytest.raises(ValueError, match=r"obstacle centre must have shape"):
        problem(chain3, deik.Obstacle([0.0, 1.0], 0.2))


def test_orientation_target_must_be_a_rotation(chain3):
    with pytest.raises(ValueError, match=r"orientation target for 'tip' is not a rotation matrix"):
        problem(chain3, deik.Orientation("tip", np.diag([1.0, 1.0, -1.0])))
    with pytest.raises(ValueError, match=r"not a rotation matrix"):
        problem(chain3, deik.Orientation("tip", 2 * np.eye(3)))
    skewed = np.eye(3)
    skewed[0, 1] = 1e-4  # R R^T off by 1e-4: rejected; float32 rounding (1e-7) is accepted
    with pytest.raises(ValueError, match=r"not a rotation matrix"):
        problem(chain3, deik.Orientation("tip", skewed))
    problem(chain3, deik.Orientation("tip", np.eye(3).astype(np.float32) + 1e-7))


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
def test_aim_axis_must_be_non_zero(chain3):
    with pytest.raises(ValueError, match=r"aim axis for 'tip' must be non-zero"):
        problem(chain3, deik.Aim("tip", [1.0, 1.0, 0.0], axis=(0.0, 0.0, 0.0)))


def test_unreachable_target_names_distance_and_length(chain3):
    with pytest.raises(
        ValueError,
        match=r"position tip: target \[3\.5, 0\.0, 0\.0\] is unreachable: it lies "
        r"3\.5 from the root's range but the chain to it is only 3 long",
    ):
        problem(chain3, deik.Position("tip", [3.5, 0.0, 0.0]))
    # an intermediate joint has a shorter chain
    with pytest.raises(ValueError, match=r"position link1: .* only 1 long"):
        problem(chain3, deik.Position("link1", [0.0, 1.5, 0.0]))
    # exactly at full reach is fine, and so is a target made by forward kinematics
    problem(chain3, deik.Position("tip", [0.0, 3.0, 0.0]))
    problem(chain3, deik.Position("link1", [0.0, -1.0, 0.0]))


def test_unreachable_target_in_a_batch_names_the_worst(chain3):
    targets = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 5.0], [2.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"target \[0\.0, 0\.0, 5\.0\] is unreachable"):
        problem(chain3, deik.Position("tip", targets))


def test_unreachable_centre_of_mass(chain3):
    with pytest.raises(ValueError, match=r"centre of mass: target .* is unreachable"):
        problem(chain3, deik.CentreOfMass([0.0, 10.0, 0.0]))


def test_root_translation_extends_what_is_reachable():
    sk = build_skeleton(
        [Joint("base", None, (0, 0, 0), translation("X", -2.0, 2.0) + euler("Z")), Joint("arm", "base", (1.0, 0, 0))],
        sites=[Site("tip", "arm", (0.5, 0, 0))],
    )
    problem(sk, deik.Position("tip", [3.4, 0.0, 0.0]))
    with pytest.raises(ValueError, match=r"unreachable: it lies 1\.6 from the root's range .* only 1\.5 long"):
        problem(sk, deik.Position("tip", [3.6, 0.0, 0.0]))


def test_reachable_target_after_root_rotation_is_accepted():
    sk = build_skeleton(
        [
            Joint("base", None, (0, 0, 0), euler("Z") + translation("X", -1.0, 1.0)),
            Joint("arm", "base", (0.5, 0, 0), hinge((0, 0, 1))),
        ],
        sites=[Site("tip", "arm", (0.1, 0, 0))],
    )
    target = deik.forward_kinematics(sk, [math.pi / 2, 1.0, 0.0]).position("tip")  # (0, 1.6, 0)
    problem(sk, deik.Position("tip", target))


# --- shared goal settings ----------------------------------------------------------------------


@pytest.mark.parametrize("weight", [1.5, -1.01, math.nan])
def test_weight_outside_unit_interval(chain3, tip_target, weight):
    with pytest.raises(ValueError, match=r"position tip: weight .* must lie in \[-1, 1\]"):
        problem(chain3, deik.Position("tip", tip_target, weight=weight))


def test_weights_at_the_ends_are_allowed(chain3, tip_target):
    problem(chain3, deik.Position("tip", tip_target, weight=-1.0), deik.Comfort(weight=1.0))


@pytest.mark.parametrize("tolerance", [-0.1, math.inf, math.nan])
def test_bad_tolerance(chain3, tip_target, tolerance):
    with pytest.raises(ValueError, match=r"position tip: tolerance .* must be >= 0"):
        problem(chain3, deik.Position("tip", tip_target, tolerance=tolerance))


@pytest.mark.parametrize("mu", [0.0, -1.0, math.inf])
def test_bad_mu(chain3, tip_target, mu):
    with pytest.raises(ValueError, match=r"mu .* must be a positive finite number"):
        problem(chain3, deik.Position("tip", tip_target, mu=mu))


@pytest.mark.parametrize("level", [-1, 1.5, "0"])
def test_bad_level(chain3, tip_target, level):
    with pytest.raises(ValueError, match=r"position tip: level .* must be an integer >= 0"):
        problem(chain3, deik.Position("tip", tip_target, level=level))


def test_too_many_levels(chain3, tip_target):
    goals = [deik.Position("tip", tip_target, level=k) for k in range(5)]
    with pytest.raises(ValueError, match=r"at most 4 priority levels are supported, got \[0, 1, 2, 3, 4\]"):
        problem(chain3, *goals)


def test_sparse_levels_are_compacted(chain3, tip_target):
    p = problem(chain3, deik.Position("tip", tip_target, level=3), deik.Comfort(level=7))
    assert p.table.n_levels == 2
    assert p.table.term_int[:, 1].tolist() == [0, 1]


def test_unknown_joint_name_with_suggestion(chain3, tip_target):
    with pytest.raises(KeyError, match=r"joint or site 'tpi' not found in skeleton 'chain:3'; did you mean 'tip'"):
        problem(chain3, deik.Position("tpi", tip_target))
    with pytest.raises(KeyError, match=r"did you mean 'link1'"):
        problem(chain3, deik.Aim("lnk1", tip_target))
    with pytest.raises(KeyError, match=r"'left_hnd' not found.*did you mean 'left_hand'"):
        problem(deik.humanoid(), deik.Orientation("left_hnd", np.eye(3)))


# --- problems ----------------------------------------------------------------------------------


def test_mismatched_batch_sizes(chain3):
    rng = np.random.default_rng(1)
    q = rng.uniform(chain3.lower, chain3.upper, (5, 3))
    tips = deik.forward_kinematics(chain3, q).position("tip")
    links = deik.forward_kinematics(chain3, q).position("link2")
    with pytest.raises(ValueError, match=r"different batch sizes \[2, 3\]"):
        problem(chain3, deik.Position("tip", tips[:2]), deik.Position("link2", links[:3]))
    with pytest.raises(ValueError, match=r"different batch sizes \[2, 4\]"):
        problem(chain3, deik.Position("tip", tips[:2]), deik.Comfort(reference=q[:4]))
    # a batch of one or no batch axis broadcasts
    assert problem(chain3, deik.Position("tip", tips[:3]), deik.Position("link2", links[:1])).batch_size == 3


def test_no_goals(chain3):
    with pytest.raises(ValueError, match=r"a problem needs at least one goal"):
        deik.Problem(chain3, [])


def test_goals_must_be_goal_objects(chain3, tip_target):
    with pytest.raises(TypeError, match=r"goals must be deik goal objects, got tuple"):
        deik.Problem(chain3, [("tip", tip_target)])
    with pytest.raises(TypeError, match=r"skeleton must be a deik.Skeleton"):
        deik.Problem("chain", [deik.Comfort()])


def test_infinite_dof_limits_in_a_problem():
    sk = build_skeleton(
        [Joint("root", None, (0, 0, 0), translation("XYZ") + euler("Z")), Joint("a", "root", (1, 0, 0), mass=1.0)]
    )
    with pytest.raises(ValueError, match=r"DOF 'root.Xposition' has infinite limits; .*finite limits"):
        deik.Problem(sk, [deik.Comfort()])


@pytest.mark.parametrize("mode", ["bounce", "", None])
def test_unknown_limits_mode(chain3, mode):
    with pytest.raises(ValueError, match=r"limits must be one of \('reflect', 'clip', 'penalty', 'paper'\)"):
        deik.Problem(chain3, [deik.Comfort()], limits=mode)


def test_bad_comfort_mode_and_joint_weights(chain3):
    with pytest.raises(ValueError, match=r"comfort mode must be 'sum' or 'max', got 'mean'"):
        problem(chain3, deik.Comfort("mean"))
    with pytest.raises(ValueError, match=r"joint_weights string must be 'start' or 'end', got 'middle'"):
        problem(chain3, deik.Comfort(joint_weights="middle"))
    with pytest.raises(ValueError, match=r"joint_weights array must be \(3,\), finite and >= 0, got shape \(2,\)"):
        problem(chain3, deik.Comfort(joint_weights=[1.0, 2.0]))
    with pytest.raises(ValueError, match=r"joint_weights array must be \(3,\), finite and >= 0"):
        problem(chain3, deik.Comfort(joint_weights=[1.0, -2.0, 0.0]))
    with pytest.raises(ValueError, match=r"joint_weights array must be"):
        problem(chain3, deik.Comfort(joint_weights=[1.0, math.nan, 0.0]))
    with pytest.raises(KeyError, match=r"'lnk0' not found.*did you mean 'link0'"):
        problem(chain3, deik.Comfort(joint_weights={"lnk0": 1.0}))
    with pytest.raises(KeyError, match=r"'tip' is a site, not a joint"):
        problem(chain3, deik.Comfort(joint_weights={"tip": 1.0}))
    with pytest.raises(ValueError, match=r"comfort reference must have shape \(3,\)"):
        problem(chain3, deik.Comfort(reference=np.zeros(4)))


@pytest.mark.parametrize("value", [-1.0, math.nan])
def test_dict_joint_weights_are_validated(chain3, value):
    with pytest.raises(ValueError, match=r"joint_weights"):
        problem(chain3, deik.Comfort("max", joint_weights={"link0": value, "link1": value, "link2": value}))


@pytest.mark.parametrize("radius, bone", [(0.0, 0.0), (-0.5, 0.0), (0.5, -0.1), (math.nan, 0.0)])
def test_obstacle_radius(chain3, radius, bone):
    with pytest.raises(ValueError, match=r"obstacle radius must be > 0 and bone_radius >= 0"):
        problem(chain3, deik.Obstacle([1.0, 1.0, 0.0], radius, bone_radius=bone))


def test_com_goals_need_mass():
    sk = deik.chain(3, mass=0.0)
    with pytest.raises(ValueError, match=r"centre_of_mass needs masses, but skeleton 'chain:3' has none"):
        problem(sk, deik.CentreOfMass([1.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match=r"com_over_support needs masses"):
        problem(sk, deik.ComOverSupport([1.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match=r"com_in_polygon needs masses"):
        problem(sk, deik.ComInPolygon(("tip", "link1")))


def test_support_polygon_frame_count(chain3):
    with pytest.raises(ValueError, match=r"support polygon needs 1 to 8 frames, got 0"):
        problem(chain3, deik.ComInPolygon(()))
    with pytest.raises(ValueError, match=r"support polygon needs 1 to 8 frames, got 9"):
        problem(chain3, deik.ComInPolygon(("tip",) * 9))


# --- settings and solve() ----------------------------------------------------------------------


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"population": 3}, r"population must be an integer >= 4 \(DE needs 3 donors\), got 3"),
        ({"population": 64.0}, r"population must be an integer >= 4"),
        ({"CR": 1.5}, r"CR \(crossover probability\) must lie in \[0, 1\], got 1.5"),
        ({"CR": -0.1}, r"CR \(crossover probability\) must lie in \[0, 1\]"),
        ({"CR": math.nan}, r"CR must be a finite number \(the crossover probability"),
        ({"F": 0.0}, r"F \(differential weight\) must lie in \(0, 2\], got 0.0"),
        ({"F": -0.5}, r"F \(differential weight\)"),
        ({"F": math.nan}, r"F must be a finite number \(the differential weight"),
        (
            {"strategy": "rand/2/exp"},
            r"strategy must be one of \['rand/1/bin', 'best/1/bin', 'current-to-best/1/bin'\]",
        ),
        ({"device": "tpu"}, r"device must be one of \['cpu', 'gpu', 'auto'\], got 'tpu'"),
        ({"dtype": "float16"}, r"dtype must be one of \['float32', 'float64'\], got 'float16'"),
        ({"seed": -1}, r"seed must be an integer >= 0, got -1"),
        ({"seed": 2**64}, r"seed must be an integer in \[0, 2\*\*64\)"),
        ({"seed": 1.5}, r"seed must be an integer"),
        ({"generations": 0}, r"generations must be an integer >= 1"),
        ({"patience": 0}, r"patience must be an integer >= 1"),
    ],
)
def test_bad_settings(changes, message):
    with pytest.raises(ValueError, match=message):
        deik.Settings(**changes)


def test_bad_settings_through_solve_overrides(chain3, tip_target):
    p = problem(chain3, deik.Position("tip", tip_target))
    with pytest.raises(ValueError, match=r"population must be an integer >= 4"):
        deik.solve(p, population=2)
    with pytest.raises(ValueError, match=r"CR \(crossover probability\)"):
        deik.solve(p, deik.Settings(population=16), CR=2.0)


def test_unknown_solve_keyword(chain3, tip_target):
    p = problem(chain3, deik.Position("tip", tip_target))
    with pytest.raises(TypeError, match=r"unknown solve\(\) settings \['popsize'\]; choose from \[.*'population'"):
        deik.solve(p, popsize=10)


def test_solve_needs_a_problem(chain3):
    with pytest.raises(TypeError, match=r"solve\(\) takes a deik.Problem, got Skeleton"):
        deik.solve(chain3)


@pytest.mark.parametrize(
    "shape, message",
    [
        ((4,), r"initial poses must have shape \(\.\.\., 3\) for skeleton 'chain:3', got \(4,\)"),
        ((2, 5), r"initial poses must have shape \(\.\.\., 3\)"),
        ((17, 3), r"initial poses must be \(n, D\) or \(B, n, D\) with n <= population, got \(1, 17, 3\)"),
        ((2, 1, 3), r"initial poses must be \(n, D\) or \(B, n, D\)"),
    ],
)
def test_initial_poses_of_wrong_shape(chain3, tip_target, shape, message):
    p = problem(chain3, deik.Position("tip", tip_target))
    with pytest.raises(ValueError, match=message):
        deik.solve(p, initial=np.zeros(shape), population=16, generations=2)


def test_initial_poses_with_nan(chain3, tip_target):
    p = problem(chain3, deik.Position("tip", tip_target))
    with pytest.raises(ValueError, match=r"initial poses contain NaN or infinite values"):
        deik.solve(p, initial=np.array([0.0, math.nan, 0.0]), population=16, generations=2)


def test_initial_poses_with_too_many_axes(chain3, tip_target):
    p = problem(chain3, deik.Position("tip", tip_target))
    with pytest.raises(ValueError, match=r"initial poses"):
        deik.solve(p, initial=np.zeros((1, 1, 2, 3)), population=16, generations=2)

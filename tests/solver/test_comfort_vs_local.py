"""Single poses with comfort on the lowest level stay at least as close to the reference as a
local least-squares solver started at the reference (issue 17 item 6), with the same goals met;
and the polish's null-space pull towards the reference leaves the goals' errors where they were.

Each problem is a standing `deik.humanoid()`: both feet planted where the reference pose has them
(heel and toe tip, level 0), both hands at targets made by forward kinematics of a random pose
that keeps the legs and pelvis of the reference and turns the spine, neck and arms (level 1), and
`Comfort` towards the reference on the lowest level (2). The local solver is what a Jacobian user
would run: scipy's bounded trust-region least squares (the Levenberg-Marquardt family) from the
reference pose on the same position goals, which ends near the start because each step is a
damped minimum-norm one. The deviation from the reference is the Comfort measure itself (Eq. 6:
sum over DOFs of |angle - reference|, radians, pelvis translation in metres)."""

import numpy as np
import pytest
from scipy.optimize import least_squares

import deik
from deik.solver.seeding import poses_around

FEET = ("left_heel", "left_toe_tip", "right_heel", "right_toe_tip")
HANDS = ("left_hand", "right_hand")
TOLERANCE = 0.005  # metres, every position goal
MOVED = ("spine", "chest", "neck", "head", "clavicle", "shoulder", "arm", "elbow", "forearm", "wrist", "hand")


def moving_dofs(skeleton) -> np.ndarray:
    """(D,) bool: the DOFs the random poses turn (spine, neck, arms), not the pelvis or legs."""
    return np.array([any(k in name.split(".")[0] for k in MOVED) for name in skeleton.dof_names])


def make_targets(count: int, seed: int) -> dict:
    """Feet at the reference, hands at FK of `count` random poses (spread 0.4 rad on the upper
    body around the reference, folded into the limits): {name: (count, 3)} and the poses."""
    human = deik.humanoid()
    poses = poses_around(human, human.reference, count + 1, spread=0.4, seed=seed)[1:]
    poses[:, ~moving_dofs(human)] = human.reference[~moving_dofs(human)]
    rest = deik.forward_kinematics(human, human.reference)
    targets = {name: np.repeat(rest.position(name)[None], count, axis=0) for name in FEET}
    for name in HANDS:
        targets[name] = np.stack([deik.forward_kinematics(human, q).position(name) for q in poses])
    return {"skeleton": human, "targets": targets, "poses": poses}


def deik_problem(case: dict) -> deik.Problem:
    """Feet on level 0, hands on level 1, Comfort towards the reference on level 2."""
    goals = [deik.Position(n, case["targets"][n], tolerance=TOLERANCE) for n in FEET]
    goals += [deik.Position(n, case["targets"][n], tolerance=TOLERANCE, level=1) for n in HANDS]
    return deik.Problem(case["skeleton"], goals + [deik.Comfort(level=2)])


def position_errors(skeleton, q: np.ndarray, targets: dict, b: int) -> np.ndarray:
    """(goals,) distances (m) of every foot and hand point of pose q from problem b's targets."""
    kin = deik.forward_kinematics(skeleton, q)
    return np.array([np.linalg.norm(kin.position(n) - targets[n][b]) for n in FEET + HANDS])


def local_solve(skeleton, targets: dict, b: int) -> np.ndarray:
    """Problem b by bounded trust-region least squares from the reference pose: (D,) radians."""

    def residuals(q):
        kin = deik.forward_kinematics(skeleton, q)
        return np.concatenate([(kin.position(n) - targets[n][b]) / TOLERANCE for n in FEET + HANDS])

    fit = least_squares(residuals, skeleton.reference, bounds=(skeleton.lower, skeleton.upper), xtol=1e-12)
    return fit.x


def deviations(skeleton, poses: np.ndarray) -> dict:
    """Comfort sum (Eq. 6) and Euclidean distance of (B, D) poses from the reference."""
    delta = poses - skeleton.reference
    return {"comfort_sum": np.abs(delta).sum(axis=-1), "euclidean": np.linalg.norm(delta, axis=-1)}


def compare(count: int, seed: int, settings: dict) -> dict:
    """Solve `count` problems both ways; per problem: goals met and deviations, both solvers."""
    case = make_targets(count, seed)
    human, targets = case["skeleton"], case["targets"]
    result = deik.solve(deik_problem(case), seed=seed, **settings)
    local = np.stack([local_solve(human, targets, b) for b in range(count)])
    rows = {}
    for name, poses in (("deik", np.asarray(result.angles, np.float64)), ("local", local)):
        errors = np.stack([position_errors(human, poses[b], targets, b) for b in range(count)])
        rows[name] = {
            "met": (errors <= TOLERANCE * (1 + 1e-6)).all(axis=1).tolist(),
            "max_error_m": errors.max(axis=1).tolist(),
            **{k: v.tolist() for k, v in deviations(human, poses).items()},
        }
    rows["truth"] = {k: v.tolist() for k, v in deviations(human, case["poses"]).items()}
    return rows


@pytest.mark.slow  # scipy's least squares with finite differences: about 50 s on 2 cores
def test_deik_deviates_no_more_than_a_local_solver_from_the_reference():
    rows = compare(8, seed=3, settings={"dtype": "float64"})
    assert all(rows["deik"]["met"]) and all(rows["local"]["met"])
    deik_sum, local_sum = np.array(rows["deik"]["comfort_sum"]), np.array(rows["local"]["comfort_sum"])
    assert np.all(deik_sum <= local_sum * 1.001), (deik_sum, local_sum)
    # and no further than the random pose that made the targets, which meets every goal too
    assert np.all(deik_sum <= np.array(rows["truth"]["comfort_sum"]))


def test_the_comfort_pull_keeps_the_goals_met_and_moves_towards_the_reference():
    case = make_targets(4, seed=5)
    human = case["skeleton"]
    # no DE at all: the polish alone, started on the random pose that meets every goal exactly
    start = np.repeat(case["poses"][:, None], 4, axis=1)
    result = deik.solve(
        deik_problem(case), initial=start, population=4, generations=1, polish_count=1, polish=20, dtype="float64"
    )
    moved = np.abs(result.angles - human.reference).sum(axis=-1)
    before = np.abs(case["poses"] - human.reference).sum(axis=-1)
    # never further, and most of the way on average (a local method: a limit can stop it early)
    assert np.all(moved < before) and moved.mean() < 0.6 * before.mean(), (moved, before)
    for goal in result.goals:
        if goal.label.startswith("position"):
            assert np.all(goal.error <= TOLERANCE)

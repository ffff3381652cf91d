"""The LM polish on the robot arm built in code (helpers.robot_arm: rest rotations, a prismatic
and a mimic DOF, a rotated tool frame), so that a clone without the real robots checks it too:
targets with joints at their limits are met and no individual ever leaves the limits (float32 and
float64), and from near a solution one generation with the polish meets a tool pose to a
micrometre. tests/solver/test_polish.py runs the same checks on the Panda URDF."""

import numpy as np
import pytest

import deik
from helpers import random_poses, robot_arm


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_polish_never_leaves_the_joint_limits(dtype):
    sk = robot_arm()
    truth = random_poses(sk, 12, 5)
    truth[:, ::2] = np.where(truth[:, ::2] > 0, sk.upper[::2], sk.lower[::2])  # targets with joints at a limit
    target = deik.forward_kinematics(sk, truth).position("tool")
    problem = deik.Problem(sk, [deik.Position("tool", target, tolerance=1e-4)])
    engine = deik.Engine(problem, deik.Settings(population=16, dtype=dtype, seed=2, polish_count=16, polish_every=1))
    state = engine.run(engine.init(), 30)
    assert (state.pop >= sk.lower.astype(dtype)).all() and (state.pop <= sk.upper.astype(dtype)).all()
    assert state.converged.mean() > 0.9


def test_polish_converges_to_a_micrometre_from_near_a_solution():
    sk = robot_arm()
    truth = random_poses(sk, 8, 3)
    near = np.clip(truth + np.random.default_rng(4).normal(0, 0.05, truth.shape), sk.lower, sk.upper)
    kin = deik.forward_kinematics(sk, truth)
    for n, start in enumerate(near):
        problem = deik.Problem(
            sk,
            [
                deik.Position("tool", kin.position("tool")[n], tolerance=1e-6),
                deik.Orientation("tool", kin.rotation("tool")[n], tolerance=1e-5),
            ],
        )
        polished = deik.solve(problem, initial=start[None], population=8, generations=1, dtype="float64", seed=1)
        assert polished.converged, [float(g.error) for g in polished.goals]
        assert polished.goals[0].error < 1e-6 and polished.goals[1].error < 1e-5
        unpolished = deik.solve(
            problem, initial=start[None], population=8, generations=1, dtype="float64", seed=1, polish=0
        )
        assert unpolished.goals[0].error > 1e-4  # one DE generation alone does not get there

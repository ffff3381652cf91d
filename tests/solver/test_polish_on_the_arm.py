"""The LM polish on the robot arm built in code (helpers.robot_arm: rest rotations, a prismatic
and a mimic DOF, a rotated tool frame), so that a clone without the real robots checks it too:
targets with joints at their limits are met and no individual ever leaves the limits, in float32
and float64. tests/solver/test_polish.py runs the same check on the Panda URDF."""

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

"""poses_around: the given pose first, perturbed copies inside the limits, batches of poses."""

import numpy as np
import pytest

import deik
from deik.model.joints import ROTATE
from deik.solver.seeding import poses_around


def test_first_row_is_the_pose_and_every_copy_stays_in_limits():
    sk = deik.humanoid()
    pose = np.random.default_rng(0).uniform(sk.lower, sk.upper)
    out = poses_around(sk, pose, 64, spread=0.5, seed=1)
    assert out.shape == (64, sk.n_dofs)
    np.testing.assert_array_equal(out[0], pose)
    assert np.all(out >= sk.lower) and np.all(out <= sk.upper)
    assert np.abs(out[1:] - pose).max() > 0.1  # really perturbed


def test_batch_of_poses_with_one_spread_per_copy():
    sk = deik.chain(5)
    poses = np.random.default_rng(2).uniform(sk.lower, sk.upper, (3, sk.n_dofs))
    spreads = np.array([1e-4, 1e-4, 1.0])
    out = poses_around(sk, poses, 4, spreads, seed=3)
    assert out.shape == (3, 4, sk.n_dofs)
    np.testing.assert_array_equal(out[:, 0], poses)
    fine = np.abs(out[:, 1:3] - poses[:, None]).max()
    assert fine < 1e-3 < np.abs(out[:, 3] - poses).max()


def test_pose_outside_limits_is_named():
    """A DOF whose limits span less than a turn (a continuous joint's wraps round:
    tests/solver/test_continuous_joints.py)."""
    sk = deik.humanoid()
    d = int(np.flatnonzero(sk.dof_kind == ROTATE)[0])
    pose = sk.reference.copy()
    pose[d] = sk.upper[d] + 0.1
    message = rf"seed pose DOF {sk.dof_names[d]!r} = .* rad \(.* degrees\) is outside its limits"
    with pytest.raises(ValueError, match=message):
        poses_around(sk, pose, 4)

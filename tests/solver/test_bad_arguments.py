"""Mistakes in Python calls get a ValueError naming the argument, never a NumPy error from deep
inside, a silent loss or a NaN result: an empty batch, complex targets or poses, a negative
generation count, a NaN or negative spread."""

import numpy as np
import pytest

import deik


def test_an_empty_batch_of_targets_is_refused_by_name():
    with pytest.raises(ValueError, match="tip target is a batch of 0: give at least one target"):
        deik.Problem(deik.chain(3), [deik.Position("tip", np.zeros((0, 3)))])


def test_complex_numbers_are_refused_not_cut_to_their_real_part():
    sk = deik.chain(3)
    with pytest.raises(ValueError, match="holds complex numbers"):
        deik.Problem(sk, [deik.Position("tip", [1 + 1j, 1, 0])])
    with pytest.raises(ValueError, match="holds complex numbers"):
        deik.Problem(sk, [deik.Orientation("tip", np.eye(3) * (1 + 0j))])
    with pytest.raises(ValueError, match="holds complex numbers"):
        deik.forward_kinematics(sk, np.zeros(3) + 0.5j)
    solver = deik.Solver(deik.Problem(sk, [deik.Position("tip", [1.0, 1.0, 0.0])]), population=8)
    with pytest.raises(ValueError, match="holds complex numbers"):
        solver.solve({"position tip": np.array([1 + 1j, 1, 0])})


def test_generation_counts_are_whole_numbers_at_least_zero():
    engine = deik.Engine(
        deik.Problem(deik.chain(3), [deik.Position("tip", [1.0, 1.0, 0.0])]), deik.Settings(population=8)
    )
    state = engine.init()
    for bad in (-5, 2.5, True, "3"):
        with pytest.raises(ValueError, match="n_generations must be"):
            engine.run(state, bad)
    assert engine.run(state, 0).generation == 0  # nothing to run: the same state back


def test_poses_around_refuses_a_nan_or_negative_spread_and_a_bad_count():
    sk = deik.chain(3)
    for spread in (float("nan"), -0.1, float("inf"), [0.1, 0.2]):
        with pytest.raises(ValueError, match="spread must be a finite number >= 0"):
            deik.poses_around(sk, np.zeros(3), 4, spread)
    for count in (0, 2.5, True):
        with pytest.raises(ValueError, match="count must be a whole number >= 1"):
            deik.poses_around(sk, np.zeros(3), count)
    poses = deik.poses_around(sk, np.zeros(3), 4, [0.0, 0.1, 0.2])
    assert np.isfinite(poses).all() and (poses[1] == 0).all()  # a zero spread copies the pose

"""Conventions end to end: a target given as a scalar-last quaternion or a 4x4 pose is solved
to the rotation scipy reads from it, the Solver swaps targets in the goal's own form, and the
result's JSON holds every frame's world position and quaternion (w first) from forward
kinematics."""

import json

import numpy as np
from scipy.spatial.transform import Rotation

import deik

SETTINGS = {"population": 32, "dtype": "float64", "seed": 0}


def _target(sk, seed):
    """The tip's world pose (4, 4) in a random in-limit pose."""
    kin = deik.forward_kinematics(sk, np.random.default_rng(seed).uniform(sk.lower, sk.upper))
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = kin.rotation("tip"), kin.position("tip")
    return T


def _pose_error(sk, angles, T):
    kin = deik.forward_kinematics(sk, angles)
    turn = Rotation.from_matrix(kin.rotation("tip").T @ T[:3, :3]).magnitude()
    return np.linalg.norm(kin.position("tip") - T[:3, 3]), np.degrees(turn)


def test_quaternion_and_pose_targets_solve_and_the_solver_keeps_the_form():
    sk = deik.chain(4, dims=3)
    first, second = _target(sk, 1), _target(sk, 2)
    xyzw = Rotation.from_matrix(first[:3, :3]).as_quat()  # scipy: scalar last
    goals = [deik.Position("tip", first[:3, 3]), deik.Orientation("tip", xyzw, "quat-xyzw")]
    result = deik.solve(deik.Problem(sk, goals), **SETTINGS)
    assert bool(result.converged)
    distance, degrees = _pose_error(sk, result.angles, first)
    assert distance <= 1e-3 and degrees <= 0.1  # the default tolerances: 0.001 length units, 0.1 degree
    ik = deik.Solver(deik.Problem(sk, goals), **SETTINGS)
    swapped = ik.solve(
        {"position tip": second[:3, 3], "orientation tip": Rotation.from_matrix(second[:3, :3]).as_quat()}
    )
    distance, degrees = _pose_error(sk, swapped.angles, second)
    assert bool(swapped.converged) and distance <= 1e-3 and degrees <= 0.1
    posed = deik.solve(deik.Problem(sk, list(deik.pose_goals("tip", second))), **SETTINGS)
    distance, degrees = _pose_error(sk, posed.angles, second)
    assert bool(posed.converged) and distance <= 1e-3 and degrees <= 0.1


def test_result_json_holds_every_frame_s_world_pose():
    sk = deik.chain(3, dims=3)
    T = _target(sk, 3)
    result = deik.solve(deik.Problem(sk, [deik.Position("tip", T[:3, 3])]), **SETTINGS)
    data = json.loads(json.dumps(result.to_dict()))
    kin = deik.forward_kinematics(sk, result.angles)
    assert list(data["sites"]) == list(sk.site_names) and list(data["joints"]) == list(sk.joint_names)
    assert data["dof_units"] == ["rad"] * sk.n_dofs
    for name in sk.frame_names:
        frame = data["sites"].get(name) or data["joints"][name]
        np.testing.assert_allclose(frame["position"], kin.position(name), atol=1e-12)
        w, x, y, z = frame["quaternion_wxyz"]
        assert w >= 0
        np.testing.assert_allclose(Rotation.from_quat([x, y, z, w]).as_matrix(), kin.rotation(name), atol=1e-12)

"""Every orientation form against scipy's Rotation as the oracle, and the errors for forms,
shapes, non-unit quaternions and broken poses."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from deik.model.orientations import (
    FORMS,
    QUATERNION_TOLERANCE,
    matrix_quaternion,
    quaternion_matrix,
    rotation_from,
    rpy_matrix,
)

ROTATIONS = Rotation.random(64, random_state=5)


def test_each_form_gives_scipys_rotation():
    R = ROTATIONS.as_matrix()
    xyzw = ROTATIONS.as_quat()  # scipy: scalar last
    wxyz = xyzw[:, [3, 0, 1, 2]]
    T = np.tile(np.eye(4), (64, 1, 1))
    T[:, :3, :3], T[:, :3, 3] = R, np.random.default_rng(1).normal(size=(64, 3))
    values = {
        "matrix": R,
        "quat-wxyz": wxyz,
        "quat-xyzw": xyzw,
        "rpy": ROTATIONS.as_euler("xyz"),  # scipy lower case: fixed axes, R = Rz Ry Rx
        "xyz": ROTATIONS.as_euler("XYZ"),  # scipy upper case: intrinsic, R = Rx Ry Rz
    }
    assert set(values) == set(FORMS)
    for form, value in values.items():
        np.testing.assert_allclose(rotation_from(form, value, "t"), R, atol=1e-12, err_msg=form)
    np.testing.assert_allclose(rotation_from("matrix", T, "t"), R, atol=1e-12)  # a 4x4 pose: its rotation
    np.testing.assert_allclose(rpy_matrix(values["rpy"][0]), R[0], atol=1e-12)  # unbatched too


def test_rpy_is_urdfs_fixed_axes_x_then_y_then_z():
    roll, pitch, yaw = 0.3, -0.7, 1.9
    Rx = Rotation.from_rotvec([roll, 0, 0]).as_matrix()
    Ry = Rotation.from_rotvec([0, pitch, 0]).as_matrix()
    Rz = Rotation.from_rotvec([0, 0, yaw]).as_matrix()
    np.testing.assert_allclose(rpy_matrix([roll, pitch, yaw]), Rz @ Ry @ Rx, atol=1e-12)


def test_matrix_to_quaternion_round_trips_in_both_orders_with_w_non_negative():
    R = ROTATIONS.as_matrix()
    # the hard cases for a trace-only formula: half turns about each axis and near them
    half = Rotation.from_rotvec(np.pi * np.eye(3)).as_matrix()
    R = np.concatenate([R, half, Rotation.from_rotvec(3.14159 * np.ones((1, 3)) / np.sqrt(3)).as_matrix()])
    wxyz = matrix_quaternion(R, "wxyz")
    xyzw = matrix_quaternion(R, "xyzw")
    np.testing.assert_allclose(np.linalg.norm(wxyz, axis=-1), 1.0, atol=1e-12)
    assert (wxyz[:, 0] >= 0).all()
    np.testing.assert_array_equal(xyzw, wxyz[:, [1, 2, 3, 0]])
    expected = Rotation.from_matrix(R).as_quat()  # xyzw, up to sign
    np.testing.assert_allclose(np.abs(np.sum(xyzw * expected, axis=-1)), 1.0, atol=1e-12)
    np.testing.assert_allclose(quaternion_matrix(wxyz, "wxyz"), R, atol=1e-12)


def test_quaternions_must_be_unit_length_within_rounding():
    q = np.array([0.7071, 0.0, 0.0, 0.7071])  # typed to 4 decimals: accepted, then normalised
    np.testing.assert_allclose(np.linalg.det(quaternion_matrix(q, "wxyz")), 1.0, atol=1e-12)
    off = np.array([1.0 + 2 * QUATERNION_TOLERANCE, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"goal q has length 1.002, not 1 .*unit quaternion"):
        quaternion_matrix(off, "wxyz", "goal q")
    with pytest.raises(ValueError, match=r"length 0"):
        rotation_from("quat-xyzw", np.zeros(4), "q")


def test_orders_and_forms_are_named_never_guessed():
    with pytest.raises(ValueError, match=r"quaternion order 'wxzy' is not one of wxyz, xyzw"):
        quaternion_matrix([1, 0, 0, 0], "wxzy")
    with pytest.raises(ValueError, match=r"t: orientation form 'quat' is not one of matrix, quat-wxyz"):
        rotation_from("quat", [1, 0, 0, 0], "t")
    with pytest.raises(ValueError, match=r"in form 'rpy' must have shape \(3,\)"):
        rotation_from("rpy", [1, 0, 0, 0], "t")
    with pytest.raises(ValueError, match=r"NaN"):
        rotation_from("xyz", [np.nan, 0, 0], "t")


def test_broken_matrices_and_poses_are_refused():
    with pytest.raises(ValueError, match=r"t is not a rotation matrix"):
        rotation_from("matrix", np.diag([1.0, 1.0, -1.0]), "t")
    T = np.eye(4)
    T[3, 0] = 0.5
    with pytest.raises(ValueError, match=r"last row is not 0 0 0 1"):
        rotation_from("matrix", T, "t")

"""Orientations in every form deik accepts, to rotation matrices and back (docs/conventions.md).

A form is always named, never guessed from the values (FORMS; one value's shape in brackets):
- "matrix": a 3x3 rotation matrix (3, 3), or a 4x4 homogeneous pose (4, 4) whose rotation
  part is used (its last row must be 0 0 0 1);
- "quat-wxyz" / "quat-xyzw": a unit quaternion (4,), scalar first / scalar last; its length
  must be 1 within QUATERNION_TOLERANCE (rounding), it is then normalised;
- "rpy": URDF roll, pitch, yaw (3,) radians about the fixed axes X, then Y, then Z:
  R = Rz(yaw) Ry(pitch) Rx(roll);
- "xyz": intrinsic Euler angles (3,) radians about X, then the new Y, then the new Z:
  R = Rx(a) Ry(b) Rz(c).
Every function takes any leading batch shape; matrices act on column vectors.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.model.rotations import euler_matrix
from deik.model.values import real_array

FORMS = {"matrix": 2, "quat-wxyz": 1, "quat-xyzw": 1, "rpy": 1, "xyz": 1}  # form -> ndim of one value
QUATERNION_ORDERS = ("wxyz", "xyzw")
QUATERNION_TOLERANCE = 1e-3  # |length - 1| a quaternion may be off by (values typed to 3 decimals)
ROTATION_TOLERANCE = 1e-5  # R R^T = I within this (2x on the diagonal, as np.allclose)
POSE_TOLERANCE = 1e-9  # a 4x4 pose's last row is 0 0 0 1 within this
QUICK_MARGIN = 1 - 1e-9  # the plain-Python quick checks pass only values this far inside a bound
_EYE = np.eye(3)
_ORTHONORMAL_BOUND = ROTATION_TOLERANCE * (1 + _EYE)  # R R^T - I, entry by entry


def rpy_matrix(rpy: ArrayLike) -> np.ndarray:
    """URDF roll, pitch, yaw (..., 3) radians -> Rz(yaw) Ry(pitch) Rx(roll) (..., 3, 3)."""
    return euler_matrix("ZYX", np.asarray(rpy, float)[..., ::-1])


def check_rotation(R: np.ndarray, what: str) -> np.ndarray:
    """`R` (..., 3, 3) unchanged when every matrix is a proper rotation (R R^T = I within
    ROTATION_TOLERANCE, determinant > 0); a ValueError naming `what` otherwise."""
    if R.shape == (3, 3) and passes_rotation_check(R.tolist()):  # one matrix: 1 us in plain Python, 9 in numpy
        return R
    off = np.abs(R @ np.swapaxes(R, -1, -2) - _EYE) > _ORTHONORMAL_BOUND
    if off.any() or (np.linalg.det(R) <= 0).any():
        raise InputError(
            f"{what} is not a rotation matrix (rows must be orthonormal within {ROTATION_TOLERANCE:g}, "
            "determinant +1); give a proper rotation"
        )
    return R


def passes_rotation_check(rows: list[list[float]]) -> bool:
    """Whether one 3x3 matrix, as nested lists of floats, passes check_rotation, worked out in
    plain Python (about 1 us; numpy's 10 us is per call, not per matrix) with QUICK_MARGIN of
    each bound to spare, so that rounding cannot pass what check_rotation refuses. NaN or
    infinite entries fail (every entry is squared in a diagonal sum). A False decides nothing:
    check_rotation then gives the verdict and its message."""
    (a, b, c), (d, e, f), (g, h, i) = rows
    diagonal, off = 2 * ROTATION_TOLERANCE * QUICK_MARGIN, ROTATION_TOLERANCE * QUICK_MARGIN
    return (
        abs(a * a + b * b + c * c - 1) <= diagonal
        and abs(d * d + e * e + f * f - 1) <= diagonal
        and abs(g * g + h * h + i * i - 1) <= diagonal
        and abs(a * d + b * e + c * f) <= off
        and abs(a * g + b * h + c * i) <= off
        and abs(d * g + e * h + f * i) <= off
        and a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) > 0  # the determinant
    )


def pose_rotation(T: np.ndarray, what: str) -> np.ndarray:
    """The rotation part (..., 3, 3) of homogeneous poses `T` (..., 4, 4), checked."""
    last = np.abs(T[..., 3, :] - [0.0, 0.0, 0.0, 1.0])
    if (last > POSE_TOLERANCE).any():
        raise InputError(f"{what} is a 4x4 pose whose last row is not 0 0 0 1; give a homogeneous transform")
    return check_rotation(T[..., :3, :3], what)


def _quaternion_order(order: str) -> str:
    if order not in QUATERNION_ORDERS:
        raise InputError(f"quaternion order {order!r} is not one of {', '.join(QUATERNION_ORDERS)}; name it")
    return order


def quaternion_matrix(q: ArrayLike, order: str, what: str = "quaternion") -> np.ndarray:
    """Unit quaternions (..., 4) in component `order` ("wxyz" or "xyzw") -> rotations (..., 3, 3).
    A ValueError naming `what` when a length is off 1 by more than QUATERNION_TOLERANCE."""
    q = np.asarray(q, dtype=np.float64)
    if _quaternion_order(order) == "xyzw":
        q = q[..., [3, 0, 1, 2]]
    length = np.linalg.norm(q, axis=-1)
    if (np.abs(length - 1.0) > QUATERNION_TOLERANCE).any():
        worst = float(length.flat[np.argmax(np.abs(length - 1.0))])
        raise InputError(
            f"{what} has length {worst:.6g}, not 1 (within {QUATERNION_TOLERANCE:g}); give a unit "
            "quaternion (deik does not normalise beyond rounding)"
        )
    w, x, y, z = np.moveaxis(q / length[..., None], -1, 0)
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def matrix_quaternion(R: ArrayLike, order: str = "wxyz") -> np.ndarray:
    """Rotations (..., 3, 3) -> unit quaternions (..., 4) in `order`, with w >= 0 (Shepperd's
    method: the largest of w, x, y, z is computed from the trace, the others from it)."""
    R = np.asarray(R, dtype=np.float64)
    trace = np.trace(R, axis1=-2, axis2=-1)
    diagonal = np.diagonal(R, axis1=-2, axis2=-1)
    # 4 candidates, each accurate where its component is the largest: rows w, x, y, z
    skew = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    pair = np.stack([R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1]], -1)
    big = np.stack([1 + trace, *(1 + 2 * diagonal[..., k] - trace for k in range(3))], -1)
    s = np.sqrt(np.maximum(big, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):  # only the chosen candidate is used
        candidates = [
            np.stack([s[..., 0], skew[..., 0] / s[..., 0], skew[..., 1] / s[..., 0], skew[..., 2] / s[..., 0]], -1),
            np.stack([skew[..., 0] / s[..., 1], s[..., 1], pair[..., 0] / s[..., 1], pair[..., 1] / s[..., 1]], -1),
            np.stack([skew[..., 1] / s[..., 2], pair[..., 0] / s[..., 2], s[..., 2], pair[..., 2] / s[..., 2]], -1),
            np.stack([skew[..., 2] / s[..., 3], pair[..., 1] / s[..., 3], pair[..., 2] / s[..., 3], s[..., 3]], -1),
        ]
    best = np.argmax(big, axis=-1)[..., None, None]
    q = np.take_along_axis(np.stack(candidates, -2), best, axis=-2)[..., 0, :] * 0.5
    q = q * np.where(q[..., :1] < 0, -1.0, 1.0)
    return q if _quaternion_order(order) == "wxyz" else q[..., [1, 2, 3, 0]]


def rotation_from(form: str, value: ArrayLike, what: str) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from `value` in orientation `form` (see FORMS; angles in
    radians); a ValueError naming `what` for an unknown form, a wrong shape, NaN, a matrix that
    is not a rotation or a quaternion that is not unit length."""
    if form not in FORMS:
        raise InputError(f"{what}: orientation form {form!r} is not one of {', '.join(FORMS)}")
    a = real_array(value, what)
    shapes = {"matrix": ((3, 3), (4, 4)), "rpy": ((3,),), "xyz": ((3,),)}.get(form, ((4,),))
    ndim = FORMS[form]
    if a.ndim < ndim or a.shape[a.ndim - ndim :] not in shapes:
        wanted = " or ".join(str(s) for s in shapes)
        raise InputError(f"{what} in form {form!r} must have shape {wanted} (or a batch of them), got {a.shape}")
    if not np.isfinite(a).all():
        raise InputError(f"{what} contains NaN or infinite values")
    if form == "matrix":
        return pose_rotation(a, what) if a.shape[-1] == 4 else check_rotation(a, what)
    if form == "rpy":
        return rpy_matrix(a)
    if form == "xyz":
        return euler_matrix("XYZ", a)
    return quaternion_matrix(a, form.removeprefix("quat-"), what)

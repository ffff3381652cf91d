"""Rotation helpers in NumPy: axis-angle matrices, Euler orders, angles between rotations.

Conventions: angles in radians; rotation matrices act on column vectors; an Euler order such as
"ZXY" is intrinsic, R = Rz(a) @ Rx(b) @ Ry(c), the convention BVH files use. All functions
accept any leading batch shape.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError

AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


def wrap_rotations(values: ArrayLike, rotation: np.ndarray) -> np.ndarray:
    """A copy of `values` (..., D) with the DOFs where `rotation` (D,) is True wrapped into
    [-pi, pi) radians (the same rotations); the others unchanged."""
    out = np.array(values, dtype=np.float64)
    out[..., rotation] = (out[..., rotation] + np.pi) % (2 * np.pi) - np.pi
    return out


def axis_angle_matrix(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation matrices about unit `axis` (3,) or (*batch, 3) by `angle` (*batch,) radians
    (the two broadcast against each other) -> (*batch, 3, 3)."""
    axis = np.asarray(axis, dtype=np.float64)
    angle = np.asarray(angle, dtype=np.float64)
    x, y, z = axis[..., 0], axis[..., 1], axis[..., 2]
    c, s = np.cos(angle), np.sin(angle)
    t = 1.0 - c
    out = np.empty(np.broadcast_shapes(axis.shape[:-1], angle.shape) + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2] = t * x * x + c, t * x * y - s * z, t * x * z + s * y
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2] = t * x * y + s * z, t * y * y + c, t * y * z - s * x
    out[..., 2, 0], out[..., 2, 1], out[..., 2, 2] = t * x * z - s * y, t * y * z + s * x, t * z * z + c
    return out


def upright(up: np.ndarray) -> np.ndarray:
    """(3, 3) the shortest turn taking the unit direction `up` to +Y (a half turn about X when
    `up` is -Y; the identity when it is +Y)."""
    up = np.asarray(up, dtype=np.float64)
    axis = np.cross(up, [0.0, 1.0, 0.0])
    length = np.linalg.norm(axis)
    angle = np.arctan2(length, up[1])
    if length < 1e-12:
        return np.eye(3) if up[1] > 0 else axis_angle_matrix(np.array([1.0, 0.0, 0.0]), np.pi)
    return axis_angle_matrix(axis / length, angle)


def euler_matrix(order: str, angles: np.ndarray) -> np.ndarray:
    """Intrinsic Euler rotation: `order` like "ZXY", `angles` (*batch, len(order)) -> (*batch, 3, 3)."""
    angles = np.asarray(angles, dtype=np.float64)
    if angles.shape[-1] != len(order):
        raise InputError(f"euler order {order!r} needs {len(order)} angles, got {angles.shape[-1]}")
    R = np.broadcast_to(np.eye(3), angles.shape[:-1] + (3, 3))
    for k, letter in enumerate(order.upper()):
        R = R @ axis_angle_matrix(np.array(AXES[letter]), angles[..., k])
    return R


def rotation_angle(R_a: np.ndarray, R_b: np.ndarray) -> np.ndarray:
    """Angle (radians, in [0, pi]) of the rotation R_a^T R_b; (*batch, 3, 3) each -> (*batch,).

    Uses atan2 of the skew and trace parts, which stays accurate near 0 where acos does not.
    """
    R = np.swapaxes(R_a, -1, -2) @ R_b
    skew = np.stack(
        [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]],
        axis=-1,
    )
    sin_part = 0.5 * np.linalg.norm(skew, axis=-1)
    cos_part = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(sin_part, cos_part)


def direction_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (radians) between vectors a and b, (*batch, 3) each -> (*batch,)."""
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.arctan2(cross, np.sum(a * b, axis=-1))


def euler_angles(order: str, R: np.ndarray) -> np.ndarray:
    """Intrinsic Euler angles (*batch, 3) radians of rotations R (*batch, 3, 3) for a Tait-Bryan
    `order` of three different axes such as "ZXY", the inverse of euler_matrix: the middle angle
    in [-pi/2, pi/2], the others in (-pi, pi]."""
    order = order.upper()
    if len(order) != 3 or set(order) - set(AXES) or len(set(order)) != 3:
        raise InputError(f"euler order {order!r} must be three different letters of X, Y and Z")
    i, j, k = ("XYZ".index(c) for c in order)
    sign = 1.0 if (j - i) % 3 == 1 else -1.0  # cyclic orders (XYZ, YZX, ZXY) and the others
    R = np.asarray(R, dtype=np.float64)
    middle = np.arcsin(np.clip(sign * R[..., i, k], -1.0, 1.0))
    first = np.arctan2(-sign * R[..., j, k], R[..., k, k])
    last = np.arctan2(-sign * R[..., i, j], R[..., i, i])
    return np.stack([first, middle, last], axis=-1)

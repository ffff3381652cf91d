"""Device maths, part 1: counter-based random numbers, 3x3 algebra, forward kinematics, COM.

The device_*.py files are written once and compiled for the CPU (numba.njit) and the GPU
(numba-cuda): `deik.kernels.targets` execs them all into one namespace per target, dropping
their imports of each other, so their functions call each other on the same target (they are
not meant to be called as plain Python). Nothing here may allocate; callers pass scratch
arrays. Matrices are flat, row-major, 9 floats per frame. The data they read (skel, terms,
scratch, ...) are the NamedTuples of deik.kernels.layout.
"""

import math

import numpy as np

from deik.kernels.layout import (
    AXIS,
    COORDINATE_AXIS,
    MASS_FRACTION,
    MASS_OFFSET,
    MOTION_BIAS,
    MOTION_END,
    MOTION_KIND,
    MOTION_SCALE,
    MOTION_START,
    OFFSET,
    PARENT,
    PLAIN_ROTATION,
    ROTATE_MOTION,
    ROTATION,
    SOURCE,
)

_K1 = np.uint64(0x9E3779B97F4A7C15)
_K2 = np.uint64(0xBF58476D1CE4E5B9)
_K3 = np.uint64(0x94D049BB133111EB)
_K4 = np.uint64(0xD6E8FEB86659FD93)
_S30, _S27, _S31, _S33, _S40 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(33), np.uint64(40)
_INV24 = 1.0 / 16777216.0


def mix64(z):
    """splitmix64 finaliser: a bijective 64-bit hash."""
    z = (z ^ (z >> _S30)) * _K2
    z = (z ^ (z >> _S27)) * _K3
    return z ^ (z >> _S31)


def random_bits(seed, problem, generation, individual, draw):
    """64 random bits from the counter (seed, problem, generation, individual, draw)."""
    z = mix64(np.uint64(seed) + _K1 * np.uint64(problem + 1))
    z = mix64(z ^ (_K4 * np.uint64(generation + 2)))
    return mix64(z ^ (_K1 * np.uint64(individual + 1) + np.uint64(draw)))


def uniform(seed, problem, generation, individual, draw):
    """A float64 in [0, 1) with 24 random bits (exact in float32 too)."""
    return float(random_bits(seed, problem, generation, individual, draw) >> _S40) * _INV24


def randint(n, seed, problem, generation, individual, draw):
    """An integer in [0, n)."""
    return np.int64((random_bits(seed, problem, generation, individual, draw) >> _S33) % np.uint64(n))


def matmul3(A, a, B, b, C, c):
    """C[c:c+9] = A[a:a+9] @ B[b:b+9] for flat row-major 3x3 matrices (C must not alias)."""
    for r in range(3):
        for k in range(3):
            row = a + 3 * r
            C[c + 3 * r + k] = A[row] * B[b + k] + A[row + 1] * B[b + 3 + k] + A[row + 2] * B[b + 6 + k]


def rotate_point(A, a, x, y, z):
    """A[a:a+9] @ (x, y, z)."""
    return (
        A[a] * x + A[a + 1] * y + A[a + 2] * z,
        A[a + 3] * x + A[a + 4] * y + A[a + 5] * z,
        A[a + 6] * x + A[a + 7] * y + A[a + 8] * z,
    )


def axis_angle_into(ax, ay, az, angle, M, m):
    """M[m:m+9] = rotation about unit axis (ax, ay, az) by `angle` radians (Rodrigues)."""
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    M[m], M[m + 1], M[m + 2] = t * ax * ax + c, t * ax * ay - s * az, t * ax * az + s * ay
    M[m + 3], M[m + 4], M[m + 5] = t * ax * ay + s * az, t * ay * ay + c, t * ay * az - s * ax
    M[m + 6], M[m + 7], M[m + 8] = t * ax * az - s * ay, t * ay * az + s * ax, t * az * az + c


def turn_columns(R, r, i, angle):
    """R[r:r+9] = R[r:r+9] @ (rotation about coordinate axis i by `angle` radians), in place:
    only the two other columns mix (12 flops instead of Rodrigues and a 3x3 product)."""
    c, s = math.cos(angle), math.sin(angle)
    a, b = (i + 1) % 3, (i + 2) % 3
    for row in range(3):
        u, v = R[r + 3 * row + a], R[r + 3 * row + b]
        R[r + 3 * row + a] = c * u + s * v
        R[r + 3 * row + b] = c * v - s * u


def frame_count(skel):
    """F: the joints, then the sites."""
    return skel.joint_int.shape[0] + skel.site_joint.shape[0]


def forward_kinematics(q, skel, R, p, work, axes, record):
    """World rotations R (F*9,) and positions p (F*3,) of every joint then site for pose q.
    Each joint's frame starts as parent @ (offset, rest rotation) and each of its motions then
    turns or slides it in place. With `record`, axes (N*6,) also receives each motion's world
    axis and pivot (the point a rotation turns about), what the analytic Jacobians need
    (device_polish.py). work needs 18 floats (general-axis rotations only)."""
    joint_int, joint_frame, site_joint, site_frame = skel.joint_int, skel.joint_frame, skel.site_joint, skel.site_frame
    motion_int, motion_float = skel.motion_int, skel.motion_float
    J = joint_int.shape[0]
    for k in range(J):
        parent, r = joint_int[k, PARENT], 9 * k
        tx, ty, tz = joint_frame[k, OFFSET], joint_frame[k, OFFSET + 1], joint_frame[k, OFFSET + 2]
        if parent < 0:
            for e in range(9):
                R[r + e] = joint_frame[k, ROTATION + e]
        else:
            if joint_int[k, PLAIN_ROTATION] == 1:
                for e in range(9):
                    R[r + e] = R[9 * parent + e]
            else:
                matmul3(R, 9 * parent, joint_frame[k], ROTATION, R, r)
            dx, dy, dz = rotate_point(R, 9 * parent, tx, ty, tz)
            tx, ty, tz = p[3 * parent] + dx, p[3 * parent + 1] + dy, p[3 * parent + 2] + dz
        for n in range(joint_int[k, MOTION_START], joint_int[k, MOTION_END]):
            ax, ay, az = motion_float[n, AXIS], motion_float[n, AXIS + 1], motion_float[n, AXIS + 2]
            value = motion_float[n, MOTION_SCALE] * q[motion_int[n, SOURCE]] + motion_float[n, MOTION_BIAS]
            if record:
                axes[6 * n], axes[6 * n + 1], axes[6 * n + 2] = rotate_point(R, r, ax, ay, az)
                axes[6 * n + 3], axes[6 * n + 4], axes[6 * n + 5] = tx, ty, tz
            if motion_int[n, MOTION_KIND] != ROTATE_MOTION:
                dx, dy, dz = rotate_point(R, r, ax * value, ay * value, az * value)
                tx, ty, tz = tx + dx, ty + dy, tz + dz
            elif motion_int[n, COORDINATE_AXIS] >= 0:
                turn_columns(R, r, motion_int[n, COORDINATE_AXIS], value * (ax + ay + az))
            else:
                axis_angle_into(ax, ay, az, value, work, 0)
                matmul3(R, r, work, 0, work, 9)
                for e in range(9):
                    R[r + e] = work[9 + e]
        p[3 * k], p[3 * k + 1], p[3 * k + 2] = tx, ty, tz
    for s in range(site_joint.shape[0]):
        j, f = site_joint[s], J + s
        matmul3(R, 9 * j, site_frame[s], ROTATION, R, 9 * f)
        dx, dy, dz = rotate_point(R, 9 * j, site_frame[s, OFFSET], site_frame[s, OFFSET + 1], site_frame[s, OFFSET + 2])
        p[3 * f], p[3 * f + 1], p[3 * f + 2] = p[3 * j] + dx, p[3 * j + 1] + dy, p[3 * j + 2] + dz


def mass_point(skel, R, p, m):
    """World position of mass point m (from its joint's frame)."""
    j, mass_data = skel.mass_joint[m], skel.mass_data
    dx, dy, dz = rotate_point(
        R, 9 * j, mass_data[m, MASS_OFFSET], mass_data[m, MASS_OFFSET + 1], mass_data[m, MASS_OFFSET + 2]
    )
    return p[3 * j] + dx, p[3 * j + 1] + dy, p[3 * j + 2] + dz


def centre_of_mass(skel, R, p):
    """Whole-body centre of mass (Eq. 3) from joint frames; mass_data holds mass fractions."""
    cx, cy, cz = 0.0, 0.0, 0.0
    for m in range(skel.mass_joint.shape[0]):
        x, y, z = mass_point(skel, R, p, m)
        w = skel.mass_data[m, MASS_FRACTION]
        cx += w * x
        cy += w * y
        cz += w * z
    return cx, cy, cz

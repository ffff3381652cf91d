"""Device maths, part 1: counter-based random numbers, 3x3 algebra, forward kinematics, COM.

The device/*.py files are written once and compiled for the CPU (numba.njit) and the GPU
(numba-cuda): `deik.backends.targets` execs them all into one namespace per target, dropping
their imports of each other, so their functions call each other on the same target (they are
not meant to be called as plain Python). Nothing here may allocate; callers pass scratch
arrays. Matrices are flat, row-major, 9 floats per frame. The data they read (skel, terms,
scratch, ...) are the NamedTuples of deik.device.layout.

Every sine and cosine of a pose goes through `sin_cos`, a polynomial of our own: it vectorises
across SIMD lanes (libm's sinf and cosf do not), it computes in the kernel's own dtype (float32
stays float32, so AVX lanes hold 8 or 16 of them), and it is the same function, operation for
operation, on the CPU, on the GPU and in the CUDA simulator, so a pose scores the same bits on
the blocked CPU path (device/lanes.py) and the one-pose path.
"""

import math

import numpy as np

from deik.device.layout import (
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
_S30, _S27, _S31, _S32, _S40 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(32), np.uint64(40)
_TWO24 = 16777216.0
_INV24 = 1.0 / _TWO24
# small functions of scalars the CPU target inlines (deik.backends.targets), so the loops that call
# them vectorise: over SIMD lanes (device/lanes.py) and over a trial's genes (make_trial)
INLINE = ("sin_cos", "dot3", "turn", "axis_angle", "mix64", "unit_bits", "unit", "below")

# sin_cos: x = k pi/2 + r with k the nearest integer to x 2/pi; r = x - k pi/2 is exact in
# Cody-Waite parts whose products with k are exact: float32 parts of 11 significant bits (exact
# for |k| < 2^13, |x| < 12,868), float64 parts of 33 bits (fdlibm's, |k| < 2^20); the last part is
# the rest, rounded. Adding then subtracting 1.5 * 2^(mantissa bits) rounds to the nearest integer.
_TWO_OVER_PI = 0.636619772367581343076
_PIO2_32 = (1.5703125, 4.837512969970703e-04, 7.549533620476723e-08, 2.5633440682570896e-12)
_PIO2_64 = (1.57079632673412561417e00, 6.07710050630396597660e-11, 2.02226624879595063154e-21)
_ROUND_32, _ROUND_64 = 12582912.0, 6755399441055744.0
# minimax polynomials on |r| <= pi/4: sin r = r + r^3 S(r^2), cos r = 1 - r^2/2 + r^4 C(r^2);
# float32 coefficients from Cephes' sinf/cosf, float64 from fdlibm's __kernel_sin/__kernel_cos
_SIN_32 = (-1.6666654611e-1, 8.3321608736e-3, -1.9515295891e-4)
_COS_32 = (4.166664568298827e-2, -1.388731625493765e-3, 2.443315711809948e-5)
_SIN_64 = (
    -1.66666666666666324348e-01,
    8.33333333332248946124e-03,
    -1.98412698298579493134e-04,
    2.75573137070700676789e-06,
    -2.50507602534068634195e-08,
    1.58969099521155010221e-10,
)
_COS_64 = (
    4.16666666666666019037e-02,
    -1.38888888888741095749e-03,
    2.48015872894767294178e-05,
    -2.75573143513906633035e-07,
    2.08757232129817482790e-09,
    -1.13596475577881948265e-11,
)


def mix64(z):
    """splitmix64 finaliser: a bijective 64-bit hash."""
    z = (z ^ (z >> _S30)) * _K2
    z = (z ^ (z >> _S27)) * _K3
    return z ^ (z >> _S31)


def stream(seed, problem, generation, individual):
    """The 64-bit key of the counter (seed, problem, generation, individual); draw k of it is
    mix64(key + k): one hash per draw, so a loop of draws over genes vectorises."""
    z = mix64(np.uint64(seed) + _K1 * np.uint64(problem + 1))
    z = mix64(z ^ (_K4 * np.uint64(generation + 2)))
    return mix64(z ^ (_K1 * np.uint64(individual + 1)))


def unit_bits(key, draw):
    """Draw `draw` of stream `key` as a 24-bit integer (uint64)."""
    return mix64(key + np.uint64(draw)) >> _S40


def unit(key, draw):
    """Draw `draw` of stream `key`: a float64 in [0, 1) with 24 random bits (exact in float32)."""
    return float(unit_bits(key, draw)) * _INV24


def threshold(probability):
    """The integer t with unit_bits(key, draw) < t exactly when unit(key, draw) < probability
    (in [0, 1]): the comparison without converting the draw to a float."""
    return np.uint64(math.ceil(probability * _TWO24))


def below(n, key, draw):
    """Draw `draw` of stream `key`: an integer in [0, n) for 0 < n < 2^32 (the high 32 bits
    times n, shifted: no division)."""
    return np.int64(((mix64(key + np.uint64(draw)) >> _S32) * np.uint64(n)) >> _S32)


def sin_cos(x, like):
    """(sin x, cos x) in the dtype of the array `like` (x radians, the same dtype), branch-free so
    loops over SIMD lanes vectorise. Within 2.5 ulp of the correctly rounded values for |x| up to
    1e4 (tests/backends/test_sin_cos.py); beyond 12,868 rad in float32 the error grows with |x|
    like the spacing of x itself. Constants are cast to the dtype (`t(...)`): a float literal
    would widen float32 arithmetic to float64 and halve the lanes."""
    t = like.dtype.type
    if t(1.0) + t(2.0**-30) == t(1.0):  # float32: the compiler folds this test away
        k = (x * t(_TWO_OVER_PI) + t(_ROUND_32)) - t(_ROUND_32)
        r = (((x - k * t(_PIO2_32[0])) - k * t(_PIO2_32[1])) - k * t(_PIO2_32[2])) - k * t(_PIO2_32[3])
        z = r * r
        s = r + r * z * (t(_SIN_32[0]) + z * (t(_SIN_32[1]) + z * t(_SIN_32[2])))
        c = t(1.0) - t(0.5) * z + z * z * (t(_COS_32[0]) + z * (t(_COS_32[1]) + z * t(_COS_32[2])))
    else:
        k = (x * t(_TWO_OVER_PI) + t(_ROUND_64)) - t(_ROUND_64)
        r = ((x - k * t(_PIO2_64[0])) - k * t(_PIO2_64[1])) - k * t(_PIO2_64[2])
        z = r * r
        s = t(_SIN_64[3]) + z * (t(_SIN_64[4]) + z * t(_SIN_64[5]))
        s = t(_SIN_64[0]) + z * (t(_SIN_64[1]) + z * (t(_SIN_64[2]) + z * s))
        c = t(_COS_64[3]) + z * (t(_COS_64[4]) + z * t(_COS_64[5]))
        c = t(_COS_64[0]) + z * (t(_COS_64[1]) + z * (t(_COS_64[2]) + z * c))
        s = r + r * z * s
        c = t(1.0) - t(0.5) * z + z * z * c
    quadrant = np.int32(k)
    if quadrant & 1:  # selects, not branches, once compiled
        s, c = c, -s
    if quadrant & 2:
        s, c = -s, -c
    return s, c


def dot3(a0, a1, a2, b0, b1, b2):
    """a0 b0 + a1 b1 + a2 b2, summed in that order: every rotation product of both FK paths uses
    it, so the one-pose and the lane paths round alike."""
    return a0 * b0 + a1 * b1 + a2 * b2


def turn(c, s, u, v):
    """Two columns' entries (u, v) of one row after a turn by the angle of cosine c and sine s
    about the third coordinate axis."""
    return c * u + s * v, c * v - s * u


def matmul3(A, a, B, b, C, c):
    """C[c:c+9] = A[a:a+9] @ B[b:b+9] for flat row-major 3x3 matrices (C must not alias)."""
    for r in range(3):
        for k in range(3):
            row = a + 3 * r
            C[c + 3 * r + k] = dot3(A[row], A[row + 1], A[row + 2], B[b + k], B[b + 3 + k], B[b + 6 + k])


def rotate_point(A, a, x, y, z):
    """A[a:a+9] @ (x, y, z)."""
    return (
        dot3(A[a], A[a + 1], A[a + 2], x, y, z),
        dot3(A[a + 3], A[a + 4], A[a + 5], x, y, z),
        dot3(A[a + 6], A[a + 7], A[a + 8], x, y, z),
    )


def axis_angle(ax, ay, az, s, c, one):
    """The 9 entries, row-major, of the rotation about unit axis (ax, ay, az) by the angle of sine
    s and cosine c (Rodrigues); one: 1 in the kernel's dtype."""
    t = one - c
    return (
        t * ax * ax + c,
        t * ax * ay - s * az,
        t * ax * az + s * ay,
        t * ax * ay + s * az,
        t * ay * ay + c,
        t * ay * az - s * ax,
        t * ax * az - s * ay,
        t * ay * az + s * ax,
        t * az * az + c,
    )


def axis_angle_into(ax, ay, az, angle, M, m):
    """M[m:m+9] = rotation about unit axis (ax, ay, az) by `angle` radians (Rodrigues)."""
    s, c = sin_cos(angle, M)
    entries = axis_angle(ax, ay, az, s, c, M.dtype.type(1.0))
    for e in range(9):
        M[m + e] = entries[e]


def turn_columns(R, r, i, angle):
    """R[r:r+9] = R[r:r+9] @ (rotation about coordinate axis i by `angle` radians), in place:
    only the two other columns mix (12 flops instead of Rodrigues and a 3x3 product)."""
    s, c = sin_cos(angle, R)
    # (i + 1) % 3 and (i + 2) % 3 as selects, without two integer divisions per turn
    a = 1 if i == 0 else (2 if i == 1 else 0)
    b = 2 if i == 0 else (0 if i == 1 else 1)
    for row in range(3):
        R[r + 3 * row + a], R[r + 3 * row + b] = turn(c, s, R[r + 3 * row + a], R[r + 3 * row + b])


def frame_count(skel):
    """F: the joints, then the sites."""
    return skel.joint_int.shape[0] + skel.site_joint.shape[0]


def forward_kinematics(q, skel, R, p, work, axes, record):
    """World rotations R (F*9,) and positions p (F*3,) of every joint then site for pose q.
    Each joint's frame starts as parent @ (offset, rest rotation) and each of its motions then
    turns or slides it in place. With `record`, axes (N*6,) also receives each motion's world
    axis and pivot (the point a rotation turns about), what the analytic Jacobians need
    (device/polish.py). work needs 18 floats (general-axis rotations only)."""
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

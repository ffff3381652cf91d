"""Device maths, part 4: residuals and analytic Jacobians for the Levenberg-Marquardt polish.

Compiled together with the other deik.device modules (see deik.backends.targets). Smooth goals
have residual vectors: position (3 rows, p - target, metres), orientation (3 rows, the
rotation vector of R R_target^T, radians), centre of mass (3 rows) and COM over support (the
same, projected on the ground). Each row is scaled by sqrt(weight * gain) / unit, where unit
is the goal's tolerance (or its distance scale when it has none), so LM minimises errors
counted in tolerances. Jacobians are geometric: a rotation motion turns every frame below its
joint about its world axis through its pivot, a translation motion moves them along its
world axis; mimic motions add scale times that to their source DOF's column.

A team of GPU threads (deik.backends.cuda_team) forms one term's Jacobian together, each thread
its own columns: every row function takes `lane` and `mask` and writes the columns d with
d & mask == lane (mask 0: every column, what one thread alone asks). Each column is summed in the
same order whoever forms it, so a team's Jacobian is bit for bit a thread's. The CPU build
compiles with COLUMNS_SPLIT off (deik.backends.targets): the ownership test is pruned there.
"""

import math

from deik.device.compiled_kinds import COM_ON, ORIENTATION_ON, POSITION_ON
from deik.device.layout import (
    MASS_FRACTION,
    MOTION_END,
    MOTION_KIND,
    MOTION_SCALE,
    MOTION_START,
    PARENT,
    ROTATE_MOTION,
    SOURCE,
    UP,
)
from deik.device.maths import mass_point
from deik.device.terms import rotation_error, weight_of
from deik.objectives.kinds import (
    AIM,
    COM_GROUND,
    ORIENTATION,
    POSITION,
    SCALE,
    TERM_FRAMES,
    TERM_KIND,
    TOLERANCE,
)

COLUMNS_SPLIT = True  # may threads share a term's columns? (off in the CPU build: one thread each)
INLINE = ("owns",)


def owns(d, lane, mask):
    """Does the thread `lane` form Jacobian column d (d & mask == lane; mask 0: every column)?"""
    return not COLUMNS_SPLIT or (d & mask) == lane


def frame_joint(f, skel):
    """The joint that carries frame f (a joint, or a site's joint)."""
    J = skel.joint_int.shape[0]
    return f if f < J else skel.site_joint[f - J]


def point_rows(x, y, z, j, skel, axes, weight, jac, D, lane, mask):
    """jac[0:3*D] += weight * d(point)/dq for a world point (x, y, z) carried by joint j (every
    motion of j and of its ancestors moves it), in the columns `lane` owns."""
    joint_int, motion_int, motion_float = skel.joint_int, skel.motion_int, skel.motion_float
    k = j
    while k >= 0:
        for n in range(joint_int[k, MOTION_START], joint_int[k, MOTION_END]):
            d, s = motion_int[n, SOURCE], weight * motion_float[n, MOTION_SCALE]
            if not owns(d, lane, mask):
                continue
            ax, ay, az = axes[6 * n], axes[6 * n + 1], axes[6 * n + 2]
            if motion_int[n, MOTION_KIND] == ROTATE_MOTION:
                vx, vy, vz = x - axes[6 * n + 3], y - axes[6 * n + 4], z - axes[6 * n + 5]
                ax, ay, az = ay * vz - az * vy, az * vx - ax * vz, ax * vy - ay * vx
            jac[d] += s * ax
            jac[D + d] += s * ay
            jac[2 * D + d] += s * az
        k = joint_int[k, PARENT]


def rotation_rows(j, skel, axes, weight, jac, D, lane, mask):
    """jac[0:3*D] += weight * (angular velocity of joint j's frame per unit dq): the rotations
    of j and of its ancestors, in the columns `lane` owns."""
    joint_int, motion_int, motion_float = skel.joint_int, skel.motion_int, skel.motion_float
    k = j
    while k >= 0:
        for n in range(joint_int[k, MOTION_START], joint_int[k, MOTION_END]):
            d = motion_int[n, SOURCE]
            if motion_int[n, MOTION_KIND] == ROTATE_MOTION and owns(d, lane, mask):
                s = weight * motion_float[n, MOTION_SCALE]
                jac[d] += s * axes[6 * n]
                jac[D + d] += s * axes[6 * n + 1]
                jac[2 * D + d] += s * axes[6 * n + 2]
        k = joint_int[k, PARENT]


def rotation_vector(R, f, target):
    """Rotation vector (radians) of R_f R_target^T, the world-frame orientation error."""
    vx, vy, vz, angle = rotation_error(R, f, target)
    sine = math.sqrt(vx * vx + vy * vy + vz * vz)
    ratio = angle / sine if sine > 1e-12 else 1.0
    return vx * ratio, vy * ratio, vz * ratio


def log_derivative(rx, ry, rz, jac, D, lane, mask):
    """Map the angular-velocity columns `lane` owns of jac (3 rows of D) to derivatives of the rotation vector
    r = (rx, ry, rz): multiply by the inverse left Jacobian of SO(3),
    I - [r]/2 + (1/t^2 - (1 + cos t) / (2 t sin t)) [r]^2 with t = |r|."""
    t = math.sqrt(rx * rx + ry * ry + rz * rz)
    c = 1.0 / 12.0
    if t >= 1e-4:
        c = 1.0 / (t * t) - (1.0 + math.cos(t)) / max(2.0 * t * math.sin(t), 1e-12)
    for d in range(D):
        if not owns(d, lane, mask):
            continue
        wx, wy, wz = jac[d], jac[D + d], jac[2 * D + d]
        ux, uy, uz = ry * wz - rz * wy, rz * wx - rx * wz, rx * wy - ry * wx
        vx, vy, vz = ry * uz - rz * uy, rz * ux - rx * uz, rx * uy - ry * ux
        jac[d] = wx - 0.5 * ux + c * vx
        jac[D + d] = wy - 0.5 * uy + c * vy
        jac[2 * D + d] = wz - 0.5 * uz + c * vz


def com_rows(skel, R, p, axes, weight, jac, D, lane, mask):
    """jac[0:3*D] += weight * d(centre of mass)/dq (mass fractions in mass_data), in the columns
    `lane` owns."""
    for m in range(skel.mass_joint.shape[0]):
        x, y, z = mass_point(skel, R, p, m)
        w = weight * skel.mass_data[m, MASS_FRACTION]
        point_rows(x, y, z, skel.mass_joint[m], skel, axes, w, jac, D, lane, mask)


def is_polished(kind):
    """Has a term of this kind residual rows (position, orientation, centre of mass, COM over
    a ground point)? The others are left to DE."""
    return kind <= COM_GROUND and kind != AIM


def term_rows(t, b, skel, terms, R, p, cx, cy, cz, axes, jac, D, lane, mask):
    """Scaled residual (3,) of smooth term t and the columns `lane` owns of its Jacobian rows
    in jac[0:3*D]; (0, 0, 0) and zero rows for terms the polish leaves to DE."""
    term_int, term_float = terms.term_int, terms.term_float
    for d in range(D):
        if owns(d, lane, mask):
            jac[d] = jac[D + d] = jac[2 * D + d] = 0.0
    kind, f = term_int[t, TERM_KIND], term_int[t, TERM_FRAMES]
    g = terms.params[b, t]
    w = weight_of(terms, b, t)
    if w <= 0.0 or not is_polished(kind):
        return 0.0, 0.0, 0.0
    unit = term_float[t, TOLERANCE] if term_float[t, TOLERANCE] > 0.0 else term_float[t, SCALE]
    s = math.sqrt(w) / unit
    if POSITION_ON and kind == POSITION:
        point_rows(p[3 * f], p[3 * f + 1], p[3 * f + 2], frame_joint(f, skel), skel, axes, s, jac, D, lane, mask)
        return s * (p[3 * f] - g[0]), s * (p[3 * f + 1] - g[1]), s * (p[3 * f + 2] - g[2])
    if ORIENTATION_ON and kind == ORIENTATION:
        rotation_rows(frame_joint(f, skel), skel, axes, s, jac, D, lane, mask)
        rx, ry, rz = rotation_vector(R, f, g)
        log_derivative(rx, ry, rz, jac, D, lane, mask)
        return s * rx, s * ry, s * rz
    if not COM_ON:  # the kernel is compiled without centre-of-mass goals (device/compiled_kinds.py)
        return 0.0, 0.0, 0.0
    com_rows(skel, R, p, axes, s, jac, D, lane, mask)
    rx, ry, rz = s * (cx - g[0]), s * (cy - g[1]), s * (cz - g[2])
    if kind == COM_GROUND:
        up = skel.ground[UP]
        h = rx * up[0] + ry * up[1] + rz * up[2]
        rx, ry, rz = rx - h * up[0], ry - h * up[1], rz - h * up[2]
        for d in range(D):
            if not owns(d, lane, mask):
                continue
            h = jac[d] * up[0] + jac[D + d] * up[1] + jac[2 * D + d] * up[2]
            jac[d] -= h * up[0]
            jac[D + d] -= h * up[1]
            jac[2 * D + d] -= h * up[2]
    return rx, ry, rz

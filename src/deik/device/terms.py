"""Device maths, part 2: every objective term's raw error and the weighted fitness (Eqs. 1-7).

Compiled together with the other deik.device modules (see deik.backends.targets); term kinds and
columns are the constants of deik.objectives.kinds.
"""

import math

from deik.device.collision import self_collision_error
from deik.device.compiled_kinds import (
    AIM_ON,
    CENTRE_OF_MASS_ON,
    COM_ON,
    COMFORT_ON,
    FLOOR_ON,
    LIMITS_ON,
    OBSTACLE_ON,
    ORIENTATION_ON,
    POSITION_ON,
    SELF_COLLISION_ON,
    SUPPORT_POLYGON_ON,
)
from deik.device.layout import HORIZONTAL_U, HORIZONTAL_V, LOWER, PARENT, UP, UPPER
from deik.device.maths import centre_of_mass, forward_kinematics, rotate_point
from deik.objectives.kinds import (
    AIM,
    COM,
    COM_GROUND,
    COMFORT_MAX,
    COMFORT_SUM,
    FLOOR,
    GAIN,
    LIMITS,
    MU,
    OBSTACLE,
    ORIENTATION,
    PAIR_A,
    PAIR_TERM,
    POSITION,
    PRIORITY_TOLERANCE,
    SCALE,
    SELF_COLLISION,
    SUPPORT_POLYGON,
    TERM_FRAME_COUNT,
    TERM_FRAMES,
    TERM_KIND,
    TERM_LEVEL,
    WEIGHT,
)

# inlined into score by the CPU target (deik.backends.targets): a call passes every array of the
# skeleton and term table as separate arguments, which cost more than a position term's error
INLINE = ("term_error",)


def segment_distance(px, py, pz, ax, ay, az, bx, by, bz):
    """Distance from point P to segment AB."""
    ux, uy, uz = bx - ax, by - ay, bz - az
    length2 = ux * ux + uy * uy + uz * uz
    t = 0.0
    if length2 > 0.0:
        t = min(max(((px - ax) * ux + (py - ay) * uy + (pz - az) * uz) / length2, 0.0), 1.0)
    dx, dy, dz = px - ax - t * ux, py - ay - t * uy, pz - az - t * uz
    return math.sqrt(dx * dx + dy * dy + dz * dz)


def polygon_distance(cx, cy, cz, frames, n, ground, p, work):
    """Distance of the COM's ground projection outside the hull of frames' projections: zero
    inside some non-degenerate triangle of the points, else the nearest point-pair segment."""
    u, v = ground[HORIZONTAL_U], ground[HORIZONTAL_V]
    qx = cx * u[0] + cy * u[1] + cz * u[2]
    qy = cx * v[0] + cy * v[1] + cz * v[2]
    for k in range(n):
        f = frames[k]
        work[2 * k] = p[3 * f] * u[0] + p[3 * f + 1] * u[1] + p[3 * f + 2] * u[2]
        work[2 * k + 1] = p[3 * f] * v[0] + p[3 * f + 1] * v[1] + p[3 * f + 2] * v[2]
    for a in range(n):
        xa, ya = work[2 * a], work[2 * a + 1]
        for b in range(a + 1, n):
            xb, yb = work[2 * b], work[2 * b + 1]
            for c in range(b + 1, n):
                xc, yc = work[2 * c], work[2 * c + 1]
                if (xb - xa) * (yc - ya) - (yb - ya) * (xc - xa) == 0.0:
                    continue
                d1 = (xb - xa) * (qy - ya) - (yb - ya) * (qx - xa)
                d2 = (xc - xb) * (qy - yb) - (yc - yb) * (qx - xb)
                d3 = (xa - xc) * (qy - yc) - (ya - yc) * (qx - xc)
                if (d1 >= 0.0 and d2 >= 0.0 and d3 >= 0.0) or (d1 <= 0.0 and d2 <= 0.0 and d3 <= 0.0):
                    return 0.0
    best = 1e30
    for a in range(n):
        for b in range(a, n):
            d = segment_distance(qx, qy, 0.0, work[2 * a], work[2 * a + 1], 0.0, work[2 * b], work[2 * b + 1], 0.0)
            best = min(best, d)
    return best


def rotation_error(R, f, target):
    """(vx, vy, vz, angle): half the skew part of R_f R_target^T (its rotation axis times the
    sine of its angle, world frame) and the angle (radians) between frame f's rotation and the
    row-major target rotation target[0:9]."""
    e01 = R[9 * f] * target[3] + R[9 * f + 1] * target[4] + R[9 * f + 2] * target[5]
    e10 = R[9 * f + 3] * target[0] + R[9 * f + 4] * target[1] + R[9 * f + 5] * target[2]
    e02 = R[9 * f] * target[6] + R[9 * f + 1] * target[7] + R[9 * f + 2] * target[8]
    e20 = R[9 * f + 6] * target[0] + R[9 * f + 7] * target[1] + R[9 * f + 8] * target[2]
    e12 = R[9 * f + 3] * target[6] + R[9 * f + 4] * target[7] + R[9 * f + 5] * target[8]
    e21 = R[9 * f + 6] * target[3] + R[9 * f + 7] * target[4] + R[9 * f + 8] * target[5]
    trace = 0.0
    for i in range(3):
        m = 9 * f + 3 * i
        trace += R[m] * target[3 * i] + R[m + 1] * target[3 * i + 1] + R[m + 2] * target[3 * i + 2]
    vx, vy, vz = 0.5 * (e21 - e12), 0.5 * (e02 - e20), 0.5 * (e10 - e01)
    return vx, vy, vz, math.atan2(math.sqrt(vx * vx + vy * vy + vz * vz), 0.5 * (trace - 1.0))


def uses_centre_of_mass(term_int):
    """Whether any term (COM, COM over ground point, support polygon) reads the COM."""
    for t in range(term_int.shape[0]):
        if term_int[t, TERM_KIND] >= COM and term_int[t, TERM_KIND] <= SUPPORT_POLYGON:
            return True
    return False


def term_error(t, q, b, skel, terms, R, p, work, cx, cy, cz):
    """Raw error of term t (metres or radians) for pose q of problem b."""
    term_int, dof_weight, reference = terms.term_int, terms.dof_weight, terms.reference
    limits, ground = skel.limits, skel.ground
    kind, f = term_int[t, TERM_KIND], term_int[t, TERM_FRAMES]
    g = terms.params[b, t]
    # each kind's branch behind its switch (device/compiled_kinds.py): a CPU kernel compiled for
    # a problem's own kinds leaves the others out
    if POSITION_ON and kind == POSITION:
        dx, dy, dz = p[3 * f] - g[0], p[3 * f + 1] - g[1], p[3 * f + 2] - g[2]
        return math.sqrt(dx * dx + dy * dy + dz * dz)
    if ORIENTATION_ON and kind == ORIENTATION:
        _, _, _, angle = rotation_error(R, f, g)
        return angle
    if AIM_ON and kind == AIM:
        ax, ay, az = rotate_point(R, 9 * f, g[0], g[1], g[2])
        vx, vy, vz = g[3] - p[3 * f], g[4] - p[3 * f + 1], g[5] - p[3 * f + 2]
        kx, ky, kz = ay * vz - az * vy, az * vx - ax * vz, ax * vy - ay * vx
        return math.atan2(math.sqrt(kx * kx + ky * ky + kz * kz), ax * vx + ay * vy + az * vz)
    if COM_ON and (kind == COM or kind == COM_GROUND):
        dx, dy, dz = cx - g[0], cy - g[1], cz - g[2]
        if kind == COM_GROUND:
            h = dx * ground[UP, 0] + dy * ground[UP, 1] + dz * ground[UP, 2]
            dx, dy, dz = dx - h * ground[UP, 0], dy - h * ground[UP, 1], dz - h * ground[UP, 2]
        return math.sqrt(dx * dx + dy * dy + dz * dz)
    if SUPPORT_POLYGON_ON and kind == SUPPORT_POLYGON:
        return polygon_distance(cx, cy, cz, term_int[t, TERM_FRAMES:], term_int[t, TERM_FRAME_COUNT], ground, p, work)
    if COMFORT_ON and (kind == COMFORT_SUM or kind == COMFORT_MAX):
        total = 0.0
        for d in range(dof_weight.shape[1]):
            e = dof_weight[t, d] * abs(q[d] - reference[b, t, d])
            total = total + e if kind == COMFORT_SUM else max(total, e)
        return total
    if LIMITS_ON and kind == LIMITS:
        total = 0.0
        for d in range(limits.shape[0]):
            total += max(limits[d, LOWER] - q[d], 0.0) + max(q[d] - limits[d, UPPER], 0.0)
        return total
    if OBSTACLE_ON and kind == OBSTACLE:
        return obstacle_error(g, skel, p)
    if FLOOR_ON and kind == FLOOR:
        return floor_error(t, g[0], terms, skel, p)
    if SELF_COLLISION_ON and kind == SELF_COLLISION:
        return self_collision_error(t, g[0], terms, skel, p)
    return 0.0  # a kind this kernel is not compiled for (never reached: see compiled_kinds)


def floor_error(t, height, terms, skel, p):
    """Summed depth (metres) below the floor at `height` along up of every joint and site (a bone,
    the segment from its joint to its child, reaches lowest at one of its ends), or, when term
    t lists points in the pair table (frame, frame, clearance), of each listed point's surface,
    `clearance` below it (a capsule's radius): the point must stay that high above the floor."""
    up = skel.ground[UP]
    pair_int, pair_radius = terms.pair_int, terms.pair_radius
    total = 0.0
    listed = False
    for k in range(pair_int.shape[0]):
        if pair_int[k, PAIR_TERM] != t:
            continue
        listed = True
        f = pair_int[k, PAIR_A]
        total += max(height + pair_radius[k] - (p[3 * f] * up[0] + p[3 * f + 1] * up[1] + p[3 * f + 2] * up[2]), 0.0)
    if listed:
        return total
    for f in range(skel.joint_int.shape[0] + skel.site_joint.shape[0]):
        total += max(height - (p[3 * f] * up[0] + p[3 * f + 1] * up[1] + p[3 * f + 2] * up[2]), 0.0)
    return total


def obstacle_error(g, skel, p):
    """Summed depth (metres) of every bone segment inside the sphere of centre g[0:3] and radius
    g[3] plus margin g[4]."""
    joint_int, site_joint = skel.joint_int, skel.site_joint
    total = 0.0
    J = joint_int.shape[0]
    for k in range(1, J + site_joint.shape[0]):
        a = joint_int[k, PARENT] if k < J else site_joint[k - J]
        d = segment_distance(
            g[0], g[1], g[2], p[3 * a], p[3 * a + 1], p[3 * a + 2], p[3 * k], p[3 * k + 1], p[3 * k + 2]
        )
        total += max(g[3] + g[4] - d, 0.0)
    return total


def weight_of(terms, b, t):
    """Term t's effective weight in problem b: its weight times the problem's gain (0: off)."""
    return terms.term_float[t, WEIGHT] * terms.params[b, t, GAIN]


def evaluate(q, b, skel, terms, scratch, levels, raw):
    """Fitness of pose q for problem b: fills levels (L,) and raw (T,); returns the total
    weighted sum of normalised terms (Eqs. 1, 2)."""
    forward_kinematics(q, skel, scratch.R, scratch.p, scratch.work, scratch.work, False)
    return score(q, b, skel, terms, scratch, levels, raw)


def score(q, b, skel, terms, scratch, levels, raw):
    """evaluate() for a pose q whose world frames are already in scratch.R and scratch.p (the
    polish computes them with the axes its Jacobians need, and scores the same frames)."""
    R, p, work = scratch.R, scratch.p, scratch.work
    term_int, term_float = terms.term_int, terms.term_float
    cx, cy, cz = 0.0, 0.0, 0.0
    if CENTRE_OF_MASS_ON and uses_centre_of_mass(term_int):
        cx, cy, cz = centre_of_mass(skel, R, p)
    for lv in range(levels.shape[0]):
        levels[lv] = 0.0
    total = 0.0
    for t in range(term_int.shape[0]):
        e = term_error(t, q, b, skel, terms, R, p, work, cx, cy, cz)
        raw[t] = e
        f = -math.expm1(-term_float[t, MU] * e / term_float[t, SCALE])
        w = weight_of(terms, b, t)
        total += w * f
        if term_float[t, PRIORITY_TOLERANCE] >= 0.0:
            f = max(f - term_float[t, PRIORITY_TOLERANCE], 0.0)
        levels[term_int[t, TERM_LEVEL]] += w * f
    return total

"""Device maths: distances between bone segments and the self-collision term's raw error.

Compiled together with the other deik.device modules (see deik.backends.targets). A bone ends at
frame k > 0 and starts at its parent joint (a joint) or at the joint it hangs from (a site), as
in deik.model.capsules; positions p are flat (F*3,) world positions, lengths in skeleton units.
"""

import math

from deik.device.layout import PARENT
from deik.objectives.kinds import PAIR_A, PAIR_B, PAIR_TERM


def bone_start(k, skel):
    """The frame bone k (k > 0) starts from."""
    J = skel.joint_int.shape[0]
    return skel.joint_int[k, PARENT] if k < J else skel.site_joint[k - J]


def _unit_clamp(x):
    return min(max(x, 0.0), 1.0)


def segments_distance(p, a0, a1, b0, b1):
    """Distance between segments from frame a0 to a1 and from b0 to b1: the closest points'
    parameters minimise over [0, 1]^2 (Ericson, Real-Time Collision Detection, 5.1.9); a
    segment of zero length is its point. deik.model.geometry.segments_distance is its twin."""
    ux, uy, uz = p[3 * a1] - p[3 * a0], p[3 * a1 + 1] - p[3 * a0 + 1], p[3 * a1 + 2] - p[3 * a0 + 2]
    vx, vy, vz = p[3 * b1] - p[3 * b0], p[3 * b1 + 1] - p[3 * b0 + 1], p[3 * b1 + 2] - p[3 * b0 + 2]
    wx, wy, wz = p[3 * a0] - p[3 * b0], p[3 * a0 + 1] - p[3 * b0 + 1], p[3 * a0 + 2] - p[3 * b0 + 2]
    a = ux * ux + uy * uy + uz * uz
    e = vx * vx + vy * vy + vz * vz
    f = vx * wx + vy * wy + vz * wz
    s, t = 0.0, 0.0
    if a > 0.0:
        c = ux * wx + uy * wy + uz * wz
        if e > 0.0:
            b = ux * vx + uy * vy + uz * vz
            denom = a * e - b * b
            if denom > 0.0:
                s = _unit_clamp((b * f - c * e) / denom)
            t = (b * s + f) / e
            if t < 0.0:
                t, s = 0.0, _unit_clamp(-c / a)
            elif t > 1.0:
                t, s = 1.0, _unit_clamp((b - c) / a)
        else:
            s = _unit_clamp(-c / a)
    elif e > 0.0:
        t = _unit_clamp(f / e)
    dx, dy, dz = wx + s * ux - t * vx, wy + s * uy - t * vy, wz + s * uz - t * vz
    return math.sqrt(dx * dx + dy * dy + dz * dz)


def self_collision_error(t, margin, terms, skel, p):
    """Summed penetration (length units) of term t's bone pairs: each pair's radii sum plus
    `margin` minus the distance between its two bones, where positive."""
    pair_int, pair_radius = terms.pair_int, terms.pair_radius
    total = 0.0
    for k in range(pair_int.shape[0]):
        if pair_int[k, PAIR_TERM] != t:
            continue
        a, b = pair_int[k, PAIR_A], pair_int[k, PAIR_B]
        d = segments_distance(p, bone_start(a, skel), a, bone_start(b, skel), b)
        total += max(pair_radius[k] + margin - d, 0.0)
    return total

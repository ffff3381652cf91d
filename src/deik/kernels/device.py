"""Device maths, written once and compiled for the CPU (numba.njit) and the GPU (numba-cuda).

Plain functions only: `deik.kernels.targets` compiles this file's source into one namespace
per target, so calls between these functions resolve to the same target. Nothing here may
allocate; callers pass scratch arrays. Matrices are flat, row-major, 9 floats per frame.
Tuples group the arrays: skel = (joint_int (J, 3): parent, dof start, dof end; joint_offset
(J, 3); dof_kind (D,); dof_axis (D, 3); site_joint (S,); site_frame (S, 12): offset then
rotation; mass_joint (M,); mass_data (M, 4): offset then mass fraction; limits (D, 2);
ground (3, 3): two horizontal axes then up), terms = (term_int, term_float, params,
dof_weight, reference (B, D)), scratch = (R (F*9,), p (F*3,), work (32,)).
"""

import math

import numpy as np

_K1 = np.uint64(0x9E3779B97F4A7C15)
_K2 = np.uint64(0xBF58476D1CE4E5B9)
_K3 = np.uint64(0x94D049BB133111EB)
_K4 = np.uint64(0xD6E8FEB86659FD93)
_S30, _S27, _S31, _S33, _S40 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(33), np.uint64(40)
_INV24 = 1.0 / 16777216.0
_TWO_PI = 2.0 * math.pi


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
            C[c + 3 * r + k] = A[a + 3 * r] * B[b + k] + A[a + 3 * r + 1] * B[b + 3 + k] + A[a + 3 * r + 2] * B[b + 6 + k]


def rotate_point(A, a, x, y, z):
    """A[a:a+9] @ (x, y, z)."""
    return (A[a] * x + A[a + 1] * y + A[a + 2] * z,
            A[a + 3] * x + A[a + 4] * y + A[a + 5] * z,
            A[a + 6] * x + A[a + 7] * y + A[a + 8] * z)


def axis_angle_into(ax, ay, az, angle, M, m):
    """M[m:m+9] = rotation about unit axis (ax, ay, az) by `angle` radians (Rodrigues)."""
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    M[m], M[m + 1], M[m + 2] = t * ax * ax + c, t * ax * ay - s * az, t * ax * az + s * ay
    M[m + 3], M[m + 4], M[m + 5] = t * ax * ay + s * az, t * ay * ay + c, t * ay * az - s * ax
    M[m + 6], M[m + 7], M[m + 8] = t * ax * az - s * ay, t * ay * az + s * ax, t * az * az + c


def forward_kinematics(q, skel, R, p, work):
    """World rotations R (F*9,) and positions p (F*3,) of every joint then site for pose q."""
    joint_int, joint_offset, dof_kind, dof_axis, site_joint, site_frame = skel[0], skel[1], skel[2], skel[3], skel[4], skel[5]
    J = joint_int.shape[0]
    for k in range(J):
        for e in range(9):
            work[e] = 1.0 if e % 4 == 0 else 0.0
        tx, ty, tz = joint_offset[k, 0], joint_offset[k, 1], joint_offset[k, 2]
        for d in range(joint_int[k, 1], joint_int[k, 2]):
            ax, ay, az = dof_axis[d, 0], dof_axis[d, 1], dof_axis[d, 2]
            if dof_kind[d] == 0:
                axis_angle_into(ax, ay, az, q[d], work, 9)
                matmul3(work, 0, work, 9, work, 18)
                for e in range(9):
                    work[e] = work[18 + e]
            else:
                dx, dy, dz = rotate_point(work, 0, ax * q[d], ay * q[d], az * q[d])
                tx, ty, tz = tx + dx, ty + dy, tz + dz
        parent = joint_int[k, 0]
        if parent < 0:
            for e in range(9):
                R[9 * k + e] = work[e]
            p[3 * k], p[3 * k + 1], p[3 * k + 2] = tx, ty, tz
        else:
            matmul3(R, 9 * parent, work, 0, R, 9 * k)
            dx, dy, dz = rotate_point(R, 9 * parent, tx, ty, tz)
            p[3 * k], p[3 * k + 1], p[3 * k + 2] = p[3 * parent] + dx, p[3 * parent + 1] + dy, p[3 * parent + 2] + dz
    for s in range(site_joint.shape[0]):
        j, f = site_joint[s], J + s
        matmul3(R, 9 * j, site_frame[s], 3, R, 9 * f)
        dx, dy, dz = rotate_point(R, 9 * j, site_frame[s, 0], site_frame[s, 1], site_frame[s, 2])
        p[3 * f], p[3 * f + 1], p[3 * f + 2] = p[3 * j] + dx, p[3 * j + 1] + dy, p[3 * j + 2] + dz


def centre_of_mass(skel, R, p):
    """Whole-body centre of mass (Eq. 3) from joint frames; mass_data holds mass fractions."""
    mass_joint, mass_data = skel[6], skel[7]
    cx, cy, cz = 0.0, 0.0, 0.0
    for m in range(mass_joint.shape[0]):
        j = mass_joint[m]
        dx, dy, dz = rotate_point(R, 9 * j, mass_data[m, 0], mass_data[m, 1], mass_data[m, 2])
        w = mass_data[m, 3]
        cx += w * (p[3 * j] + dx)
        cy += w * (p[3 * j + 1] + dy)
        cz += w * (p[3 * j + 2] + dz)
    return cx, cy, cz


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
    """Distance of the COM's ground projection outside the hull of frames' projections."""
    qx = cx * ground[0, 0] + cy * ground[0, 1] + cz * ground[0, 2]
    qy = cx * ground[1, 0] + cy * ground[1, 1] + cz * ground[1, 2]
    for k in range(n):
        f = frames[k]
        work[2 * k] = p[3 * f] * ground[0, 0] + p[3 * f + 1] * ground[0, 1] + p[3 * f + 2] * ground[0, 2]
        work[2 * k + 1] = p[3 * f] * ground[1, 0] + p[3 * f + 1] * ground[1, 1] + p[3 * f + 2] * ground[1, 2]
    for a in range(n):
        for b in range(a + 1, n):
            for c in range(b + 1, n):
                d1 = (work[2 * b] - work[2 * a]) * (qy - work[2 * a + 1]) - (work[2 * b + 1] - work[2 * a + 1]) * (qx - work[2 * a])
                d2 = (work[2 * c] - work[2 * b]) * (qy - work[2 * b + 1]) - (work[2 * c + 1] - work[2 * b + 1]) * (qx - work[2 * b])
                d3 = (work[2 * a] - work[2 * c]) * (qy - work[2 * c + 1]) - (work[2 * a + 1] - work[2 * c + 1]) * (qx - work[2 * c])
                if (d1 >= 0.0 and d2 >= 0.0 and d3 >= 0.0) or (d1 <= 0.0 and d2 <= 0.0 and d3 <= 0.0):
                    return 0.0
    best = 1e30
    for a in range(n):
        for b in range(a, n):
            d = segment_distance(qx, qy, 0.0, work[2 * a], work[2 * a + 1], 0.0, work[2 * b], work[2 * b + 1], 0.0)
            best = min(best, d)
    return best


def orientation_error(R, f, target):
    """Angle (radians) between frame f's rotation and the row-major target rotation target[0:9]."""
    tr, sx, sy, sz = 0.0, 0.0, 0.0, 0.0
    for i in range(3):
        for j in range(3):
            e = target[i] * R[9 * f + j] + target[3 + i] * R[9 * f + 3 + j] + target[6 + i] * R[9 * f + 6 + j]
            if i == j:
                tr += e
            elif i == 2 and j == 1:
                sx += e
            elif i == 1 and j == 2:
                sx -= e
            elif i == 0 and j == 2:
                sy += e
            elif i == 2 and j == 0:
                sy -= e
            elif i == 1 and j == 0:
                sz += e
            else:
                sz -= e
    return math.atan2(0.5 * math.sqrt(sx * sx + sy * sy + sz * sz), 0.5 * (tr - 1.0))


def term_error(t, q, b, skel, terms, R, p, work, cx, cy, cz):
    """Raw error of term t (metres or radians) for pose q of problem b."""
    term_int, params, dof_weight, reference = terms[0], terms[2], terms[3], terms[4]
    limits, ground, joint_int, site_joint = skel[8], skel[9], skel[0], skel[4]
    kind, f = term_int[t, 0], term_int[t, 3]
    g = params[b, t]
    if kind == 0:
        dx, dy, dz = p[3 * f] - g[0], p[3 * f + 1] - g[1], p[3 * f + 2] - g[2]
        return math.sqrt(dx * dx + dy * dy + dz * dz)
    if kind == 1:
        return orientation_error(R, f, g)
    if kind == 2:
        ax, ay, az = rotate_point(R, 9 * f, g[0], g[1], g[2])
        vx, vy, vz = g[3] - p[3 * f], g[4] - p[3 * f + 1], g[5] - p[3 * f + 2]
        kx, ky, kz = ay * vz - az * vy, az * vx - ax * vz, ax * vy - ay * vx
        return math.atan2(math.sqrt(kx * kx + ky * ky + kz * kz), ax * vx + ay * vy + az * vz)
    if kind == 3 or kind == 4:
        dx, dy, dz = cx - g[0], cy - g[1], cz - g[2]
        if kind == 4:
            h = dx * ground[2, 0] + dy * ground[2, 1] + dz * ground[2, 2]
            dx, dy, dz = dx - h * ground[2, 0], dy - h * ground[2, 1], dz - h * ground[2, 2]
        return math.sqrt(dx * dx + dy * dy + dz * dz)
    if kind == 5:
        return polygon_distance(cx, cy, cz, term_int[t, 3:], term_int[t, 2], ground, p, work)
    if kind == 6 or kind == 7:
        total = 0.0
        for d in range(q.shape[0]):
            e = dof_weight[t, d] * abs(q[d] - reference[b, d])
            total = total + e if kind == 6 else max(total, e)
        return total
    if kind == 8:
        total = 0.0
        for d in range(q.shape[0]):
            total += max(limits[d, 0] - q[d], 0.0) + max(q[d] - limits[d, 1], 0.0)
        return total
    total = 0.0
    J = joint_int.shape[0]
    for k in range(1, J + site_joint.shape[0]):
        a = joint_int[k, 0] if k < J else site_joint[k - J]
        d = segment_distance(g[0], g[1], g[2], p[3 * a], p[3 * a + 1], p[3 * a + 2], p[3 * k], p[3 * k + 1], p[3 * k + 2])
        total += max(g[3] + g[4] - d, 0.0)
    return total


def evaluate(q, b, skel, terms, scratch, levels, raw):
    """Fitness of pose q for problem b: fills levels (L,) and raw (T,); returns the total
    weighted sum of normalised terms (Eqs. 1, 2)."""
    R, p, work = scratch
    term_int, term_float = terms[0], terms[1]
    forward_kinematics(q, skel, R, p, work)
    cx, cy, cz = centre_of_mass(skel, R, p)
    for lv in range(levels.shape[0]):
        levels[lv] = 0.0
    total = 0.0
    for t in range(term_int.shape[0]):
        e = term_error(t, q, b, skel, terms, R, p, work, cx, cy, cz)
        raw[t] = e
        f = -math.expm1(-term_float[t, 1] * e / term_float[t, 2])
        total += term_float[t, 0] * f
        if term_float[t, 4] >= 0.0:
            f = max(f - term_float[t, 4], 0.0)
        levels[term_int[t, 1]] += term_float[t, 0] * f
    return total


def not_worse(a, b):
    """Strict priority: is level vector a at least as good as b (lexicographic)?"""
    for lv in range(a.shape[0]):
        if a[lv] < b[lv]:
            return True
        if a[lv] > b[lv]:
            return False
    return True


def donor(n, exclude_a, exclude_b, exclude_c, n_exclude, seed, b, gen, i, draw):
    """A population index in [0, n) that avoids the first n_exclude of the excluded indices."""
    r = randint(n - n_exclude, seed, b, gen, i, draw)
    lo, mid, hi = exclude_a, exclude_b if n_exclude > 1 else n, exclude_c if n_exclude > 2 else n
    if lo > mid:
        lo, mid = mid, lo
    if mid > hi:
        mid, hi = hi, mid
    if lo > mid:
        lo, mid = mid, lo
    for e in (lo, mid, hi):
        if r >= e:
            r += 1
    return r


def make_trial(pop, b, i, best, gen, settings, limits, trial):
    """DE trial vector for individual i of problem b (Figure 1: reads only the current
    population). settings = (strategy, limit_mode, F, CR, seed). Strategies: 0 rand/1/bin,
    1 best/1/bin, 2 current-to-best/1/bin. Limit modes: 0 reflect, 1 clip, 2 penalty (genes
    may leave their limits; a top-priority term penalises it), 3 the paper's Algorithm 2."""
    strategy, limit_mode, F, CR, seed = settings
    P, D = pop.shape[1], pop.shape[2]
    r1 = donor(P, i, 0, 0, 1, seed, b, gen, i, 0)
    r2 = donor(P, i, r1, 0, 2, seed, b, gen, i, 1)
    r3 = donor(P, i, r1, r2, 3, seed, b, gen, i, 2)
    forced = randint(D, seed, b, gen, i, 3)
    for d in range(D):
        if d == forced or uniform(seed, b, gen, i, 4 + d) < CR:
            if strategy == 0:
                v = pop[b, r1, d] + F * (pop[b, r2, d] - pop[b, r3, d])
            elif strategy == 1:
                v = pop[b, best, d] + F * (pop[b, r1, d] - pop[b, r2, d])
            else:
                v = pop[b, i, d] + F * (pop[b, best, d] - pop[b, i, d]) + F * (pop[b, r1, d] - pop[b, r2, d])
        else:
            v = pop[b, i, d]
        lo, hi = limits[d, 0], limits[d, 1]
        if limit_mode == 0:
            if v < lo:
                v = lo + (lo - v)
            elif v > hi:
                v = hi - (v - hi)
            v = min(max(v, lo), hi)
        elif limit_mode == 1:
            v = min(max(v, lo), hi)
        elif limit_mode == 3 and abs(v) > _TWO_PI:
            v = v * (1.0 / (abs(v) - _TWO_PI))
        trial[d] = v

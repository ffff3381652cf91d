"""Device maths, part 5: the Levenberg-Marquardt polish of one individual (memetic step).

Compiled together with the other device_*.py files (see deik.kernels.targets). The polish
minimises the scaled residuals of device_polish.py over the terms on the levels up to the
individual's first unmet one, with steps clamped into the joint limits (a DOF at a limit that
the gradient pushes outwards is held fixed). A step is kept only if the full strict-priority
fitness improves, so the polish never trades a higher level for a lower one and never leaves
the limits. lm is a layout.LmScratch.
"""

import math

from deik.kernels.device_evolution import keep_trial, within_tolerances
from deik.kernels.device_maths import centre_of_mass, forward_kinematics
from deik.kernels.device_polish import term_rows
from deik.kernels.device_terms import score, uses_centre_of_mass, weight_of
from deik.kernels.layout import LOWER, UPPER
from deik.objectives.kinds import (
    COMFORT_MAX,
    COMFORT_SUM,
    MU,
    SCALE,
    TERM_KIND,
    TERM_LEVEL,
)

_MAX_DAMPING = 1e8
_DAMPING_FLOOR = 1e-2  # damping of a DOF is at least this fraction of the stiffest DOF's


def improves(lv, tot, levels, total):
    """Are levels lv strictly better than `levels` (lexicographic), or equal with a lower total?"""
    for lvl in range(levels.shape[0]):
        if lv[lvl] < levels[lvl]:
            return True
        if lv[lvl] > levels[lvl]:
            return False
    return tot < total


def normal_equations(q, b, top, skel, terms, scratch, axes, lm, D, frames_ready):
    """lm.normal = J^T J and lm.gradient = J^T r at pose q of the smooth terms on levels <=
    top and of every comfort term (a weak pull towards its reference on any level, so that
    steps for a higher level take the smallest move); returns the cost r^T r. frames_ready:
    scratch.R, scratch.p and axes already hold pose q's frames (else they are computed)."""
    R, p, term_int = scratch.R, scratch.p, terms.term_int
    A, gradient, jac = lm.normal, lm.gradient, lm.jac
    if not frames_ready:
        forward_kinematics(q, skel, R, p, scratch.work, axes, True)
    cx, cy, cz = 0.0, 0.0, 0.0
    if uses_centre_of_mass(term_int):
        cx, cy, cz = centre_of_mass(skel, R, p)
    for e in range(D * D):
        A[e] = 0.0
    for d in range(D):
        gradient[d] = 0.0
    cost = 0.0
    for t in range(term_int.shape[0]):
        if term_int[t, TERM_KIND] == COMFORT_SUM or term_int[t, TERM_KIND] == COMFORT_MAX:
            cost += add_comfort(t, b, q, terms, A, gradient, D)
            continue
        if term_int[t, TERM_LEVEL] > top:
            continue
        r0, r1, r2 = term_rows(t, b, skel, terms, R, p, cx, cy, cz, axes, jac, D)
        cost += r0 * r0 + r1 * r1 + r2 * r2
        for row in range(3):
            r = r0 if row == 0 else (r1 if row == 1 else r2)
            for a in range(D):
                ja = jac[row * D + a]
                if ja != 0.0:
                    gradient[a] += ja * r
                    for c in range(D):
                        A[a * D + c] += ja * jac[row * D + c]
    return cost


def add_comfort(t, b, q, terms, A, gradient, D):
    """Comfort term t as quadratic rows sqrt(weight * dof weight) * mu / scale * (q - reference)
    added to A's diagonal and the gradient: the polish then prefers the smallest move from the
    reference among poses that meet the other goals (the comfort's own L1/max form is left to
    DE and to the acceptance test). Returns their cost."""
    term_float, dof_weight, reference = terms.term_float, terms.dof_weight, terms.reference
    w = weight_of(terms, b, t)
    if w <= 0.0:
        return 0.0
    unit = term_float[t, MU] / term_float[t, SCALE]
    cost = 0.0
    for d in range(D):
        c2 = w * dof_weight[t, d] * unit * unit
        e = q[d] - reference[b, t, d]
        A[d * D + d] += c2
        gradient[d] += c2 * e
        cost += c2 * e * e
    return cost


def damped_step(lm, D, damping, q, limits):
    """delta = -(N + damping * diag(N))^-1 gradient for the normal matrix N = lm.normal, by a
    Cholesky factorisation in lm.A (N is kept for retries with other damping), DOFs held at
    their limits where the gradient pushes outwards; False if the matrix is not positive
    definite."""
    A, gradient, delta = lm.A, lm.gradient, lm.delta
    for e in range(D * D):
        A[e] = lm.normal[e]
    peak = 0.0
    for a in range(D):
        peak = max(peak, A[a * D + a])
    for a in range(D):
        A[a * D + a] += damping * max(A[a * D + a], _DAMPING_FLOOR * peak) + 1e-9 * peak + 1e-30
        delta[a] = -gradient[a]
        if (q[a] <= limits[a, LOWER] and gradient[a] > 0.0) or (q[a] >= limits[a, UPPER] and gradient[a] < 0.0):
            for c in range(D):
                A[a * D + c] = 0.0
                A[c * D + a] = 0.0
            A[a * D + a] = 1.0
            delta[a] = 0.0
    for j in range(D):
        s = A[j * D + j]
        for k in range(j):
            s -= A[j * D + k] * A[j * D + k]
        if not s > 0.0:
            return False
        s = math.sqrt(s)
        A[j * D + j] = s
        for i in range(j + 1, D):
            v = A[i * D + j]
            for k in range(j):
                v -= A[i * D + k] * A[j * D + k]
            A[i * D + j] = v / s
    for i in range(D):
        v = delta[i]
        for k in range(i):
            v -= A[i * D + k] * delta[k]
        delta[i] = v / A[i * D + i]
    for i in range(D - 1, -1, -1):
        v = delta[i]
        for k in range(i + 1, D):
            v -= A[k * D + i] * delta[k]
        delta[i] = v / A[i * D + i]
    return True


def polish(b, i, state, iterations, skel, terms, scratch, axes, lm, q, lv, rw):
    """Up to `iterations` LM steps on individual i of problem b, until every tolerance is met,
    in place in the Buffers `state`; q (D,), lv (L,), rw (T,) are scratch."""
    pop, levels, total = state.pop, state.levels, state.total
    D, L, T = pop.shape[2], levels.shape[2], state.raw.shape[2]
    limits = skel.limits
    top = L - 1
    for lvl in range(L - 1, -1, -1):
        if levels[b, i, lvl] > 0.0:
            top = lvl
    damping = 1e-3
    # the normal equations change only when a step is kept; a kept step's frames (computed with
    # the axes, to score it) are then the new pose's, so each iteration runs one FK
    formed, frames_ready = False, False
    for _ in range(iterations):
        if not formed:
            if normal_equations(pop[b, i], b, top, skel, terms, scratch, axes, lm, D, frames_ready) == 0.0:
                return
            formed = True
        if damped_step(lm, D, damping, pop[b, i], limits):
            delta = lm.delta
            for d in range(D):
                q[d] = min(max(pop[b, i, d] + delta[d], limits[d, LOWER]), limits[d, UPPER])
            forward_kinematics(q, skel, scratch.R, scratch.p, scratch.work, axes, True)
            tot = score(q, b, skel, terms, scratch, lv, rw)
            if improves(lv, tot, levels[b, i], total[b, i]):
                keep_trial(state, b, i, q, lv, rw, tot, state.rates[b, i])
                if within_tolerances(b, rw, terms, T):
                    return
                damping = max(damping * 0.3, 1e-7)
                formed, frames_ready = False, True
                continue
        damping *= 10.0
        if damping > _MAX_DAMPING:
            return

"""Device maths, part 5: the Levenberg-Marquardt polish of one individual (memetic step).

Compiled together with the other deik.device modules (see deik.backends.targets). The polish
minimises the scaled residuals of device/polish.py over the terms on the levels up to the
individual's first unmet one, with steps clamped into the joint limits (a DOF at a limit that
the gradient pushes outwards is held fixed). Where every goal has a tolerance it converges on a
copy of the individual, judging steps by the cost it minimises, and the individual takes the
result only if it is better or meets every tolerance (converge); where comfort is left to
improve it also moves towards comfort's reference in their null space, judging each step by
the full strict-priority fitness (relax). Either way the polish never trades a higher level
for a lower one and never leaves the limits. lm is a layout.LmScratch.
"""

import math

from deik.device.compiled_kinds import CENTRE_OF_MASS_ON, COMFORT_ON
from deik.device.evolution import held_at_limit, into_limits, keep_trial, within_tolerances
from deik.device.maths import centre_of_mass, forward_kinematics
from deik.device.polish import is_polished, term_rows
from deik.device.terms import score, uses_centre_of_mass, weight_of
from deik.objectives.kinds import COMFORT_MAX, COMFORT_SUM, SCALE, TERM_KIND, TERM_LEVEL, TOLERANCE

MAX_DAMPING = 1e8
DAMPING_FLOOR = 1e-2  # damping of a DOF is at least this fraction of the stiffest DOF's
_PULL_STIFFNESS = 1e-6  # comfort's weight against the goals' J^T J (its largest diagonal)
_MIN_PULL = 1.0 / 64.0  # a comfort pull is shortened 4-fold per rejected step down to this
STALL_ITERATIONS = 8  # converge gives up when its cost has not halved in this many iterations
# converge's first damping, relative to the normal matrix's diagonal. With fewer residual rows
# than DOFs the Gauss-Newton step is the shortest that zeroes the linearised residual, far too
# long from a far start, and its refusals end many starts in a stall; damping 1 (about half a
# step) met 79 % of Panda 6-D targets from the mid-limit pose instead of 65 % (1e-3), and a
# 20-joint chain's target from a random pose 99.4 % instead of 94.5 %. With exactly as many rows
# (a 6-joint arm's 6-D pose) the square Gauss-Newton step is as long, and from a start at a
# singularity (a UR5's zero pose, the middle of +-2 pi limits) longer still: damping 1 met 84 %
# of such targets in the first polishes instead of 48 %. With more rows than DOFs (a
# least-squares step) 1e-3 did better: three goals on a 4-joint chain took 961 us per problem
# at 1e-3 and 1412 us at 1.
REDUNDANT_DAMPING, DAMPING = 1.0, 1e-3


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
    top (comfort is not among them: comfort_step moves towards its reference in their null
    space); returns the cost r^T r. frames_ready: scratch.R, scratch.p and axes already hold
    pose q's frames (else they are computed)."""
    R, p, term_int = scratch.R, scratch.p, terms.term_int
    A, gradient, jac = lm.normal, lm.gradient, lm.jac
    if not frames_ready:
        forward_kinematics(q, skel, R, p, scratch.work, axes, True)
    cx, cy, cz = 0.0, 0.0, 0.0
    if CENTRE_OF_MASS_ON and uses_centre_of_mass(term_int):
        cx, cy, cz = centre_of_mass(skel, R, p)
    for e in range(D * D):
        A[e] = 0.0
    for d in range(D):
        gradient[d] = 0.0
    cost = 0.0
    for t in range(term_int.shape[0]):
        if term_int[t, TERM_LEVEL] > top:
            continue
        r0, r1, r2 = term_rows(t, b, skel, terms, R, p, cx, cy, cz, axes, jac, D, 0, 0)
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


def polished_rows(b, terms, top):
    """How many residual rows the polish forms for problem b: three per weighted goal with rows
    (device_polish.is_polished) on a level <= top."""
    term_int = terms.term_int
    m = 0
    for t in range(term_int.shape[0]):
        if term_int[t, TERM_LEVEL] <= top and weight_of(terms, b, t) > 0.0 and is_polished(term_int[t, TERM_KIND]):
            m += 3
    return m


def jacobian_rows(q, b, top, m, skel, terms, scratch, axes, lm, D, frames_ready):
    """normal_equations' rows kept as they are, for dual_step when there are fewer (m, from
    polished_rows) than DOFs: J (m, D) row-major in lm.normal[0:m*D], the residual r (m,) in
    lm.A[m*m:m*m+m], lm.gradient = J^T r; returns the cost r^T r."""
    R, p, term_int = scratch.R, scratch.p, terms.term_int
    J, r, gradient = lm.normal, lm.A[m * m : m * m + m], lm.gradient
    if not frames_ready:
        forward_kinematics(q, skel, R, p, scratch.work, axes, True)
    cx, cy, cz = 0.0, 0.0, 0.0
    if CENTRE_OF_MASS_ON and uses_centre_of_mass(term_int):
        cx, cy, cz = centre_of_mass(skel, R, p)
    row, cost = 0, 0.0
    for t in range(term_int.shape[0]):
        if term_int[t, TERM_LEVEL] <= top and weight_of(terms, b, t) > 0.0 and is_polished(term_int[t, TERM_KIND]):
            r[row], r[row + 1], r[row + 2] = term_rows(
                t, b, skel, terms, R, p, cx, cy, cz, axes, J[row * D : (row + 3) * D], D, 0, 0
            )
            cost += r[row] * r[row] + r[row + 1] * r[row + 1] + r[row + 2] * r[row + 2]
            row += 3
    for d in range(D):
        g = 0.0
        for k in range(m):
            g += J[k * D + d] * r[k]
        gradient[d] = g
    return cost


def dual_step(lm, D, m, damping, q, limits, halt):
    """damped_step's step through an m x m system, for m < D rows J (m, D) and residual r of
    jacobian_rows: with Lambda the damping diagonal, (J^T J + Lambda)^-1 J^T r =
    Lambda^-1 J^T (I + J Lambda^-1 J^T)^-1 r (Woodbury), about m^2 D flops instead of
    m D^2 + D^3 / 6: a 20-joint chain reaching for a point solves 3 x 3 instead of 20 x 20.
    Damping and DOFs held at their limits as in damped_step; False if not positive definite."""
    J, A, inverse, delta, gradient = lm.normal, lm.A, lm.jac, lm.delta, lm.gradient
    r, y = A[m * m : m * m + m], A[m * m + m : m * m + 2 * m]
    peak = 0.0
    for d in range(D):
        diagonal = 0.0
        for k in range(m):
            diagonal += J[k * D + d] * J[k * D + d]
        inverse[d] = diagonal
        peak = max(peak, diagonal)
    for d in range(D):
        if held_at_limit(q[d], -gradient[d], limits, d):
            inverse[d] = 0.0
        else:
            inverse[d] = 1.0 / (damping * max(inverse[d], DAMPING_FLOOR * peak) + 1e-9 * peak + 1e-30)
    for i in range(m):
        for k in range(i + 1):
            v = 1.0 if i == k else 0.0
            for d in range(D):
                v += J[i * D + d] * inverse[d] * J[k * D + d]
            A[i * m + k] = v
        y[i] = r[i]
    if not cholesky(A, m, halt):
        return False
    cholesky_solve(A, y, m)
    for d in range(D):
        v = 0.0
        for k in range(m):
            v += J[k * D + d] * y[k]
        delta[d] = -inverse[d] * v
    return True


def comfort_step(b, q, terms, lm, D, pull, limits, halt):
    """Add to the step lm.delta a move towards the comfort terms' reference that leaves the
    polished terms' errors unchanged to first order: the minimiser of (x - v)^T W (x - v) +
    |J x|^2 / stiffness, (J^T J + stiffness W)^-1 stiffness W v, with W the comfort's DOF
    weights, v = pull * (reference - (q + delta)) and a stiffness far below J^T J's scale (the
    acceptance test catches what the curvature adds). Overwrites lm.A (damped_step refills it).
    Returns whether problem b has a comfort term with weight (else nothing is added)."""
    if not COMFORT_ON:  # compiled without comfort terms (device/compiled_kinds.py)
        return False
    term_int, dof_weight, reference = terms.term_int, terms.dof_weight, terms.reference
    A, normal = lm.A, lm.normal
    v, w = lm.jac[0:D], lm.jac[D : 2 * D]
    any_comfort, peak, heaviest = False, 0.0, 0.0
    for d in range(D):
        target, weight = 0.0, 0.0
        for t in range(term_int.shape[0]):
            if term_int[t, TERM_KIND] == COMFORT_SUM or term_int[t, TERM_KIND] == COMFORT_MAX:
                wt = weight_of(terms, b, t) * dof_weight[t, d]
                if wt > 0.0:
                    target += wt * reference[b, t, d]
                    weight += wt
        v[d], w[d] = 0.0, weight
        peak = max(peak, normal[d * D + d])
        heaviest = max(heaviest, weight)
        if weight > 0.0:
            any_comfort = True
            at = q[d] + lm.delta[d]
            v[d] = pull * (target / weight - at)
            if held_at_limit(at, v[d], limits, d):
                v[d] = 0.0
    if not any_comfort:
        return False
    stiffness = _PULL_STIFFNESS * peak / heaviest + 1e-30
    for e in range(D * D):
        A[e] = normal[e]
    for d in range(D):
        A[d * D + d] += stiffness * w[d] + 1e-9 * peak + 1e-30
        v[d] *= stiffness * w[d]
    if not cholesky(A, D, halt):
        return False
    cholesky_solve(A, v, D)
    for d in range(D):
        lm.delta[d] += v[d]
    return True


def cholesky(A, D, halt):
    """Factorise the symmetric A (D*D,) in place into L (lower triangle) with L L^T = A;
    False if A is not positive definite, or when the host's stop flag halt (1,) is set (read
    per column: a factorisation of 3,000 DOFs takes seconds)."""
    for j in range(D):
        if halt[0] != 0:
            return False
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
    return True


def cholesky_solve(A, x, D):
    """x <- (L L^T)^-1 x in place for the Cholesky factor L in A's lower triangle (D*D,)."""
    for i in range(D):
        v = x[i]
        for k in range(i):
            v -= A[i * D + k] * x[k]
        x[i] = v / A[i * D + i]
    for i in range(D - 1, -1, -1):
        v = x[i]
        for k in range(i + 1, D):
            v -= A[k * D + i] * x[k]
        x[i] = v / A[i * D + i]


def damped_step(lm, D, damping, q, limits, halt):
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
        A[a * D + a] += damping * max(A[a * D + a], DAMPING_FLOOR * peak) + 1e-9 * peak + 1e-30
        delta[a] = -gradient[a]
        if held_at_limit(q[a], -gradient[a], limits, a):
            for c in range(D):
                A[a * D + c] = 0.0
                A[c * D + a] = 0.0
            A[a * D + a] = 1.0
            delta[a] = 0.0
    if not cholesky(A, D, halt):
        return False
    cholesky_solve(A, delta, D)
    return True


def open_ended(b, terms, T):
    """Has problem b a weighted goal without a tolerance (comfort), left to improve once every
    tolerance is met?"""
    for t in range(T):
        if terms.term_float[t, TOLERANCE] < 0.0 and weight_of(terms, b, t) > 0.0:
            return True
    return False


def polish(b, i, state, iterations, skel, terms, scratch, axes, lm, q, lv, rw, frames_ready, halt):
    """Up to `iterations` LM steps on individual i of problem b, in the Buffers `state`, towards
    every tolerance (converge), or where a goal without tolerance is left, on to the smallest
    move from comfort's reference (relax); q (D,), lv (L,), rw (T,) are scratch. frames_ready:
    scratch.R, scratch.p and axes already hold the individual's frames (else computed). halt
    (1,): the host's stop flag (Status.halt), read before every iteration: one LM iteration of a
    large skeleton costs D^3 / 6 multiply-adds, so a time limit or Ctrl-C is honoured within one."""
    if open_ended(b, terms, state.raw.shape[2]):
        relax(b, i, state, iterations, skel, terms, scratch, axes, lm, q, lv, rw, frames_ready, halt)
    else:
        converge(b, i, state, iterations, skel, terms, scratch, axes, lm, q, lv, rw, frames_ready, halt)


def first_unmet_level(levels):
    """The first priority level with a positive value (the last level when all are zero):
    the polish works on the goals of this level and those above it."""
    top = levels.shape[0] - 1
    for lvl in range(levels.shape[0] - 1, -1, -1):
        if levels[lvl] > 0.0:
            top = lvl
    return top


def polished_cost(b, rw, terms, top):
    """The LM cost r^T r of raw errors rw (T,): each polished goal on a level <= top adds
    weight * gain * (error / unit)^2, unit its tolerance (else its distance scale), which is
    what normal_equations sums over its scaled residual rows (device_polish.term_rows)."""
    term_int, term_float = terms.term_int, terms.term_float
    cost = 0.0
    for t in range(term_int.shape[0]):
        w = weight_of(terms, b, t)
        if term_int[t, TERM_LEVEL] <= top and w > 0.0 and is_polished(term_int[t, TERM_KIND]):
            unit = term_float[t, TOLERANCE] if term_float[t, TOLERANCE] > 0.0 else term_float[t, SCALE]
            cost += w * (rw[t] / unit) * (rw[t] / unit)
    return cost


def keeps_the_rest(b, lv, rw, pose_levels, pose_raw, terms, top):
    """May a step that lowers the polished cost be kept? Only if no level above `top` gets
    worse and no goal of level `top` that the polish cannot differentiate (left to DE: support
    polygon, aim, obstacles, ...) moves further from its target."""
    for lvl in range(top):
        if lv[lvl] > pose_levels[lvl]:
            return False
    term_int = terms.term_int
    for t in range(term_int.shape[0]):
        if (
            term_int[t, TERM_LEVEL] == top
            and not is_polished(term_int[t, TERM_KIND])
            and weight_of(terms, b, t) > 0.0
            and rw[t] > pose_raw[t]
        ):
            return False
    return True


def converge(b, i, state, iterations, skel, terms, scratch, axes, lm, q, lv, rw, frames_ready, halt):
    """polish() when every weighted goal has a tolerance. LM runs on a copy of the individual
    (lm.pose and its levels and raw errors) and keeps a step when it lowers the cost LM
    minimises, the polished goals' squared errors in tolerances (polished_cost), without
    worsening a higher level or an unpolished goal (keeps_the_rest): judged by the fitness
    instead, which weighs errors by distance scales, not tolerances, a step LM proposes was
    often refused and the damping grew until the search stalled. It stops at every tolerance
    met, after `iterations`, or when the cost has not halved in STALL_ITERATIONS iterations (a
    start stuck at a joint limit or in a local minimum: a restart is cheaper). The individual
    takes the result only if it meets every tolerance or is better by strict priority, so the
    polish never makes a population worse."""
    pop, levels, total, raw = state.pop, state.levels, state.total, state.raw
    D, T = pop.shape[2], raw.shape[2]
    limits, x, pose_levels, pose_raw = skel.limits, lm.pose, lm.pose_levels, lm.pose_raw
    for d in range(D):
        x[d] = pop[b, i, d]
    for lvl in range(levels.shape[2]):
        pose_levels[lvl] = levels[b, i, lvl]
    for t in range(T):
        pose_raw[t] = raw[b, i, t]
    pose_total = total[b, i]
    top = first_unmet_level(levels[b, i])
    cost = polished_cost(b, pose_raw, terms, top)
    m = polished_rows(b, terms, top)
    dual = m < D  # fewer residual rows than DOFs: solve m x m (dual_step)
    anchor, since = cost, 0
    damping = REDUNDANT_DAMPING if m <= D else DAMPING  # square systems too: see DAMPING
    met = within_tolerances(b, pose_raw, terms, T)
    # the normal equations change only when a step is kept; a kept step's frames (computed with
    # the axes, to score it) are then the new pose's, so each iteration runs one FK
    formed = False
    for _ in range(iterations):
        if met or cost == 0.0 or since >= STALL_ITERATIONS or halt[0] != 0:
            break  # (a zero cost leaves nothing the polish can move: the unmet goals are DE's)
        since += 1
        if not formed:
            if dual:
                jacobian_rows(x, b, top, m, skel, terms, scratch, axes, lm, D, frames_ready)
            else:
                normal_equations(x, b, top, skel, terms, scratch, axes, lm, D, frames_ready)
            formed = True
        if dual_step(lm, D, m, damping, x, limits, halt) if dual else damped_step(lm, D, damping, x, limits, halt):
            for d in range(D):
                q[d] = into_limits(x[d] + lm.delta[d], limits, d)
            forward_kinematics(q, skel, scratch.R, scratch.p, scratch.work, axes, True)
            tot = score(q, b, skel, terms, scratch, lv, rw)
            trial_cost = polished_cost(b, rw, terms, top)
            if trial_cost < cost and keeps_the_rest(b, lv, rw, pose_levels, pose_raw, terms, top):
                keep_pose(x, pose_levels, pose_raw, q, lv, rw)
                pose_total, cost = tot, trial_cost
                met = within_tolerances(b, rw, terms, T)
                if cost < 0.5 * anchor:
                    anchor, since = cost, 0
                damping = max(damping * 0.3, 1e-7)
                formed, frames_ready = False, True
                continue
        damping *= 10.0
        if damping > MAX_DAMPING:
            break
    if met or improves(pose_levels, pose_total, levels[b, i], total[b, i]):
        keep_trial(state, b, i, x, pose_levels, pose_raw, pose_total, state.rates[b, i])


def keep_pose(x, pose_levels, pose_raw, q, lv, rw):
    """Copy a kept step's pose q, levels lv and raw errors rw into the polished copy."""
    for d in range(x.shape[0]):
        x[d] = q[d]
    for lvl in range(pose_levels.shape[0]):
        pose_levels[lvl] = lv[lvl]
    for t in range(pose_raw.shape[0]):
        pose_raw[t] = rw[t]


def relax(b, i, state, iterations, skel, terms, scratch, axes, lm, q, lv, rw, frames_ready, halt):
    """polish() when a goal without tolerance (comfort) is left to improve: LM steps in place,
    each kept only if the full strict-priority fitness improves (so the polish never trades a
    higher level for a lower one), every step with a pull towards comfort's reference in the
    polished goals' null space (comfort_step)."""
    pop, levels, total = state.pop, state.levels, state.total
    D = pop.shape[2]
    limits = skel.limits
    top = first_unmet_level(levels[b, i])
    damping = 1e-3
    pull = 1.0
    # the normal equations change only when a step is kept; a kept step's frames (computed with
    # the axes, to score it) are then the new pose's, so each iteration runs one FK
    formed = False
    for _ in range(iterations):
        if halt[0] != 0:
            return
        if not formed:
            normal_equations(pop[b, i], b, top, skel, terms, scratch, axes, lm, D, frames_ready)
            formed = True
        pulled = False
        if damped_step(lm, D, damping, pop[b, i], limits, halt):
            if pull > 0.0:
                pulled = comfort_step(b, pop[b, i], terms, lm, D, pull, limits, halt)
            delta = lm.delta
            for d in range(D):
                q[d] = into_limits(pop[b, i, d] + delta[d], limits, d)
            forward_kinematics(q, skel, scratch.R, scratch.p, scratch.work, axes, True)
            tot = score(q, b, skel, terms, scratch, lv, rw)
            if improves(lv, tot, levels[b, i], total[b, i]):
                keep_trial(state, b, i, q, lv, rw, tot, state.rates[b, i])
                damping = max(damping * 0.3, 1e-7)
                pull = min(2.0 * pull, 1.0)
                formed, frames_ready = False, True
                continue
        if pulled and pull > _MIN_PULL:
            pull *= 0.25  # first a shorter pull towards the reference, then more damping
            continue
        damping *= 10.0
        if damping > MAX_DAMPING:
            return

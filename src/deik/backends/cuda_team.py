"""The first polish with a team of GPU threads per problem (GPU only; numba-cuda).

`first_polish_team` does what cuda_kernels.first_polish does, with TEAM_LANES threads per
problem and many problems per block. What is sequential along the chain, the forward
kinematics, the scoring and the LM's decisions, every lane runs alike on its own scratch, so no
lane waits for another and every lane knows the pose, the cost and the damping. The rest is
split by DOF, lane l taking the DOFs d with d % TEAM_LANES == l:

- the columns of each term's three Jacobian rows (device_polish.term_rows walks the joints from
  the goal's frame to the root and forms only the lane's columns), into the team's shared rows,
- the rows of the normal matrix J^T J and of the gradient J^T r, or with fewer residual rows
  than DOFs, the columns of J, the elements of the m x m matrix I + J Lambda^-1 J^T and the
  step's entries,
- the entries below each pivot of the Cholesky factorisation, and the substitutions.

The polish's matrices (the damped and undamped D x D, the gradient, the step and three work
vectors that hold a term's Jacobian rows while the system is formed) live in shared memory: one
array of TEAM_SHARED_FLOATS per block, carved into a slab per team for the skeleton's D
(team_floats), so a 7-DOF arm fits 16 problems in a block of 128 threads and a 32-DOF skeleton
one. Skeletons of more DOFs (fits() is False) keep the thread-per-problem kernel, and so do goal
tables with a goal without tolerance (comfort: device_lm.relax).

Every element is summed in the order device_lm sums it for a thread alone, so in float64 a team
gives the same bits as a thread alone, and as the CPU (the CUDA simulator checks it). The lanes
meet at cuda.syncthreads() barriers, every thread of a block at every barrier: the loops that hold
a barrier run the same count in every team (the skeleton's D, the term count, the LM's
iterations), a team with nothing to do in a phase passes its barriers idle, and the block leaves
the LM's loop once no team is still polishing (syncthreads_or).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from deik.backends import targets
from deik.backends.cuda_kernels import carve_scratch, take, write_answer
from deik.backends.gpu import numba_cuda, simulated
from deik.device.layout import LmScratch
from deik.device.lm import DAMPING, DAMPING_FLOOR, MAX_DAMPING, REDUNDANT_DAMPING, STALL_ITERATIONS
from deik.objectives.kinds import TERM_KIND, TERM_LEVEL

cuda = numba_cuda()
targets.register_cuda_kernel_cache()

if TYPE_CHECKING:  # what a reader's go-to-definition reaches: the device maths as plain Python
    from deik.device import driver as device_driver
    from deik.device import evolution as device_evolution
    from deik.device import lm as device_lm
    from deik.device import maths as device_maths
    from deik.device import polish as device_polish
    from deik.device import terms as device_terms
else:  # what runs: the same functions compiled with cuda.jit(device=True) (deik.backends.targets)
    device_driver = device_evolution = device_lm = device_maths = device_polish = device_terms = targets.cuda_device()

TEAM_LANES = 8  # threads per problem (a power of two: lane l takes the DOFs d with d & LANE_MASK == l)
LANE_MASK = TEAM_LANES - 1
MAX_TEAMS_PER_BLOCK = 16  # 128 threads
TEAM_MAX_DOFS = 32  # the most DOFs a team polishes; beyond, the thread-per-problem kernel


def team_floats(D: int) -> int:
    """Shared floats of one team's slab: A and the normal matrix (D*D each), the gradient, three
    work vectors (a term's Jacobian rows; then the damping's inverse and diagonal, the Cholesky
    pivots) and the step (D, 3D, D)."""
    return 2 * D * D + 5 * D


TEAM_SHARED_FLOATS = team_floats(TEAM_MAX_DOFS)  # one block's shared array (17 KB in float64)
# the register cap evolve has, for the same polish code: four blocks of 128 threads (64 problems of
# a 7-DOF arm) resident per multiprocessor
TEAM_REGISTERS = 128
TEAM_OPTIONS = {} if simulated() else {"max_registers": TEAM_REGISTERS}  # the simulator takes no cap


def fits(D: int) -> bool:
    """Does a team polish a skeleton of D DOFs (its slab fits the block's shared array)?"""
    return 0 < D <= TEAM_MAX_DOFS


def teams_per_block(D: int) -> int:
    """Problems one block polishes side by side for a skeleton of D DOFs (fits(D))."""
    return max(1, min(MAX_TEAMS_PER_BLOCK, TEAM_SHARED_FLOATS // team_floats(D)))


@cuda.jit(device=True)
def first_owned(start, lane):
    """The first index >= start that lane owns (index & LANE_MASK == lane)."""
    return start + ((lane - start) & LANE_MASK)


@cuda.jit(device=True)
def team_lm(slab, lm, D):
    """The LmScratch of a team: A, the normal matrix, the gradient, the work vectors (in `jac`:
    a term's Jacobian rows while the system is formed) and the step in the team's shared slab;
    the polished pose, its levels and raw errors the lane's own."""
    A, o = take(slab, 0, D * D)
    normal, o = take(slab, o, D * D)
    gradient, o = take(slab, o, D)
    jac, o = take(slab, o, 3 * D)
    delta, o = take(slab, o, D)
    return LmScratch(A, normal, gradient, jac, delta, lm.pose, lm.pose_levels, lm.pose_raw)


@cuda.jit(device=True)
def team_system(b, top, m, skel, terms, scratch, axes, lm, D, lane, work):
    """The LM's system at the pose whose frames every lane holds, by a team. Each term's three
    Jacobian rows are formed in the team's shared lm.jac (3*D,), every lane its own columns
    (device_polish.term_rows with the lane's mask). With m < D rows (device_lm.jacobian_rows):
    a lane copies its columns into J (m, D) in lm.normal, r (m,) goes to lm.A[m*m:m*m+m], then
    J^T r by lane. Else (device_lm.normal_equations): a lane adds its rows of J^T J and J^T r,
    reading every column of the term. Two barriers a polished kind of term and one more, alike
    in every team (the goal table is the block's); `work` False: the barriers only."""
    R, p, term_int = scratch.R, scratch.p, terms.term_int
    rows, normal, gradient, r = lm.jac, lm.normal, lm.gradient, lm.A[m * m : m * m + m]
    dual = m < D
    cx, cy, cz = 0.0, 0.0, 0.0
    if work:
        if device_terms.uses_centre_of_mass(term_int):
            cx, cy, cz = device_maths.centre_of_mass(skel, R, p)
        if not dual:
            for a in range(lane, D, TEAM_LANES):
                for c in range(D):
                    normal[a * D + c] = 0.0
                gradient[a] = 0.0
    row = 0
    for t in range(term_int.shape[0]):
        if not device_polish.is_polished(term_int[t, TERM_KIND]):
            continue  # alike in every team: no rows, no barrier
        formed = work and term_int[t, TERM_LEVEL] <= top and (not dual or device_terms.weight_of(terms, b, t) > 0.0)
        r0, r1, r2 = 0.0, 0.0, 0.0
        if formed:
            r0, r1, r2 = device_polish.term_rows(t, b, skel, terms, R, p, cx, cy, cz, axes, rows, D, lane, LANE_MASK)
        if formed and dual:  # J's columns are the lane's own: no other lane's needed
            for k in range(3):
                for d in range(lane, D, TEAM_LANES):
                    normal[(row + k) * D + d] = rows[k * D + d]
            if lane == 0:
                r[row], r[row + 1], r[row + 2] = r0, r1, r2
            row += 3
        cuda.syncthreads()  # every column of the term's rows formed
        if formed and not dual:
            for k in range(3):
                rk = r0 if k == 0 else (r1 if k == 1 else r2)
                for a in range(lane, D, TEAM_LANES):
                    ja = rows[k * D + a]
                    if ja != 0.0:
                        gradient[a] += ja * rk
                        for c in range(D):
                            normal[a * D + c] += ja * rows[k * D + c]
        cuda.syncthreads()  # every lane has read the rows the next term overwrites
    if work and dual:  # r (lane 0's) was written before the loop's last barrier
        for d in range(lane, D, TEAM_LANES):
            g = 0.0
            for k in range(m):
                g += normal[k * D + d] * r[k]
            gradient[d] = g
    cuda.syncthreads()


@cuda.jit(device=True)
def team_dual_system(lm, D, m, damping, q, limits, lane, work):
    """device_lm.dual_step up to its factorisation, by a team: the damping diagonal's inverse
    (lm.jac[0:D]), the m x m matrix I + J Lambda^-1 J^T in lm.A (elements by lane) and its
    right-hand side y. 3 barriers; `work` False: the barriers only."""
    J, A, gradient = lm.normal, lm.A, lm.gradient
    inverse, diagonal = lm.jac[0:D], lm.jac[D : 2 * D]
    r, y = A[m * m : m * m + m], A[m * m + m : m * m + 2 * m]
    if work:
        for d in range(lane, D, TEAM_LANES):
            s = 0.0
            for k in range(m):
                s += J[k * D + d] * J[k * D + d]
            diagonal[d] = s
    cuda.syncthreads()
    if work:
        peak = 0.0
        for d in range(D):
            peak = max(peak, diagonal[d])
        for d in range(lane, D, TEAM_LANES):
            if device_lm.held_at_limit(q[d], -gradient[d], limits, d):
                inverse[d] = 0.0
            else:
                inverse[d] = 1.0 / (damping * max(diagonal[d], DAMPING_FLOOR * peak) + 1e-9 * peak + 1e-30)
    cuda.syncthreads()
    if work:
        e = 0
        for i in range(m):
            for k in range(i + 1):
                if e & LANE_MASK == lane:
                    v = 1.0 if i == k else 0.0
                    for d in range(D):
                        v += J[i * D + d] * inverse[d] * J[k * D + d]
                    A[i * m + k] = v
                e += 1
            if lane == 0:
                y[i] = r[i]
    cuda.syncthreads()


@cuda.jit(device=True)
def team_dual_finish(lm, D, m, lane, work):
    """device_lm.dual_step after its solve: the step delta = -Lambda^-1 J^T y, by lane. 1 barrier."""
    J, A, inverse, delta = lm.normal, lm.A, lm.jac[0:D], lm.delta
    y = A[m * m + m : m * m + 2 * m]
    if work:
        for d in range(lane, D, TEAM_LANES):
            v = 0.0
            for k in range(m):
                v += J[k * D + d] * y[k]
            delta[d] = -inverse[d] * v
    cuda.syncthreads()


@cuda.jit(device=True)
def team_damped_system(lm, D, damping, q, limits, lane, work):
    """device_lm.damped_step up to its factorisation, by a team: A = N + damping diag(N) by
    rows, delta = -gradient, DOFs held at their limits cut out. 2 barriers; `work` False: the
    barriers only."""
    A, normal, gradient, delta = lm.A, lm.normal, lm.gradient, lm.delta
    if work:
        peak = 0.0
        for a in range(D):
            peak = max(peak, normal[a * D + a])
        for a in range(lane, D, TEAM_LANES):
            for c in range(D):
                A[a * D + c] = normal[a * D + c]
            A[a * D + a] += damping * max(A[a * D + a], DAMPING_FLOOR * peak) + 1e-9 * peak + 1e-30
            delta[a] = -gradient[a]
    cuda.syncthreads()
    if work:
        for a in range(lane, D, TEAM_LANES):
            if device_lm.held_at_limit(q[a], -gradient[a], limits, a):
                for c in range(D):
                    A[a * D + c] = 0.0
                    A[c * D + a] = 0.0
                A[a * D + a] = 1.0
                delta[a] = 0.0
    cuda.syncthreads()


@cuda.jit(device=True)
def team_cholesky(A, n, N, halt, pivots, lane, work):
    """device_lm.cholesky of the n x n matrix A by a team: column j's entries below the pivot by
    lane, one barrier a column (N >= n columns, the same in every team); the pivots wait in
    pivots (n,) until every lane has read the diagonal. Returns whether A was positive definite
    (and the host's stop flag unset), alike in every lane."""
    ok = work
    for j in range(N):
        if ok and j < n:
            if halt[0] != 0:
                ok = False
            else:
                s = A[j * n + j]
                for k in range(j):
                    s -= A[j * n + k] * A[j * n + k]
                if not s > 0.0:
                    ok = False
                else:
                    s = math.sqrt(s)
                    if j & LANE_MASK == lane:
                        pivots[j] = s
                    for i in range(first_owned(j + 1, lane), n, TEAM_LANES):
                        v = A[i * n + j]
                        for k in range(j):
                            v -= A[i * n + k] * A[j * n + k]
                        A[i * n + j] = v / s
        cuda.syncthreads()
    if ok:
        for j in range(lane, n, TEAM_LANES):
            A[j * n + j] = pivots[j]
    cuda.syncthreads()
    return ok


@cuda.jit(device=True)
def team_solve(A, x, solved, n, N, lane, work):
    """device_lm.cholesky_solve by a team: x <- (L L^T)^-1 x for the factor in A (n x n). Forward
    by columns (lanes update their entries below each solved one, in the order a thread alone
    subtracts), the solved entries kept in solved (n,); backward by rows. 2 N barriers."""
    for i in range(N):
        if work and i < n:
            xi = x[i] / A[i * n + i]
            if i & LANE_MASK == lane:
                solved[i] = xi
            for k in range(first_owned(i + 1, lane), n, TEAM_LANES):
                x[k] -= A[k * n + i] * xi
        cuda.syncthreads()
    for i in range(N - 1, -1, -1):
        if work and i < n and i & LANE_MASK == lane:
            v = solved[i]
            for k in range(i + 1, n):
                v -= A[k * n + i] * x[k]
            x[i] = v / A[i * n + i]
        cuda.syncthreads()


@cuda.jit(device=True)
def team_step(lm, D, m, damping, x, limits, halt, lane, work):
    """One LM step from the formed system, by a team: device_lm.dual_step when m < D rows, else
    device_lm.damped_step, into lm.delta. Returns whether it succeeded (alike in every lane)."""
    dual = m < D
    team_dual_system(lm, D, m, damping, x, limits, lane, work and dual)
    team_damped_system(lm, D, damping, x, limits, lane, work and not dual)
    n = m if dual else D
    rhs = lm.A[m * m + m : m * m + 2 * m] if dual else lm.delta
    pivots = lm.jac[2 * D : 3 * D]
    ok = team_cholesky(lm.A, n, D, halt, pivots, lane, work)
    team_solve(lm.A, rhs, pivots, n, D, lane, work and ok)
    team_dual_finish(lm, D, m, lane, work and ok and dual)
    return ok


@cuda.jit(device=True)
def team_converge(b, state, iterations, skel, terms, scratch, axes, lm, q, lv, rw, halt, lane, live):
    """device_lm.converge of individual 0 of problem b by a team (its frames ready in every
    lane's scratch), step for step; `live` False: a team without a problem, at the barriers."""
    pop, levels, total, raw = state.pop, state.levels, state.total, state.raw
    D, T = pop.shape[2], raw.shape[2]
    limits, x, pose_levels, pose_raw = skel.limits, lm.pose, lm.pose_levels, lm.pose_raw
    for d in range(D):
        x[d] = pop[b, 0, d]
    for lvl in range(levels.shape[2]):
        pose_levels[lvl] = levels[b, 0, lvl]
    for t in range(T):
        pose_raw[t] = raw[b, 0, t]
    pose_total = total[b, 0]
    top = device_lm.first_unmet_level(levels[b, 0])
    cost = device_lm.polished_cost(b, pose_raw, terms, top)
    m = device_lm.polished_rows(b, terms, top)
    dual = m < D
    anchor, since = cost, 0
    damping = REDUNDANT_DAMPING if dual else DAMPING
    met = device_evolution.within_tolerances(b, pose_raw, terms, T)
    formed, done = False, not live
    for _ in range(iterations):
        if not done and (met or cost == 0.0 or since >= STALL_ITERATIONS or halt[0] != 0):
            done = True
        if not cuda.syncthreads_or(0 if done else 1):
            break  # every team of the block has finished
        working = not done
        form = working and not formed
        team_system(b, top, m, skel, terms, scratch, axes, lm, D, lane, form)
        if working:
            since += 1
            formed = True
        stepped = team_step(lm, D, m, damping, x, limits, halt, lane, working)
        kept = False
        if stepped:
            for d in range(D):
                q[d] = device_lm.into_limits(x[d] + lm.delta[d], limits, d)
            device_maths.forward_kinematics(q, skel, scratch.R, scratch.p, scratch.work, axes, True)
            tot = device_terms.score(q, b, skel, terms, scratch, lv, rw)
            trial_cost = device_lm.polished_cost(b, rw, terms, top)
            if trial_cost < cost and device_lm.keeps_the_rest(b, lv, rw, pose_levels, pose_raw, terms, top):
                device_lm.keep_pose(x, pose_levels, pose_raw, q, lv, rw)
                pose_total, cost = tot, trial_cost
                met = device_evolution.within_tolerances(b, rw, terms, T)
                if cost < 0.5 * anchor:
                    anchor, since = cost, 0
                damping = max(damping * 0.3, 1e-7)
                formed, kept = False, True
        if working and not kept:  # (a kept step's frames, in every lane's scratch, are the new pose's)
            damping *= 10.0
            if damping > MAX_DAMPING:
                done = True
    keep = live and (met or device_lm.improves(pose_levels, pose_total, levels[b, 0], total[b, 0]))
    cuda.syncthreads()  # every lane has read the individual
    if keep and lane == 0:
        device_evolution.keep_trial(state, b, 0, x, pose_levels, pose_raw, pose_total, state.rates[b, 0])
    cuda.syncthreads()


@cuda.jit(cache=True, **TEAM_OPTIONS)
def first_polish_team(cur, status, skel, terms, settings, schedule, rules, initial, n_initial, unmet, answers, pool):
    """cuda_kernels.first_polish with a team of TEAM_LANES threads per problem and
    blockDim.x // TEAM_LANES problems per block (grid-stride over groups of them); pool
    (thread_rows, blocks * threads): each lane's own scratch column. For goal tables whose every
    weighted goal has a tolerance (device_lm.converge)."""
    B, P, D = cur.pop.shape[0], cur.pop.shape[1], cur.pop.shape[2]
    L, T = cur.levels.shape[2], cur.raw.shape[2]
    tid = cuda.threadIdx.x
    team, lane, teams = tid // TEAM_LANES, tid & LANE_MASK, cuda.blockDim.x // TEAM_LANES
    shared = cuda.shared.array(TEAM_SHARED_FLOATS, pool.dtype)
    size = 2 * D * D + 5 * D  # team_floats(D)
    column = pool[:, cuda.blockIdx.x * cuda.blockDim.x + tid]
    slab = shared[team * size : (team + 1) * size]
    scratch, axes, q, _, lv, rw, own = carve_scratch(column, slab, skel, D, L, T)
    lm = team_lm(slab, own, D)
    for first in range(cuda.blockIdx.x * teams, B, cuda.gridDim.x * teams):
        live = first + team < B
        b = min(first + team, B - 1)  # a team past the last problem reads the last one and writes nothing
        # one lane writes the team's individual (scores accumulate in place: two lanes adding
        # into one array would count a term twice), every lane then has its frames and scores
        if live and lane == 0:
            device_driver.seed_individual(b, 0, cur, skel, settings, initial, n_initial)
        cuda.syncthreads()  # the seeded pose, before any lane reads it
        if live:
            device_maths.forward_kinematics(cur.pop[b, 0], skel, scratch.R, scratch.p, scratch.work, axes, True)
            if lane == 0:
                cur.total[b, 0] = device_terms.score(
                    cur.pop[b, 0], b, skel, terms, scratch, cur.levels[b, 0], cur.raw[b, 0]
                )
            else:
                device_terms.score(cur.pop[b, 0], b, skel, terms, scratch, lv, rw)
        cuda.syncthreads()  # the individual's scores, before any lane reads them
        iterations = device_evolution.first_polish_iterations(schedule)
        team_converge(b, cur, iterations, skel, terms, scratch, axes, lm, q, lv, rw, status.halt, lane, live)
        met = live and device_evolution.within_tolerances(b, cur.raw[b, 0], terms, T)
        if met:
            for i in range(1 + lane, P, TEAM_LANES):
                device_evolution.copy_individual(cur, cur, b, 0, i)
        cuda.syncthreads()
        if live and lane == 0:
            if met:
                device_evolution.rank_first(b, cur, status)
                device_evolution.settle_after_polish(b, 0, cur, terms, status, rules, False)
                write_answer(b, b, 0, cur, status, answers)
            else:
                unmet[int(cuda.atomic.add(answers, (B, 0), 1.0))] = b
        cuda.syncthreads()

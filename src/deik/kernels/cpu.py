"""CPU kernels: the parallel ping-pong DE of Figure 1 with numba prange.

Every generation reads the current buffers (pop, levels, total, raw) and writes the next;
individuals are split into chunks, one scratch allocation per chunk. Results do not depend on
the thread count: each individual's trial depends only on (seed, problem, generation,
individual) and the current population, and the per-problem bookkeeping runs in index order.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from deik.kernels.targets import cpu as dev

INIT_GENERATION = -1


@njit(cache=True)
def _scratch(skel, dtype_probe, n_terms, n_levels, n_dofs):
    frames = skel[0].shape[0] + skel[4].shape[0]
    R = np.empty(frames * 9, dtype_probe.dtype)
    p = np.empty(frames * 3, dtype_probe.dtype)
    work = np.empty(32, dtype_probe.dtype)
    return (R, p, work), np.empty(n_dofs, dtype_probe.dtype), np.empty(n_levels, dtype_probe.dtype), \
        np.empty(n_terms, dtype_probe.dtype)


@njit(cache=True)
def _polish_scratch(skel, dtype_probe, n_dofs):
    """(axes (N*6,), lm = (A, gradient, jac, delta)) for device.polish."""
    D, t = n_dofs, dtype_probe.dtype
    lm = (np.empty(D * D, t), np.empty(D, t), np.empty(3 * D, t), np.empty(D, t))
    return np.empty(6 * skel[2].shape[0], t), lm


@njit(parallel=True, cache=True)
def initialise(pop, levels, total, raw, rates, skel, terms, settings, initial, n_initial, n_chunks):
    """Fill pop (B, P, D) uniformly inside the limits (the first n_initial individuals of each
    problem copy initial (B, n_initial, D)), set every individual's F, CR (rates (B, P, 2)) to
    the settings' and evaluate it. n_chunks: work units (a few per thread); it changes the
    split of work, never the result."""
    B, P, D = pop.shape
    limits, seed = skel[8], settings[4]
    n = B * P
    n_chunks = max(1, min(n, n_chunks))
    for c in prange(n_chunks):
        scratch, _, lv, rw = _scratch(skel, pop, raw.shape[2], levels.shape[2], D)
        for idx in range(c * n // n_chunks, (c + 1) * n // n_chunks):
            b, i = idx // P, idx % P
            for d in range(D):
                if i < n_initial:
                    pop[b, i, d] = initial[b, i, d]
                else:
                    u = dev.uniform(seed, b, INIT_GENERATION, i, d)
                    pop[b, i, d] = limits[d, 0] + (limits[d, 1] - limits[d, 0]) * u
            rates[b, i, 0], rates[b, i, 1] = settings[2], settings[3]
            total[b, i] = dev.evaluate(pop[b, i], b, skel, terms, scratch, levels[b, i], raw[b, i])


@njit(parallel=True, cache=True)
def run_generations(cur, nxt, skel, terms, settings, memetic, status, control, history, gen_start, n_gens, n_chunks):
    """Run up to n_gens generations; returns how many buffer swaps happened (the final state
    lies in `cur` when even, in `nxt` when odd). cur/nxt = (pop, levels, total, raw, rates).
    memetic = (LM iterations, every how many generations, individuals per problem)."""
    B, P, D = cur[0].shape
    limits = skel[8]
    best, active, restarting, leader = status[0], status[1], status[7], status[9]
    island_size = P // settings[6]
    iterations, every, count = memetic
    n = B * P
    n_chunks = max(1, min(n, n_chunks))
    swaps = 0
    for g in range(n_gens):
        gen = gen_start + g
        any_active = False
        for b in range(B):
            any_active = any_active or active[b]
        if not any_active:
            break
        pop, levels, rates = cur[0], cur[1], cur[4]
        for c in prange(n_chunks):
            scratch, trial, lv, rw = _scratch(skel, pop, cur[3].shape[2], levels.shape[2], D)
            trial_rates = np.empty(2, pop.dtype)
            for idx in range(c * n // n_chunks, (c + 1) * n // n_chunks):
                b, i = idx // P, idx % P
                accept = False
                tot = 0.0
                if active[b]:
                    dev.make_trial(pop, rates, b, i, leader[b, i // island_size], gen, settings, limits, trial, trial_rates, restarting[b])
                    tot = dev.evaluate(trial, b, skel, terms, scratch, lv, rw)
                    accept = i != best[b] if restarting[b] else dev.not_worse(lv, levels[b, i])
                if accept:
                    dev.keep_trial(nxt, b, i, trial, lv, rw, tot, trial_rates)
                else:
                    dev.copy_individual(cur, nxt, b, i)
        cur, nxt = nxt, cur
        swaps += 1
        if iterations > 0 and gen % every == 0:
            _polish_round(cur, skel, terms, status, memetic, n_chunks)
        for b in range(B):
            if active[b]:
                dev.update_status(b, gen, cur, terms, status, control, history)
    return swaps


@njit(parallel=True, cache=True)
def _polish_round(state, skel, terms, status, memetic, n_chunks):
    """LM-polish `count` individuals of every active problem in place (device.polish)."""
    B, P, D = state[0].shape
    active, leader = status[1], status[9]
    iterations, _, count = memetic
    n = B * count
    n_chunks = max(1, min(n, n_chunks))
    for c in prange(n_chunks):
        scratch, q, lv, rw = _scratch(skel, state[0], state[3].shape[2], state[1].shape[2], D)
        axes, lm = _polish_scratch(skel, state[0], D)
        for job in range(c * n // n_chunks, (c + 1) * n // n_chunks):
            b, k = job // count, job % count
            if active[b]:
                i = dev.polish_target(leader[b], k, count, P)
                dev.polish(b, i, state, iterations, skel, terms, scratch, axes, lm, q, lv, rw)


@njit(parallel=True, cache=True)
def evaluate_poses(poses, problem_index, skel, terms, levels, total, raw):
    """Evaluate poses (N, D), pose n against problem problem_index[n]; fills levels (N, L),
    total (N,), raw (N, T)."""
    N, D = poses.shape
    for n in prange(N):
        scratch, _, _, _ = _scratch(skel, poses, raw.shape[1], levels.shape[1], D)
        total[n] = dev.evaluate(poses[n], problem_index[n], skel, terms, scratch, levels[n], raw[n])


@njit(parallel=True, cache=True)
def forward_kinematics_batch(poses, skel, R, p):
    """World frames of poses (N, D) -> R (N, F*9), p (N, F*3) with the kernel's own FK."""
    for n in prange(poses.shape[0]):
        work = np.empty(32, poses.dtype)
        dev.forward_kinematics(poses[n], skel, R[n], p[n], work, work, False)


@njit(cache=True)
def residual_rows(poses, problem_index, term, skel, terms):
    """The LM polish's scaled residual (N, 3) of one term and its analytic Jacobian (N, 3, D)
    at poses (N, D) (zeros for terms the polish leaves to DE)."""
    N, D = poses.shape
    residual, jacobian = np.zeros((N, 3), poses.dtype), np.zeros((N, 3, D), poses.dtype)
    scratch, _, _, _ = _scratch(skel, poses, 1, 1, D)
    axes, lm = _polish_scratch(skel, poses, D)
    jac = lm[2]
    for n in range(N):
        R, p, work = scratch
        dev.forward_kinematics(poses[n], skel, R, p, work, axes, True)
        cx, cy, cz = dev.centre_of_mass(skel, R, p)
        residual[n, 0], residual[n, 1], residual[n, 2] = dev.term_rows(term, problem_index[n], skel, terms, R, p, cx, cy, cz, axes, jac, D)
        for row in range(3):
            for d in range(D):
                jacobian[n, row, d] = jac[row * D + d]
    return residual, jacobian

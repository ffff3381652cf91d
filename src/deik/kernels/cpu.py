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


@njit(parallel=True, cache=True)
def initialise(pop, levels, total, raw, skel, terms, seed, initial, n_initial, n_chunks):
    """Fill pop (B, P, D) uniformly inside the limits (the first n_initial individuals of each
    problem copy initial (B, n_initial, D)) and evaluate it. n_chunks: work units (a few per
    thread); it changes the split of work, never the result."""
    B, P, D = pop.shape
    limits = skel[8]
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
            total[b, i] = dev.evaluate(pop[b, i], b, skel, terms, scratch, levels[b, i], raw[b, i])


@njit(parallel=True, cache=True)
def run_generations(cur, nxt, skel, terms, settings, status, control, history, gen_start, n_gens, n_chunks):
    """Run up to n_gens generations; returns how many buffer swaps happened (the final state
    lies in `cur` when even, in `nxt` when odd). cur/nxt = (pop, levels, total, raw)."""
    B, P, D = cur[0].shape
    limits = skel[8]
    best, active = status[0], status[1]
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
        pop, levels, raw = cur[0], cur[1], cur[3]
        npop, nlevels, ntotal, nraw = nxt
        for c in prange(n_chunks):
            scratch, trial, lv, rw = _scratch(skel, pop, raw.shape[2], levels.shape[2], D)
            for idx in range(c * n // n_chunks, (c + 1) * n // n_chunks):
                b, i = idx // P, idx % P
                accept = False
                tot = 0.0
                if active[b]:
                    dev.make_trial(pop, b, i, best[b], gen, settings, limits, trial)
                    tot = dev.evaluate(trial, b, skel, terms, scratch, lv, rw)
                    accept = dev.not_worse(lv, levels[b, i])
                if accept:
                    npop[b, i, :] = trial
                    nlevels[b, i, :] = lv
                    nraw[b, i, :] = rw
                    ntotal[b, i] = tot
                else:
                    dev.copy_individual(cur, nxt, b, i)
        cur, nxt = nxt, cur
        swaps += 1
        for b in range(B):
            if active[b]:
                dev.update_status(b, gen, cur, terms, status, control, history)
    return swaps


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
        dev.forward_kinematics(poses[n], skel, R[n], p[n], work)

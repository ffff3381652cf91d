"""Device maths, part 3: DE trial vectors, strict-priority comparison, per-problem bookkeeping.

Compiled together with device_maths.py and device_terms.py (see deik.kernels.targets).
"""

import math

_TWO_PI = 2.0 * math.pi
_JDE_REDRAW = 0.1
_JDE_F_MIN = 0.1


def not_worse(candidate, incumbent):
    """Strict priority: are the candidate's levels at least as good as the incumbent's
    (lexicographic)? The incumbent's length is the level count (GPU scratch is padded)."""
    for lv in range(incumbent.shape[0]):
        if candidate[lv] < incumbent[lv]:
            return True
        if candidate[lv] > incumbent[lv]:
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


def make_trial(pop, rates, b, i, best, gen, settings, limits, trial, trial_rates, restart):
    """DE trial vector for individual i of problem b (Figure 1: reads only the current
    population) and the F, CR it used (trial_rates); `best` is the leader of i's island, whose
    members are its only donors. settings = (strategy, limit_mode, F, CR, seed, adaptive,
    islands). Strategies: 0 rand/1/bin, 1 best/1/bin, 2 current-to-best/1/bin. Limit
    modes: 0 reflect, 1 clip, 2 penalty (genes may leave their limits; a top-priority term
    penalises it), 3 the paper's Algorithm 2. adaptive (jDE): each individual carries its own
    F and CR in rates (B, P, 2), redrawn with probability 0.1 (F in [0.1, 1], CR in [0, 1]) and
    inherited by the trial when it is accepted. restart: a uniform random pose instead."""
    strategy, limit_mode, F, CR, seed, adaptive, islands = settings
    P, D = pop.shape[1], pop.shape[2]
    size = P // islands
    base = (i // size) * size
    if restart:
        for d in range(D):
            trial[d] = limits[d, 0] + (limits[d, 1] - limits[d, 0]) * uniform(seed, b, gen, i, 4 + d)
        trial_rates[0], trial_rates[1] = F, CR
        return
    f, cr = F, CR
    if adaptive:
        f, cr = rates[b, i, 0], rates[b, i, 1]
        if uniform(seed, b, gen, i, 4 + D) < _JDE_REDRAW:
            f = _JDE_F_MIN + (1.0 - _JDE_F_MIN) * uniform(seed, b, gen, i, 5 + D)
        if uniform(seed, b, gen, i, 6 + D) < _JDE_REDRAW:
            cr = uniform(seed, b, gen, i, 7 + D)
    trial_rates[0], trial_rates[1] = f, cr
    r1 = donor(size, i - base, 0, 0, 1, seed, b, gen, i, 0)
    r2 = donor(size, i - base, r1, 0, 2, seed, b, gen, i, 1)
    r3 = donor(size, i - base, r1, r2, 3, seed, b, gen, i, 2)
    r1, r2, r3 = r1 + base, r2 + base, r3 + base
    forced = randint(D, seed, b, gen, i, 3)
    for d in range(D):
        if d == forced or uniform(seed, b, gen, i, 4 + d) < cr:
            if strategy == 0:
                v = pop[b, r1, d] + f * (pop[b, r2, d] - pop[b, r3, d])
            elif strategy == 1:
                v = pop[b, best, d] + f * (pop[b, r1, d] - pop[b, r2, d])
            else:
                v = pop[b, i, d] + f * (pop[b, best, d] - pop[b, i, d]) + f * (pop[b, r1, d] - pop[b, r2, d])
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


def polish_target(leaders, k, count, P):
    """The k-th of `count` distinct individuals a polish round refines: each island's leader
    first (leaders (islands,)), then individuals spread evenly around each island from it."""
    islands = leaders.shape[0]
    island, size = k % islands, P // islands
    per_island = (count + islands - 1) // islands
    base = island * size
    return base + (leaders[island] - base + (k // islands) * size // per_island) % size


def copy_individual(source, target, b, i, j):
    """Copy individual i of problem b from one (pop, levels, total, raw, rates) buffer set
    over individual j of another (or of the same)."""
    for d in range(source[0].shape[2]):
        target[0][b, j, d] = source[0][b, i, d]
    for lv in range(source[1].shape[2]):
        target[1][b, j, lv] = source[1][b, i, lv]
    target[2][b, j] = source[2][b, i]
    for t in range(source[3].shape[2]):
        target[3][b, j, t] = source[3][b, i, t]
    target[4][b, j, 0] = source[4][b, i, 0]
    target[4][b, j, 1] = source[4][b, i, 1]


def keep_trial(target, b, i, trial, lv, rw, tot, trial_rates):
    """Write an accepted trial (and its levels, raw errors, total, F and CR) into target."""
    for d in range(target[0].shape[2]):
        target[0][b, i, d] = trial[d]
    for lvl in range(target[1].shape[2]):
        target[1][b, i, lvl] = lv[lvl]
    target[2][b, i] = tot
    for t in range(target[3].shape[2]):
        target[3][b, i, t] = rw[t]
    target[4][b, i, 0] = trial_rates[0]
    target[4][b, i, 1] = trial_rates[1]


def better_of(levels, b, a, c):
    """Index a or c, whichever individual of problem b has the better levels (a on ties)."""
    return a if not_worse(levels[b, a], levels[b, c]) else c


def migrate(b, pop_state, elite, leader, islands):
    """Ring migration: each island's leader replaces the worst individual (never the elite)
    of the next island."""
    size = pop_state[0].shape[1] // islands
    for j in range(islands):
        base = ((j + 1) % islands) * size
        worst = -1
        for i in range(base, base + size):
            if i != elite and (worst < 0 or better_of(pop_state[1], b, i, worst) == worst):
                worst = i
        copy_individual(pop_state, pop_state, b, leader[b, j], worst)


def within_tolerances(b, rw, terms, T):
    """Does every goal with a tolerance (and a weight in problem b) meet it, raw errors rw (T,)?"""
    term_float, params = terms[1], terms[2]
    for t in range(T):
        if term_float[t, 3] >= 0.0 and term_float[t, 0] * params[b, t, 11] > 0.0 and rw[t] > term_float[t, 3]:
            return False
    return True


def update_status(b, gen, row, pop_state, terms, status, control, history):
    """After a generation: best index, island leaders, migration, history, convergence,
    stagnation and restarts of problem b. A problem that stagnates unconverged with restarts
    left is flagged to restart: its next generation replaces every individual but the best by
    a random pose, and that best stays on as the elite, never worse, while the leaders that
    guide mutation and polish are the best of the others in each island. The best and mean
    total go to history[row, b] (generation-major (G, B, 2): a launch writes a prefix)."""
    pop, levels, total, raw = pop_state[0], pop_state[1], pop_state[2], pop_state[3]
    best, active, generations, converged, best_seen, last_improved, restarts, restarting, elite, leader = status
    patience, rel_improvement, stop_on_converged, max_restarts, migration = control
    P, islands = pop.shape[1], leader.shape[1]
    size = P // islands
    restarting[b] = False
    k = 0
    mean = 0.0
    for i in range(P):
        mean += total[b, i]
        k = better_of(levels, b, k, i)
    for j in range(islands):
        lead = j * size if j * size != elite[b] else j * size + 1
        for i in range(j * size, (j + 1) * size):
            if i != elite[b]:
                lead = better_of(levels, b, lead, i)
        leader[b, j] = lead
    if islands > 1 and (gen + 1) % migration == 0:
        migrate(b, pop_state, elite[b], leader, islands)
    best[b] = k
    history[row, b, 0] = total[b, k]
    history[row, b, 1] = mean / P
    generations[b] += 1
    met = within_tolerances(b, raw[b, k], terms, raw.shape[2])
    converged[b] = met
    if met and stop_on_converged:
        active[b] = False
    if total[b, k] < best_seen[b] - rel_improvement * abs(best_seen[b]) - 1e-30:
        best_seen[b] = total[b, k]
        last_improved[b] = gen
    elif gen - last_improved[b] >= patience:
        if not met and restarts[b] < max_restarts:
            restarts[b] += 1
            restarting[b] = True
            elite[b] = k
            last_improved[b] = gen
        else:
            active[b] = False

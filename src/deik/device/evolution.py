"""Device maths, part 3: DE trial vectors, strict-priority comparison, per-problem bookkeeping,
and how a DOF meets its limits (DE's limit modes; the polish's stop or wrap).

Compiled together with the other deik.device modules (see deik.backends.targets).
"""

import math

from deik.device.layout import (
    BEST_1,
    CLIP,
    HISTORY_BEST,
    HISTORY_MEAN,
    LOWER,
    PAPER,
    PENALTY,
    RAND_1,
    RATE_CR,
    RATE_F,
    REFLECT,
    TURN,
    UPPER,
)
from deik.device.maths import below, stream, threshold, unit, unit_bits
from deik.device.polish import is_polished
from deik.device.terms import weight_of
from deik.objectives.kinds import TERM_KIND, TOLERANCE

# inlined by the CPU target (deik.backends.targets) so make_trial's gene loop vectorises
INLINE = ("_cross", "within_limits")
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


def donor(n, exclude_a, exclude_b, exclude_c, n_exclude, key, draw):
    """A population index in [0, n) that avoids the first n_exclude of the excluded indices
    (draw `draw` of stream `key`)."""
    r = below(n - n_exclude, key, draw)
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


def make_trial(pop, rates, b, i, best, gen, settings, bounds, trial, trial_rates, restart):
    """DE trial vector for individual i of problem b (Figure 1: reads only the current
    population) and the F, CR it used (trial_rates); `best` is the leader of i's island, whose
    members are its only donors (settings: layout.KernelSettings; bounds: the flat limits,
    PackedSkeleton.bounds). Limit modes: reflect and
    clip fold or clamp genes into the limits, penalty lets them leave (a top-priority term
    penalises it), paper is Algorithm 2. adaptive (jDE): each individual carries its own F and
    CR in rates (B, P, 2), redrawn with probability 0.1 (F in [0.1, 1], CR in [0, 1]) and
    inherited by the trial when it is accepted. restart: a uniform random pose instead. Random
    numbers are draws of the stream of (seed, b, gen, i): 0-3 donors and the forced gene, 4 + d
    gene d, 4 + D onwards the rates. The gene loop (_cross) keeps no branch once compiled, so it
    vectorises over genes; F and CR are cast to the population's dtype so that a float32
    kernel computes its genes in float32."""
    key = stream(settings.seed, b, gen, i)
    P, D = pop.shape[1], pop.shape[2]
    size = P // settings.islands
    base = (i // size) * size
    if restart:
        for d in range(D):
            lo, hi = bounds[2 * d + LOWER], bounds[2 * d + UPPER]
            trial[d] = lo + (hi - lo) * unit(key, 4 + d)
        trial_rates[RATE_F], trial_rates[RATE_CR] = settings.F, settings.CR
        return
    t = pop.dtype.type
    f, cr = t(settings.F), t(settings.CR)
    if settings.adaptive:
        f, cr = rates[b, i, RATE_F], rates[b, i, RATE_CR]
        if unit(key, 4 + D) < _JDE_REDRAW:
            f = t(_JDE_F_MIN + (1.0 - _JDE_F_MIN) * unit(key, 5 + D))
        if unit(key, 6 + D) < _JDE_REDRAW:
            cr = t(unit(key, 7 + D))
    trial_rates[RATE_F], trial_rates[RATE_CR] = f, cr
    r1 = donor(size, i - base, 0, 0, 1, key, 0) + base
    r2 = donor(size, i - base, r1 - base, 0, 2, key, 1) + base
    r3 = donor(size, i - base, r1 - base, r2 - base, 3, key, 2) + base
    # every strategy as a + g (c - a) + f (p - q): rand/1 and best/1 with g = 0 and c = a
    current, g = pop[b, i], f - f
    if settings.strategy == RAND_1:
        a, c, p, q = pop[b, r1], pop[b, r1], pop[b, r2], pop[b, r3]
    elif settings.strategy == BEST_1:
        a, c, p, q = pop[b, best], pop[b, best], pop[b, r1], pop[b, r2]
    else:
        a, c, p, q, g = current, pop[b, best], pop[b, r1], pop[b, r2], f
    # one call per limit mode, each with its mode as a constant once inlined: a mode read in the
    # loop would keep a branch there, and the gene loop would not vectorise
    forced, mode = below(D, key, 3), settings.limit_mode
    if mode == REFLECT:
        _cross(trial, current, a, c, p, q, g, f, cr, forced, key, bounds, REFLECT)
    elif mode == CLIP:
        _cross(trial, current, a, c, p, q, g, f, cr, forced, key, bounds, CLIP)
    elif mode == PAPER:
        _cross(trial, current, a, c, p, q, g, f, cr, forced, key, bounds, PAPER)
    else:
        _cross(trial, current, a, c, p, q, g, f, cr, forced, key, bounds, PENALTY)


def _cross(trial, current, a, c, p, q, g, f, cr, forced, key, bounds, limit_mode):
    """trial[d] = the mutant a + g (c - a) + f (p - q) where gene d crosses over (d == forced or
    draw 4 + d of stream `key` below cr), else current[d]; then within_limits (rows (D,); the
    GPU's trial may be longer, padded). The
    limits are read flat, two per DOF (PackedSkeleton.bounds): indexed limits[d, LOWER], their
    stride would be the array's shape, unknown to LLVM, which then vectorises only for a stride
    of one; and a reshape in the kernel would link numba-cuda's reshape helper, with which a CUDA
    kernel cannot be cached."""
    below_cr = threshold(cr)
    for d in range(current.shape[0]):
        mutant = a[d] + g * (c[d] - a[d]) + f * (p[d] - q[d])
        crossed = (d == forced) | (unit_bits(key, 4 + d) < below_cr)
        lo, hi = bounds[2 * d + LOWER], bounds[2 * d + UPPER]
        trial[d] = within_limits(mutant if crossed else current[d], lo, hi, limit_mode)


def within_limits(v, lo, hi, limit_mode):
    """Gene v after the limit mode: reflect folds it into [lo, hi], clip clamps it, penalty
    leaves it (a top-priority term penalises it), paper applies Algorithm 2 (beyond +-2 pi it is
    scaled by 1 / (|v| - 2 pi))."""
    if limit_mode == REFLECT:
        if v < lo:
            v = lo + (lo - v)
        elif v > hi:
            v = hi - (v - hi)
        return min(max(v, lo), hi)
    if limit_mode == CLIP:
        return min(max(v, lo), hi)
    if limit_mode == PAPER and abs(v) > _TWO_PI:
        return v * (1.0 / (abs(v) - _TWO_PI))
    return v


def polish_target(leaders, k, count, P):
    """The k-th of `count` distinct individuals a polish round refines: each island's leader
    first (leaders (islands,)), then individuals spread evenly around each island from it."""
    islands = leaders.shape[0]
    island, size = k % islands, P // islands
    per_island = (count + islands - 1) // islands
    base = island * size
    return base + (leaders[island] - base + (k // islands) * size // per_island) % size


def first_polish_iterations(schedule):
    """LM iterations of individual 0's polish in a lazy first population (device_driver.
    polish_first): those of two polishes, since the round that follows passes over it
    (polished_just_now). A polish that stalls stops early either way; one still converging
    when a single budget ran out goes on at once instead of in that round."""
    return 2 * schedule.iterations


def polished_just_now(i, first_round):
    """Whether a polish round passes over individual i: in the round that follows a lazy first
    population (first_round), individual 0 has just had its polish (first_polish_iterations),
    which stopped short of the tolerances: almost always a stall (a 6-D arm target met by it
    1 % more often with twice the iterations), so a second polish from there rarely meets them
    (docs/decisions.md, "No second polish of a stalled start")."""
    return first_round and i == 0


def copy_individual(source, target, b, i, j):
    """Copy individual i of problem b from one Buffers set over individual j of another (or of
    the same)."""
    keep_trial(
        target, b, j, source.pop[b, i], source.levels[b, i], source.raw[b, i], source.total[b, i], source.rates[b, i]
    )


def keep_trial(target, b, i, trial, lv, rw, tot, trial_rates):
    """Write an accepted trial (and its levels, raw errors, total, F and CR) into target."""
    for d in range(target.pop.shape[2]):
        target.pop[b, i, d] = trial[d]
    for lvl in range(target.levels.shape[2]):
        target.levels[b, i, lvl] = lv[lvl]
    target.total[b, i] = tot
    for t in range(target.raw.shape[2]):
        target.raw[b, i, t] = rw[t]
    target.rates[b, i, RATE_F] = trial_rates[RATE_F]
    target.rates[b, i, RATE_CR] = trial_rates[RATE_CR]


def better_of(levels, b, a, c):
    """Index a or c, whichever individual of problem b has the better levels (a on ties)."""
    return a if not_worse(levels[b, a], levels[b, c]) else c


def migrate(b, state, elite, leaders, islands):
    """Ring migration: each island's leader replaces the worst individual (never the elite)
    of the next island."""
    size = state.pop.shape[1] // islands
    for j in range(islands):
        base = ((j + 1) % islands) * size
        worst = -1
        for i in range(base, base + size):
            if i != elite and (worst < 0 or better_of(state.levels, b, i, worst) == worst):
                worst = i
        copy_individual(state, state, b, leaders[b, j], worst)


def within_tolerances(b, rw, terms, T):
    """Does every goal with a tolerance (and a weight in problem b) meet it, raw errors rw (T,)?"""
    term_float = terms.term_float
    for t in range(T):
        if term_float[t, TOLERANCE] >= 0.0 and weight_of(terms, b, t) > 0.0 and rw[t] > term_float[t, TOLERANCE]:
            return False
    return True


def rank_problem(b, state, status):
    """Problem b's best individual (set as status.best[b] and returned) and its island leaders
    (status.leaders[b]): the best of each island but the elite."""
    levels, elite, leaders = state.levels, status.elite, status.leaders
    P, islands = state.pop.shape[1], leaders.shape[1]
    size = P // islands
    k = 0
    for i in range(P):
        k = better_of(levels, b, k, i)
    for j in range(islands):
        lead = j * size if j * size != elite[b] else j * size + 1
        for i in range(j * size, (j + 1) * size):
            if i != elite[b]:
                lead = better_of(levels, b, lead, i)
        leaders[b, j] = lead
    status.best[b] = k
    return k


def rank_first(b, state, status):
    """A first population's bookkeeping for problem b: every Status field reset (active, no
    generations, restarts or elite), then its best and leaders (rank_problem) and best levels
    seen. The Status arrays can therefore be reused from solve to solve unfilled."""
    status.active[b], status.converged[b], status.restarting[b] = True, False, False
    status.generations[b], status.last_improved[b], status.restarts[b], status.elite[b] = 0, 0, 0, -1
    remember_best(b, rank_problem(b, state, status), state, status)


def remember_best(b, k, state, status):
    """Keep individual k's levels and total as problem b's best seen."""
    for lvl in range(status.best_levels.shape[1]):
        status.best_levels[b, lvl] = state.levels[b, k, lvl]
    status.best_seen[b] = state.total[b, k]


def improved(b, k, state, status, rel):
    """Is individual k better than problem b's best seen by more than the fraction rel, judged
    by strict priority: the first level that differs by more than that decides, and the total
    only where no level does (a lower level's gain may raise the total; it still counts)?"""
    seen, lv = status.best_levels[b], state.levels[b, k]
    for lvl in range(seen.shape[0]):
        margin = rel * abs(seen[lvl]) + 1e-30
        if lv[lvl] < seen[lvl] - margin:
            return True
        if lv[lvl] > seen[lvl] + margin:
            return False
    return state.total[b, k] < status.best_seen[b] - rel * abs(status.best_seen[b]) - 1e-30


def settle_after_polish(b, gen, state, terms, status, rules, full_round):
    """After a polish: problem b's best, leaders and convergence (status.converged); a
    converged problem stops (status.active) when rules.stop_on_converged. After a full round
    (full_round) that met nothing, a problem whose every weighted goal the polish sees
    (polish_sees_all) restarts at once, restarts permitting: its round found only local minima
    of those goals, along which DE crept for hundreds of generations before stagnating (the
    stragglers of a Panda batch: 8 mm off in position while the orientation kept improving)."""
    k = rank_problem(b, state, status)
    met = within_tolerances(b, state.raw[b, k], terms, state.raw.shape[2])
    status.converged[b] = met
    if met and rules.stop_on_converged:
        status.active[b] = False
    elif full_round and not met and status.restarts[b] < rules.max_restarts and polish_sees_all(b, terms):
        restart(b, k, gen, status)


def polish_sees_all(b, terms):
    """Has every weighted goal of problem b a tolerance and residual rows (is_polished)?"""
    term_int, term_float = terms.term_int, terms.term_float
    for t in range(term_int.shape[0]):
        if weight_of(terms, b, t) > 0.0 and (term_float[t, TOLERANCE] < 0.0 or not is_polished(term_int[t, TERM_KIND])):
            return False
    return True


def restart(b, k, gen, status):
    """Flag problem b to restart in its next breeding, individual k kept as the elite."""
    status.restarts[b] += 1
    status.restarting[b] = True
    status.elite[b] = k
    status.last_improved[b] = gen


def update_status(b, gen, row, state, terms, status, rules, history):
    """After a generation: best index, island leaders, migration, history, convergence,
    stagnation and restarts of problem b (status: layout.Status, rules: layout.SearchRules). A
    problem that stagnates unconverged with restarts left is flagged to restart: its next
    generation replaces every individual but the best by a random pose, and that best stays on
    as the elite, never worse, while the leaders that guide mutation and polish are the best of
    the others in each island. The best and mean total go to history[row, b] (generation-major
    (G, B, 2): a launch writes a prefix)."""
    total, raw = state.total, state.raw
    elite, leaders, last_improved = status.elite, status.leaders, status.last_improved
    P, islands = state.pop.shape[1], leaders.shape[1]
    status.restarting[b] = False
    mean = 0.0
    for i in range(P):
        mean += total[b, i]
    k = rank_problem(b, state, status)
    if islands > 1 and (gen + 1) % rules.migration == 0:
        migrate(b, state, elite[b], leaders, islands)
    history[row, b, HISTORY_BEST] = total[b, k]
    history[row, b, HISTORY_MEAN] = mean / P
    status.generations[b] += 1
    met = within_tolerances(b, raw[b, k], terms, raw.shape[2])
    status.converged[b] = met
    if met and rules.stop_on_converged:
        status.active[b] = False
    if improved(b, k, state, status, rules.rel_improvement):
        remember_best(b, k, state, status)
        last_improved[b] = gen
    elif gen - last_improved[b] >= rules.patience:
        if not met and status.restarts[b] < rules.max_restarts:
            restart(b, k, gen, status)
        else:
            status.active[b] = False


def into_limits(v, limits, d):
    """Value v of DOF d brought inside its limits (layout.PackedSkeleton.limits): a rotation that
    turns a whole turn or more (TURN > 0: a continuous joint) passes a limit the way the joint
    does, by whole turns, and any other DOF stops at it. Stopped at +-pi, a continuous joint's
    polish from a far start stalled against the limit: the continuous Panda's first polish met
    67 % of 6-D targets from its zero pose, and 91 % wrapping (docs/decisions.md)."""
    lo, hi, turn = limits[d, LOWER], limits[d, UPPER], limits[d, TURN]
    if turn > 0.0:
        if v > hi:
            v -= turn * math.ceil((v - hi) / turn)
        elif v < lo:
            v += turn * math.ceil((lo - v) / turn)
    return min(max(v, lo), hi)


def held_at_limit(value, move, limits, d):
    """Is DOF d, at `value`, held at a limit that `move` would take it past? Never one that
    wraps round (into_limits)."""
    if limits[d, TURN] > 0.0:
        return False
    return (value <= limits[d, LOWER] and move < 0.0) or (value >= limits[d, UPPER] and move > 0.0)

"""Device maths, part 6: the per-individual work of every kernel, shared by both back-ends.

Compiled together with the other device_*.py files (see deik.kernels.targets). cpu.py and
cuda.py only decide which thread runs which (problem b, individual i) and own the scratch;
what happens to one individual is written here once. Buffers, skel, terms, settings and status
are the NamedTuples of deik.kernels.layout; scratch is a Scratch, trial (D,), trial_rates (2,),
lv (L,) and rw (T,) per-thread scratch.
"""

from deik.kernels.device_evolution import (
    copy_individual,
    keep_trial,
    make_trial,
    not_worse,
    within_tolerances,
)
from deik.kernels.device_lm import open_ended, polish
from deik.kernels.device_maths import uniform
from deik.kernels.device_terms import evaluate
from deik.kernels.layout import INIT_GENERATION, LOWER, RATE_CR, RATE_F, UPPER


def initialise_individual(b, i, state, skel, terms, settings, initial, n_initial, scratch):
    """Individual i of problem b: a copy of initial[b, i] when i < n_initial, else uniform inside
    the limits; its F and CR are the settings'; then evaluated."""
    limits, pop = skel.limits, state.pop
    for d in range(pop.shape[2]):
        if i < n_initial:
            pop[b, i, d] = initial[b, i, d]
        else:
            u = uniform(settings.seed, b, INIT_GENERATION, i, d)
            pop[b, i, d] = limits[d, LOWER] + (limits[d, UPPER] - limits[d, LOWER]) * u
    state.rates[b, i, RATE_F], state.rates[b, i, RATE_CR] = settings.F, settings.CR
    state.total[b, i] = evaluate(pop[b, i], b, skel, terms, scratch, state.levels[b, i], state.raw[b, i])


def polish_first(b, state, skel, terms, settings, memetic, initial, n_initial, scratch, axes, lm, q, lv, rw):
    """The start of a lazy first population: individual 0 of problem b (initial[b, 0], else
    its uniform pose) evaluated and polished; returns whether it meets every tolerance, in
    which case the problem stops and the rest of its population is never sampled."""
    initialise_individual(b, 0, state, skel, terms, settings, initial, n_initial, scratch)
    polish(b, 0, state, memetic.iterations, skel, terms, scratch, axes, lm, q, lv, rw)
    return within_tolerances(b, state.raw[b, 0], terms, state.raw.shape[2])


def complete_individual(b, i, met, state, skel, terms, settings, initial, n_initial, scratch):
    """Individual i >= 1 of a lazy first population whose individual 0 was polished
    (polish_first): a copy of individual 0 when that met every tolerance (the stopped
    problem's population stays consistent at no cost), else as initialise_individual."""
    if met:
        copy_individual(state, state, b, 0, i)
    else:
        initialise_individual(b, i, state, skel, terms, settings, initial, n_initial, scratch)


def breed_individual(b, i, gen, cur, nxt, skel, terms, settings, status, scratch, trial, trial_rates, lv, rw):
    """Generation `gen` for individual i of problem b: its trial from cur, evaluated, goes to nxt
    if not worse (strict priority), else the individual is copied over. In a restart generation
    every trial but the best's is kept."""
    island_size = cur.pop.shape[1] // settings.islands
    restarting = status.restarting[b]
    make_trial(
        cur.pop,
        cur.rates,
        b,
        i,
        status.leaders[b, i // island_size],
        gen,
        settings,
        skel.limits,
        trial,
        trial_rates,
        restarting,
    )
    tot = evaluate(trial, b, skel, terms, scratch, lv, rw)
    if i != status.best[b] if restarting else not_worse(lv, cur.levels[b, i]):
        keep_trial(nxt, b, i, trial, lv, rw, tot, trial_rates)
    else:
        copy_individual(cur, nxt, b, i, i)


def polish_individual(b, target, state, skel, terms, memetic, scratch, axes, lm, q, lv, rw):
    """LM polish of individual `target` of problem b in place (see device_lm.polish); returns
    whether the round may stop there: it meets every tolerance and no goal without one
    (comfort) is left to improve, which every polished individual then pursues."""
    polish(b, target, state, memetic.iterations, skel, terms, scratch, axes, lm, q, lv, rw)
    T = state.raw.shape[2]
    return within_tolerances(b, state.raw[b, target], terms, T) and not open_ended(b, terms, T)

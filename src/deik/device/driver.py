"""Device maths, part 6: the per-individual work of every kernel, shared by both back-ends.

Compiled together with the other deik.device modules (see deik.backends.targets). cpu.py and
cuda.py only decide which thread runs which (problem b, individual i) and own the scratch;
what happens to one individual is written here once: the GPU runs initialise_individual and
breed_individual, one individual per thread, and the CPU's blocks (device/lanes.py) run their
parts, seed_individual, propose and select, around an FK of many individuals at once. Buffers,
skel, terms, settings and status are the NamedTuples of deik.device.layout; scratch is a
Scratch, trial (D,), trial_rates (2,), lv (L,) and rw (T,) per-thread scratch.
"""

from deik.device.evolution import (
    copy_individual,
    first_polish_iterations,
    keep_trial,
    make_trial,
    not_worse,
    within_tolerances,
)
from deik.device.layout import INIT_GENERATION, LOWER, RATE_CR, RATE_F, UPPER
from deik.device.lm import open_ended, polish
from deik.device.maths import forward_kinematics, stream, unit
from deik.device.terms import evaluate, score


def seed_individual(b, i, state, skel, settings, initial, n_initial):
    """Individual i of problem b, not yet evaluated: a copy of initial[b, i] when i < n_initial,
    else uniform inside the limits; its F and CR are the settings'."""
    limits, pop, key = skel.limits, state.pop, stream(settings.seed, b, INIT_GENERATION, i)
    for d in range(pop.shape[2]):
        if i < n_initial:
            pop[b, i, d] = initial[b, i, d]
        else:
            pop[b, i, d] = limits[d, LOWER] + (limits[d, UPPER] - limits[d, LOWER]) * unit(key, d)
    state.rates[b, i, RATE_F], state.rates[b, i, RATE_CR] = settings.F, settings.CR


def initialise_individual(b, i, state, skel, terms, settings, initial, n_initial, scratch):
    """seed_individual, then evaluated."""
    seed_individual(b, i, state, skel, settings, initial, n_initial)
    state.total[b, i] = evaluate(state.pop[b, i], b, skel, terms, scratch, state.levels[b, i], state.raw[b, i])


def polish_first(b, state, skel, terms, settings, schedule, initial, n_initial, scratch, axes, lm, q, lv, rw, halt):
    """The start of a lazy first population: individual 0 of problem b (initial[b, 0], else
    its uniform pose) evaluated and polished; returns whether it meets every tolerance, in
    which case the problem stops and the rest of its population is never sampled. Its frames
    are computed once, with the motion axes, to score it and to start the polish. halt: the
    host's stop flag (device_lm.polish)."""
    seed_individual(b, 0, state, skel, settings, initial, n_initial)
    forward_kinematics(state.pop[b, 0], skel, scratch.R, scratch.p, scratch.work, axes, True)
    state.total[b, 0] = score(state.pop[b, 0], b, skel, terms, scratch, state.levels[b, 0], state.raw[b, 0])
    polish(b, 0, state, first_polish_iterations(schedule), skel, terms, scratch, axes, lm, q, lv, rw, True, halt)
    return within_tolerances(b, state.raw[b, 0], terms, state.raw.shape[2])


def complete_individual(b, i, met, state, skel, terms, settings, initial, n_initial, scratch):
    """Individual i >= 1 of a lazy first population whose individual 0 was polished
    (polish_first): a copy of individual 0 when that met every tolerance (the stopped
    problem's population stays consistent at no cost), else as initialise_individual."""
    if met:
        copy_individual(state, state, b, 0, i)
    else:
        initialise_individual(b, i, state, skel, terms, settings, initial, n_initial, scratch)


def propose(b, i, gen, cur, skel, settings, status, trial, trial_rates):
    """Generation `gen`'s trial (D,) for individual i of problem b from cur, and the F and CR it
    used (trial_rates (2,)); a uniform random pose in a restart generation."""
    make_trial(
        cur.pop,
        cur.rates,
        b,
        i,
        status.leaders[b, i // (cur.pop.shape[1] // settings.islands)],
        gen,
        settings,
        skel.bounds,
        trial,
        trial_rates,
        status.restarting[b],
    )


def select(b, i, cur, nxt, status, trial, lv, rw, tot, trial_rates):
    """An evaluated trial (levels lv, raw errors rw, total tot) goes to nxt if not worse than
    individual i of problem b (strict priority), else the individual is copied over; in a restart
    generation every trial but the best's is kept."""
    if i != status.best[b] if status.restarting[b] else not_worse(lv, cur.levels[b, i]):
        keep_trial(nxt, b, i, trial, lv, rw, tot, trial_rates)
    else:
        copy_individual(cur, nxt, b, i, i)


def breed_individual(b, i, gen, cur, nxt, skel, terms, settings, status, scratch, trial, trial_rates, lv, rw):
    """Generation `gen` for individual i of problem b: propose, evaluate, select."""
    propose(b, i, gen, cur, skel, settings, status, trial, trial_rates)
    tot = evaluate(trial, b, skel, terms, scratch, lv, rw)
    select(b, i, cur, nxt, status, trial, lv, rw, tot, trial_rates)


def polish_individual(b, target, state, skel, terms, schedule, scratch, axes, lm, q, lv, rw, halt):
    """LM polish of individual `target` of problem b in place (see device_lm.polish); returns
    whether the round may stop there: it meets every tolerance and no goal without one
    (comfort) is left to improve, which every polished individual then pursues."""
    polish(b, target, state, schedule.iterations, skel, terms, scratch, axes, lm, q, lv, rw, False, halt)
    T = state.raw.shape[2]
    return within_tolerances(b, state.raw[b, target], terms, T) and not open_ended(b, terms, T)

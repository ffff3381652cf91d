"""Compiled goal structures, kept for problems that differ from an earlier one only in targets.

A robot posed in a loop builds `deik.Problem(skeleton, [Position(tip, p), Orientation(tip, R)])`
again and again: the same skeleton, goal kinds, frames, weights and tolerances, new targets.
Compiling such a problem (every goal's row checked and packed, the term table stacked) took
about 45 us of a 200 us solve. The first problem of each structure compiles as usual and is
kept; a later problem of the same structure checks each new target with its goal's quick check
(Goal.quick_target, what deik.Solver swaps targets with) and takes the kept term rows and
table with its own targets written into a copy of the parameters. A target the quick check
declines (a batch axis, another form, a value to report) compiles the whole problem afresh, so
every error reads as before. At most MAX_STRUCTURES structures are kept, the oldest dropped.
The problems of a kept structure share a token (Compiled.structure), which deik.solve's kept
engines (solver/kept.py) are found by instead of comparing the tables.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from operator import methodcaller
from typing import TYPE_CHECKING

import numpy as np

from deik.model.skeleton import Skeleton
from deik.objectives.goals import Goal

if TYPE_CHECKING:  # problem.py imports this module
    from deik.solver.problem import Compiled

MAX_STRUCTURES = 32


@dataclass(frozen=True)
class _Known:
    skeleton: Skeleton  # held, so that the key's id() cannot be reused by another skeleton
    compiled: Compiled  # of the first problem of this structure, with the structure's token
    quick: tuple  # per goal with a target: (term index, its quick check)


_structure_of = methodcaller("structure")  # Goal.structure, called at C speed
_known: dict = {}
_lock = threading.Lock()


def _key(skeleton: Skeleton, goals: tuple[Goal, ...], limits: str) -> tuple | None:
    """The structure of a problem (what its compile reads but the targets), hashable, or None
    when a goal's structure is not plain (Goal.structure)."""
    parts = tuple(map(_structure_of, goals))
    return None if None in parts else (id(skeleton), limits, parts)


def recall(skeleton: Skeleton, goals: tuple[Goal, ...], limits: str) -> Compiled | None:
    """The Compiled (deik.solver.problem) of a problem with these goals, from the kept one of
    its structure with these goals' targets written in; None when none is kept or a target
    needs the full compile."""
    key = _key(skeleton, goals, limits)
    known = None if key is None else _known.get(key)
    if known is None or known.skeleton is not skeleton:
        return None
    table = known.compiled.table
    params = table.params.copy()  # (1, T, N_PARAMS): the gains and fixed columns stay
    for t, quick in known.quick:
        values = quick(goals[t].target)
        if values is None:
            return None
        params[0, t, : values.shape[0]] = values
    return _with_params(known.compiled, params)


def _with_params(compiled: Compiled, params: np.ndarray) -> Compiled:
    """`compiled` with `params` in its table, the rest shared. Both records are frozen and
    already checked: their fields are copied without dataclasses.replace's __init__ (3 us of
    a 100 us robot solve)."""
    table = object.__new__(type(compiled.table))
    table.__dict__.update(vars(compiled.table), params=params)
    return _with(compiled, table=table)


def _with(compiled: Compiled, **fields) -> Compiled:
    """`compiled` with `fields` replaced, unchecked (see _with_params)."""
    new = object.__new__(type(compiled))
    new.__dict__.update(vars(compiled), **fields)
    return new


def keep(skeleton: Skeleton, goals: tuple[Goal, ...], limits: str, compiled: Compiled) -> Compiled:
    """Keep `compiled` for later problems of its structure: only a single (unbatched) problem
    whose every goal with a target has a quick check. Returns `compiled`, with its structure's
    token (Compiled.structure) when that structure is kept."""
    key = _key(skeleton, goals, limits)
    if key is None or compiled.batch_shape != () or key in _known:
        return compiled
    quick = []
    for t, goal in enumerate(goals):
        if hasattr(goal, "target"):
            check = goal.quick_target(skeleton)
            if check is None:
                return compiled
            quick.append((t, check))
    compiled = _with(compiled, structure=object())
    with _lock:
        _known[key] = _Known(skeleton, compiled, tuple(quick))
        while len(_known) > MAX_STRUCTURES:
            del _known[next(iter(_known))]
    return compiled

"""Engines kept between deik.solve calls on problems of one structure.

`deik.solve` builds an Engine (packed terms, kernel settings, the Result's per-term facts) and
its buffers on every call: about 60 us of a 200 us robot solve. Calls in a loop usually pose
the same structure again (skeleton, goal kinds, frames, weights, tolerances, levels, batch size
and settings) with other targets. `kept_engine` keeps the last Engine and Workspace of each
small structure: a later call takes them out (no other call can use them meanwhile), writes its
own targets, gains and comfort references into the engine's arrays, and puts them back when
done. A Result never refers to them (solve.make_result copies what it reports). Only solves of
at most KEEP_BYTES of buffers are kept, and at most KEEP_STRUCTURES structures.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, fields
from operator import attrgetter

import numpy as np

from deik.solver.engine import Engine, seeded
from deik.solver.footprint import solve_bytes
from deik.solver.problem import Problem
from deik.solver.settings import Settings
from deik.solver.workspace import Workspace

KEEP_BYTES = 1 << 20  # buffers of a kept solve: small problems, where set-up dominates
KEEP_STRUCTURES = 16
_unseeded = attrgetter(*(f.name for f in fields(Settings) if f.name != "seed"))  # a seed is set per call


@dataclass
class _Kept:
    skeleton: object  # held, so that the key's id() cannot be reused by another skeleton
    structure: object  # the problem's structure token (Compiled.structure), held likewise
    engine: Engine
    workspace: Workspace


_kept: dict = {}
_lock = threading.Lock()


def _structure(problem: Problem, settings: Settings) -> tuple:
    """Everything an Engine is built from but the seed, the targets and the comfort reference
    poses (which a kept engine takes in place): equal keys give engines that differ only in
    those. The gains are in the key because the Result's per-term facts read them. Problems of
    a structure kept by deik.solver.structures share a token (Compiled.structure) that stands
    for all of the table's part."""
    compiled = problem.compiled
    if compiled.structure is not None:
        return (compiled.structure, *_unseeded(settings))
    table = compiled.table
    arrays = (table.term_int, table.term_float, table.dof_weight, table.pair_int, table.pair_radius)
    return (
        id(problem.skeleton),
        problem.limits,
        table.labels,
        table.n_levels,
        table.params.shape,
        table.params[:, :, -1].tobytes(),  # the gains (objectives.kinds.GAIN): the report reads them
        *(a.tobytes() for a in arrays),
        *_unseeded(settings),
    )


class kept_engine:  # noqa: N801 (a context manager used like a function, as contextlib's are)
    """(engine, workspace) for solving `problem` with `settings`: a kept pair of the same
    structure with this problem's targets written in, else new ones; kept afterwards when small
    and the solve did not raise. (A class rather than a generator: contextlib's machinery cost
    1.5 us of a 0.1 ms solve.)"""

    __slots__ = ("_problem", "_settings", "_key", "_kept")

    def __init__(self, problem: Problem, settings: Settings):
        self._problem, self._settings = problem, settings

    def __enter__(self) -> tuple[Engine, Workspace]:
        problem, settings = self._problem, self._settings
        self._key = key = _structure(problem, settings)
        with _lock:
            kept = _kept.pop(key, None)
        if kept is not None and kept.skeleton is problem.skeleton:
            engine = kept.engine
            engine.problem = problem
            # the problems of one structure token share their comfort references (none differ)
            shared_reference = kept.structure is not None
            for terms in (engine.terms,) if engine.terms64 is engine.terms else (engine.terms, engine.terms64):
                terms.params[...] = problem.table.params
                if not shared_reference:
                    terms.reference[...] = problem.reference
            # held by this call alone: its settings (which differ at most in the seed) set in place
            if settings.seed != engine.settings.seed:
                engine.kernel_settings = seeded(engine.kernel_settings, settings.seed)
            engine.settings = settings if settings.device != "auto" else settings.with_device(engine.settings.device)
        else:
            engine = Engine(problem, settings).for_problem(problem)
            size = solve_bytes(
                problem.batch_size,
                settings.population,
                problem.skeleton.n_dofs,
                problem.table.n_terms,
                problem.table.n_levels,
                np.dtype(settings.dtype).itemsize,
                0,
            )
            if size > KEEP_BYTES:
                self._kept = None
                return engine, Workspace()
            kept = _Kept(problem.skeleton, problem.compiled.structure, engine, Workspace())
        self._kept = kept
        return engine, kept.workspace

    def __exit__(self, exc_type, exc, traceback) -> None:
        if self._kept is not None and exc_type is None:
            with _lock:
                _kept[self._key] = self._kept
                while len(_kept) > KEEP_STRUCTURES:
                    del _kept[next(iter(_kept))]

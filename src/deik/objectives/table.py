"""The term table: objectives as data that every kernel reads.

A problem compiles to T rows. Each row: kind, level (0 = highest priority), up to MAX_TERM_FRAMES
frame indices, weight in [-1, 1], mu, the distance scale, the tolerance (raw units; -1 = none),
per-problem parameters (targets) and per-DOF weights; self-collision terms add the bone pairs
they test to one pair list. Raw errors are metres (or the skeleton's
length unit) or radians; the normalised value is 1 - exp(-mu * raw / scale) (Eqs. 4-7),
computed as -expm1 so that float32 keeps small errors.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deik.errors import InputError
from deik.objectives.kinds import MAX_LEVELS, MAX_TERM_FRAMES, MU, SCALE, TERM_KIND


@dataclass(frozen=True, kw_only=True)
class TermRow:
    """One compiled goal (see the module docstring), what Goal.row returns: its kind and label,
    its per-problem parameters (B, N_PARAMS) (B = 1 without a batch axis; the gain column is
    set by the Problem), up to MAX_TERM_FRAMES frame indices, weight, mu, distance scale,
    tolerance (-1: none) and level; a comfort term's per-DOF weights (D,) and reference poses
    (B, D); a self-collision term's bone pairs, (bone a, bone b, radius a + radius b) each."""

    kind: int
    label: str
    params: np.ndarray
    frames: tuple[int, ...] = ()
    weight: float = 1.0
    mu: float = 1.0
    scale: float = 1.0
    tolerance: float = -1.0
    level: int = 0
    dof_weight: np.ndarray | None = None
    reference: np.ndarray | None = None
    pairs: tuple[tuple[int, int, float], ...] = ()


@dataclass(frozen=True, eq=False)
class TermTable:
    """Arrays for the kernels. T terms, B problems, D DOFs, L levels.

    term_int (T, 3 + MAX_TERM_FRAMES) int32: kind, level, frame count, frames;
    term_float (T, 5): weight, mu, scale, tolerance, priority tolerance; params
    (B, T, N_PARAMS); dof_weight (T, D); pair_int (K, 3) int32: term, bone a, bone b (columns
    PAIR_* of deik.objectives.kinds) and pair_radius (K,) their capsule radii's sum. With
    more than one level, a term with a tolerance adds only its excess w * max(f - f(tolerance),
    0) to its level: a level is met (zero) exactly when each of its goals is within its own
    tolerance, and only then does the next level decide. The priority tolerance column holds
    f(tolerance), or -1 where the plain w * f counts (single-level problems, the paper's
    weighted sum, and terms without tolerance).
    """

    labels: tuple[str, ...]
    term_int: np.ndarray
    term_float: np.ndarray
    params: np.ndarray
    dof_weight: np.ndarray
    n_levels: int
    pair_int: np.ndarray
    pair_radius: np.ndarray

    @property
    def n_terms(self) -> int:
        return len(self.labels)

    @property
    def kinds(self) -> np.ndarray:
        return self.term_int[:, TERM_KIND]

    def normalise(self, raw: np.ndarray) -> np.ndarray:
        """Raw errors (..., T) -> normalised values 1 - exp(-mu raw / scale) in [0, 1)."""
        mu, scale = self.term_float[:, MU], self.term_float[:, SCALE]
        return -np.expm1(-mu * raw / scale)


def compile_rows(rows: list[TermRow], params_batch: np.ndarray, n_dofs: int) -> TermTable:
    """Stack rows into a TermTable; `params_batch` (B, T, N_PARAMS) holds per-problem targets."""
    T = len(rows)
    levels = sorted({r.level for r in rows})
    if len(levels) > MAX_LEVELS:
        raise InputError(f"at most {MAX_LEVELS} priority levels are supported, got {levels}")
    dense = {lv: k for k, lv in enumerate(levels)}
    term_int = np.full((T, 3 + MAX_TERM_FRAMES), -1, np.int32)
    term_float = np.zeros((T, 5))
    dof_weight = np.zeros((T, n_dofs))
    for t, r in enumerate(rows):
        if len(r.frames) > MAX_TERM_FRAMES:
            raise InputError(f"{r.label}: at most {MAX_TERM_FRAMES} frames per term")
        term_int[t, :3] = (r.kind, dense[r.level], len(r.frames))
        term_int[t, 3 : 3 + len(r.frames)] = r.frames
        prioritised = len(levels) > 1 and r.tolerance >= 0 and r.weight > 0
        f_tolerance = -np.expm1(-r.mu * r.tolerance / r.scale) if prioritised else -1.0
        term_float[t] = (r.weight, r.mu, r.scale, r.tolerance, f_tolerance)
        if r.dof_weight is not None:
            dof_weight[t] = r.dof_weight
    pairs = [(t, a, b, radius) for t, r in enumerate(rows) for a, b, radius in r.pairs]
    pair_int = np.array([p[:3] for p in pairs], np.int32).reshape(-1, 3)
    return TermTable(
        labels=tuple(r.label for r in rows),
        term_int=term_int,
        term_float=term_float,
        params=np.ascontiguousarray(params_batch, dtype=np.float64),
        dof_weight=dof_weight,
        n_levels=len(levels),
        pair_int=pair_int,
        pair_radius=np.array([p[3] for p in pairs], np.float64),
    )

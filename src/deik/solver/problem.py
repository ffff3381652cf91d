"""Problem: a skeleton, its goals and the joint-limit mode, compiled to the kernels' term table.

A problem's batch shape is () when no goal target, reference pose or `active` mask carries a
batch axis and (B,) when one does (even B = 1) or when the problem stacks others
(Problem.stack); a Result's batched fields have that leading shape. Stacked problems share
one term table, compiled from their parts.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from deik.errors import InputError
from deik.model.skeleton import Skeleton
from deik.objectives.goals import Goal, LimitsPenalty
from deik.objectives.kinds import GAIN, N_PARAMS
from deik.objectives.table import TermRow, TermTable, compile_rows
from deik.solver import structures

LIMIT_MODES = ("reflect", "clip", "penalty", "paper")


@dataclass(frozen=True, kw_only=True)
class Compiled:
    """A problem's term rows (T,) (a stack's are its first part's, with the merged weights; a
    problem whose structure was compiled before shares that problem's rows, so a row's params
    are the targets of the problem that compiled it and only the table's are this problem's),
    its TermTable (params (B, T, N_PARAMS)), the comfort reference pose of each term per problem
    (B, T, D) and its batch shape (() or (B,)). `structure`: a token that every problem of one
    structure kept by deik.solver.structures shares (their tables differ only in targets), or
    None."""

    rows: tuple[TermRow, ...]
    table: TermTable
    reference: np.ndarray
    batch_shape: tuple[int, ...]
    structure: object = None


@dataclass(frozen=True, eq=False)
class Problem:
    """An IK problem. `goals`: Goal instances (deik.Position, deik.Comfort, ...), any sequence,
    kept as a tuple. `limits`:
    "reflect" (default) or "clip" fold or clamp trial angles into the joint limits; "penalty"
    lets them leave and ranks any violation below every feasible pose (a top-priority term);
    "paper" applies the paper's Algorithm 2 (only the +-2 pi range, limits used for sampling).
    Targets with a leading batch axis pose B problems at once (B = batch_size).
    `parts`: the problems a stacked problem is made of (set by Problem.stack, whose goals are
    then the first part's). `compiled`: the term rows, table, references and batch shape (see
    Compiled), compiled when the problem is made."""

    skeleton: Skeleton
    goals: Sequence[Goal]
    limits: str = "reflect"
    parts: tuple = field(default=(), repr=False)

    def __post_init__(self):
        object.__setattr__(self, "goals", tuple(self.goals))
        object.__setattr__(self, "parts", tuple(self.parts))
        self._check()
        # compiled now so that bad goals fail here, not inside a solve; set as a plain attribute
        # (functools.cached_property takes a lock on every first read: 1 us of a 0.1 ms solve)
        object.__setattr__(self, "compiled", self._stacked() if self.parts else self._compile())

    def _check(self) -> None:
        if not isinstance(self.skeleton, Skeleton):
            raise TypeError(f"skeleton must be a deik.Skeleton, got {type(self.skeleton).__name__}")
        if not self.goals:
            raise InputError("a problem needs at least one goal, e.g. deik.Position('tip', target)")
        for g in self.goals:
            if not isinstance(g, Goal):
                raise TypeError(f"goals must be deik goal objects, got {type(g).__name__}")
        if self.limits not in LIMIT_MODES:
            raise InputError(f"limits must be one of {LIMIT_MODES}, got {self.limits!r}")
        if self.parts and (
            not all(isinstance(p, Problem) for p in self.parts)
            or len(self.parts[0].goals) != len(self.goals)
            or any(a is not b for a, b in zip(self.parts[0].goals, self.goals))
        ):
            raise InputError("a stacked problem's parts must be Problems and its goals the first part's")

    def _check_skeleton(self) -> None:
        """Raise unless the skeleton has free DOFs, each within finite limits (a structure
        compiled before passed this: see deik.solver.structures)."""
        if self.skeleton.n_dofs == 0:
            raise InputError(
                f"skeleton {self.skeleton.name!r} has no free DOF to solve for (every joint is fixed or mimics "
                "another); choose a base and tip with moving joints between them"
            )
        bad = np.flatnonzero(~np.isfinite(self.skeleton.lower) | ~np.isfinite(self.skeleton.upper))
        if bad.size:
            raise InputError(
                f"DOF {self.skeleton.dof_names[bad[0]]!r} has infinite limits; DE samples its "
                "first population inside the limits, so give every DOF finite limits"
            )

    @classmethod
    def stack(cls, problems: Sequence[Problem]) -> Problem:
        """One batched problem from `problems` (a sequence of Problems) that share a skeleton
        and limit mode and have the same goals in the same order, differing only in targets,
        weights, comfort reference poses and `active` masks; a problem with a batch of B
        contributes B problems. Weights that differ are carried as per-problem gains, so they
        must share a sign. solve(Problem.stack(ps)) solves them all in one launch."""
        problems = tuple(problems)
        if not problems or not all(isinstance(p, Problem) for p in problems):
            raise TypeError("Problem.stack takes a non-empty sequence of deik.Problem")
        first = problems[0]
        return cls(first.skeleton, first.goals, first.limits, parts=problems)

    def _stacked(self) -> Compiled:
        """The Compiled of a stacked problem (Problem.stack), from its parts."""
        rows, params, reference = _merge_parts(self.parts)
        return Compiled(
            rows=rows,
            table=compile_rows(rows, params, self.skeleton.n_dofs),
            reference=reference,
            batch_shape=(len(params),),
        )

    @property
    def rows(self) -> tuple[TermRow, ...]:
        return self.compiled.rows

    @property
    def table(self) -> TermTable:
        return self.compiled.table

    @property
    def reference(self) -> np.ndarray:
        """Reference pose of each comfort term, per problem: (B, T, D); zeros for other terms."""
        return self.compiled.reference

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """() for a single problem, (B,) for a batch (see the module docstring)."""
        return self.compiled.batch_shape

    @property
    def batch_size(self) -> int:
        return self.table.params.shape[0]

    def _compile(self) -> Compiled:
        """Each goal's row (and the joint-limit term's with limits="penalty"), stacked into the
        table; a goal without a batch axis broadcasts over the batch. A problem of a structure
        compiled before takes that one's rows with its own targets (deik.solver.structures)."""
        known = structures.recall(self.skeleton, self.goals, self.limits)
        if known is not None:
            return known
        return structures.keep(self.skeleton, self.goals, self.limits, self._compile_rows())

    def _compile_rows(self) -> Compiled:
        """_compile from every goal's row."""
        self._check_skeleton()
        sk = self.skeleton
        terms = list(self.goals)
        rows = [g.row(sk) for g in terms]
        if self.limits == "penalty":  # a level above every goal's
            terms.append(LimitsPenalty(level=min(r.level for r in rows) - 1))
            rows.append(terms[-1].row(sk))
        gains = [g.gain() for g in terms]
        sizes = {r.params.shape[0] for r in rows} | {gain.shape[0] for gain in gains}
        sizes |= {r.reference.shape[0] for r in rows if r.reference is not None}
        sizes.discard(1)
        if len(sizes) > 1:
            raise InputError(f"goal targets have different batch sizes {sorted(sizes)}; use one B or none")
        B = sizes.pop() if sizes else 1
        params = np.zeros((B, len(rows), N_PARAMS))
        reference = np.zeros((B, len(rows), sk.n_dofs))
        for t, (row, gain) in enumerate(zip(rows, gains)):
            params[:, t] = row.params  # a batch of 1 broadcasts
            params[:, t, GAIN] = gain
            if row.reference is not None:
                reference[:, t] = row.reference
        batch_shape = (B,) if any(g.batched() for g in terms) else ()
        return Compiled(
            rows=tuple(rows), table=compile_rows(rows, params, sk.n_dofs), reference=reference, batch_shape=batch_shape
        )


def _merge_parts(parts) -> tuple[tuple, np.ndarray, np.ndarray]:
    """(rows (T,), params (B, T, N_PARAMS), reference (B, T, D)) of the Problems `parts`
    stacked along the batch axis, B the sum of their batch sizes. A weight that differs
    between parts becomes the largest weight times a per-problem gain, so it must keep one
    sign; raises a ValueError naming the first part that cannot share the table. Only the
    check of each part's rows is per part; the parameters are scaled in one pass (per part,
    10,000 stacked problems took longer than solving them)."""
    first = parts[0]
    first_keys = _row_keys(first.rows)
    for k, p in enumerate(parts[1:], 1):
        same = p.skeleton is first.skeleton and p.limits == first.limits
        if not same or (p.rows is not first.rows and _row_keys(p.rows) != first_keys):
            _check_stackable(first, p, k)  # names what differs
    weights = np.array([[r.weight for r in p.rows] for p in parts])  # (N, T)
    if ((weights > 0).any(axis=0) & (weights < 0).any(axis=0)).any():
        raise InputError("Problem.stack: a goal has positive weights in some problems and negative in others")
    magnitude = np.abs(weights).max(axis=0)
    sign = np.where((weights < 0).any(axis=0), -1.0, 1.0)
    rows = tuple(replace(r, weight=float(s * m)) for r, s, m in zip(first.rows, sign, magnitude))
    params = np.concatenate([p.table.params for p in parts])  # a new array: the parts' stay as they are
    scale = np.divide(np.abs(weights), magnitude, out=np.zeros_like(weights), where=magnitude > 0)
    params[:, :, GAIN] *= np.repeat(scale, [p.batch_size for p in parts], axis=0)
    return rows, params, np.concatenate([p.reference for p in parts])


def _row_keys(rows) -> tuple:
    """What must agree between the rows of stacked problems (all but targets and weights),
    comparable with ==: (kind, label, frames, mu, scale, tolerance, level, pairs, DOF weights
    as bytes or None) per row."""
    return tuple(
        (
            r.kind,
            r.label,
            r.frames,
            r.mu,
            r.scale,
            r.tolerance,
            r.level,
            r.pairs,
            None if r.dof_weight is None else (r.dof_weight.shape, np.asarray(r.dof_weight, float).tobytes()),
        )
        for r in rows
    )


def _check_stackable(first, other, k: int) -> None:
    """Raise unless problem k can share a term table with the first one (_row_keys, and the
    skeleton and limit mode); the error names what differs."""
    if other.skeleton is not first.skeleton:
        raise InputError(f"Problem.stack: problem {k} has another skeleton; stacked problems share one Skeleton object")
    if other.limits != first.limits:
        raise InputError(f"Problem.stack: problem {k} uses limits={other.limits!r}, problem 0 {first.limits!r}")
    if len(other.rows) != len(first.rows):
        raise InputError(f"Problem.stack: problem {k} has {len(other.rows)} terms, problem 0 has {len(first.rows)}")
    for t, (a, b) in enumerate(zip(first.rows, other.rows)):
        same = (a.kind, a.label, a.frames, a.mu, a.scale, a.tolerance, a.level, a.pairs) == (
            b.kind,
            b.label,
            b.frames,
            b.mu,
            b.scale,
            b.tolerance,
            b.level,
            b.pairs,
        )
        if (
            not same
            or (a.dof_weight is None) != (b.dof_weight is None)
            or (a.dof_weight is not None and not np.array_equal(a.dof_weight, b.dof_weight))
        ):
            raise InputError(
                f"Problem.stack: goal {t} ({b.label}) of problem {k} differs from problem 0's "
                f"({a.label}) in more than its target, weight, reference or active mask"
            )

"""Problem: a skeleton, its goals and the joint-limit mode, compiled to the kernels' term table."""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from deik.objectives import table as tt
from deik.objectives.goals import Comfort, Goal
from deik.model.skeleton import Skeleton

LIMIT_MODES = ("reflect", "clip", "penalty", "paper")


@dataclass(frozen=True, eq=False)
class Problem:
    """An IK problem. `goals`: Goal instances (deik.Position, deik.Comfort, ...). `limits`:
    "reflect" (default) or "clip" fold or clamp trial angles into the joint limits; "penalty"
    lets them leave and ranks any violation below every feasible pose (a top-priority term);
    "paper" applies the paper's Algorithm 2 (only the +-2 pi range, limits used for sampling).
    Targets with a leading batch axis pose B problems at once (B = batch_size)."""

    skeleton: Skeleton
    goals: tuple
    limits: str = "reflect"

    def __post_init__(self):
        object.__setattr__(self, "goals", tuple(self.goals))
        if not isinstance(self.skeleton, Skeleton):
            raise TypeError(f"skeleton must be a deik.Skeleton, got {type(self.skeleton).__name__}")
        if not self.goals:
            raise ValueError("a problem needs at least one goal, e.g. deik.Position('tip', target)")
        for g in self.goals:
            if not isinstance(g, Goal):
                raise TypeError(f"goals must be deik goal objects, got {type(g).__name__}")
        if self.limits not in LIMIT_MODES:
            raise ValueError(f"limits must be one of {LIMIT_MODES}, got {self.limits!r}")
        if self.skeleton.n_dofs == 0:
            raise ValueError(
                f"skeleton {self.skeleton.name!r} has no free DOF to solve for (every joint is fixed or mimics "
                "another); choose a base and tip with moving joints between them"
            )
        bad = np.flatnonzero(~np.isfinite(self.skeleton.lower) | ~np.isfinite(self.skeleton.upper))
        if bad.size:
            raise ValueError(
                f"DOF {self.skeleton.dof_names[bad[0]]!r} has infinite limits; DE samples its "
                "first population inside the limits, so give every DOF finite limits"
            )
        self.table  # compile now so that bad goals fail here, not inside a solve

    @classmethod
    def stack(cls, problems) -> "Problem":
        """One batched problem from `problems` (a sequence of Problems) that share a skeleton
        and limit mode and have the same goals in the same order, differing only in targets,
        weights, comfort reference poses and `active` masks; a problem with a batch of B
        contributes B problems. Weights that differ are carried as per-problem gains, so they
        must share a sign. solve(Problem.stack(ps)) solves them all in one launch."""
        problems = list(problems)
        if not problems or not all(isinstance(p, Problem) for p in problems):
            raise TypeError("Problem.stack takes a non-empty sequence of deik.Problem")
        first = problems[0]
        for k, p in enumerate(problems[1:], 1):
            _check_stackable(first, p, k)
        weights = np.array([[r.weight for r in p.rows] for p in problems])  # (N, T)
        magnitude = np.abs(weights).max(axis=0)
        if ((weights > 0).any(axis=0) & (weights < 0).any(axis=0)).any():
            raise ValueError("Problem.stack: a goal has positive weights in some problems and negative in others")
        sign = np.where((weights < 0).any(axis=0), -1.0, 1.0)
        rows = [replace(r, weight=float(s * m)) for r, s, m in zip(first.rows, sign, magnitude)]
        params = []
        for p, w in zip(problems, weights):
            part = p.table.params.copy()
            part[:, :, tt.GAIN] *= np.divide(np.abs(w), magnitude, out=np.zeros_like(w), where=magnitude > 0)
            params.append(part)
        stacked = cls(first.skeleton, first.goals, first.limits)
        params = np.concatenate(params)
        # the merged table and references replace the ones compiled from the first problem's goals
        stacked.__dict__.update(
            rows=rows, batch_size=len(params), table=tt.compile_rows(rows, params, first.skeleton.n_dofs),
            reference=np.concatenate([np.broadcast_to(p.reference, (p.batch_size,) + p.reference.shape[1:])
                                      for p in problems]),
        )
        return stacked

    def with_goal_targets(self, goals: tuple, params: np.ndarray) -> "Problem":
        """This problem with `goals` (same kinds, weights and tolerances, new targets) and
        their parameters `params` (B, T, N_PARAMS): the compiled rows are reused (Solver)."""
        new = object.__new__(Problem)
        new.__dict__.update(self.__dict__)
        new.__dict__.pop("_goal_params", None)
        new.__dict__.update(goals=tuple(goals), table=replace(self.table, params=params))
        return new

    @cached_property
    def rows(self) -> list[tt.TermRow]:
        rows = [g.row(self.skeleton) for g in self.goals]
        if self.limits == "penalty":
            top = min(r.level for r in rows) - 1
            rows.append(tt.TermRow(tt.LIMITS, "joint limits", (), (), 1.0, 1.0, 1.0, 0.0, top))
        return rows

    @cached_property
    def _goal_params(self) -> list:
        """Each goal's parameters (B_g, N_PARAMS) and gains (B_g,), parsed once."""
        return [(g.params(self.skeleton), g.gain()) for g in self.goals]

    @cached_property
    def batch_size(self) -> int:
        sizes = {p.shape[0] for p, _ in self._goal_params} | {gain.shape[0] for _, gain in self._goal_params}
        sizes |= {r.shape[0] for r in self._references if r is not None}
        sizes.discard(1)
        if len(sizes) > 1:
            raise ValueError(f"goal targets have different batch sizes {sorted(sizes)}; use one B or none")
        return sizes.pop() if sizes else 1

    @cached_property
    def _references(self) -> list:
        return [g.reference_pose(self.skeleton) for g in self.goals if isinstance(g, Comfort)]

    @cached_property
    def reference(self) -> np.ndarray:
        """Reference pose of each comfort term, per problem: (B, T, D); zeros for other terms."""
        out = np.zeros((self.batch_size, len(self.rows), self.skeleton.n_dofs))
        for t, goal in enumerate(self.goals):
            if isinstance(goal, Comfort):
                ref = goal.reference_pose(self.skeleton)
                out[:, t] = self.skeleton.reference if ref is None else ref
        return out

    @cached_property
    def table(self) -> tt.TermTable:
        B = self.batch_size
        params = np.zeros((B, len(self.rows), tt.N_PARAMS))
        for t, (goal_params, gain) in enumerate(self._goal_params):
            params[:, t] = goal_params  # a batch of 1 broadcasts
            params[:, t, tt.GAIN] = gain
        if self.limits == "penalty":
            params[:, -1, tt.GAIN] = 1.0
        return tt.compile_rows(self.rows, params, self.skeleton.n_dofs)


def _check_stackable(first: Problem, other: Problem, k: int) -> None:
    """Raise unless problem k can share a term table with the first one."""
    if other.skeleton is not first.skeleton:
        raise ValueError(f"Problem.stack: problem {k} has another skeleton; stacked problems share one Skeleton object")
    if other.limits != first.limits:
        raise ValueError(f"Problem.stack: problem {k} uses limits={other.limits!r}, problem 0 {first.limits!r}")
    if len(other.rows) != len(first.rows):
        raise ValueError(f"Problem.stack: problem {k} has {len(other.rows)} terms, problem 0 has {len(first.rows)}")
    for t, (a, b) in enumerate(zip(first.rows, other.rows)):
        same = (a.kind, a.label, a.frames, a.mu, a.scale, a.tolerance, a.level) == \
            (b.kind, b.label, b.frames, b.mu, b.scale, b.tolerance, b.level)
        if not same or (a.dof_weight is None) != (b.dof_weight is None) or \
                (a.dof_weight is not None and not np.array_equal(a.dof_weight, b.dof_weight)):
            raise ValueError(f"Problem.stack: goal {t} ({b.label}) of problem {k} differs from problem 0's "
                             f"({a.label}) in more than its target, weight, reference or active mask")

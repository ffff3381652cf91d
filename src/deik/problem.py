"""Problem: a skeleton, its goals and the joint-limit mode, compiled to the kernels' term table."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from deik.objectives import table as tt
from deik.objectives.goals import Comfort, Goal
from deik.skeleton import Skeleton

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
        bad = np.flatnonzero(~np.isfinite(self.skeleton.lower) | ~np.isfinite(self.skeleton.upper))
        if bad.size:
            raise ValueError(
                f"DOF {self.skeleton.dof_names[bad[0]]!r} has infinite limits; DE samples its "
                "first population inside the limits, so give every DOF finite limits"
            )
        self.table  # compile now so that bad goals fail here, not inside a solve

    @cached_property
    def rows(self) -> list[tt.TermRow]:
        rows = [g.row(self.skeleton) for g in self.goals]
        if self.limits == "penalty":
            top = min(r.level for r in rows) - 1
            rows.append(tt.TermRow(tt.LIMITS, "joint limits", (), (), 1.0, 1.0, 1.0, 0.0, top))
        return rows

    @cached_property
    def batch_size(self) -> int:
        sizes = {g.params(self.skeleton).shape[0] for g in self.goals} | {g.gain().shape[0] for g in self.goals}
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
        params = []
        for g in self.goals:
            rows = np.broadcast_to(g.params(self.skeleton), (B, tt.N_PARAMS)).copy()
            rows[:, tt.GAIN] = np.broadcast_to(g.gain(), (B,))
            params.append(rows)
        if self.limits == "penalty":
            params.append(np.zeros((B, tt.N_PARAMS)))
            params[-1][:, tt.GAIN] = 1.0
        return tt.compile_rows(self.rows, np.stack(params, axis=1), self.skeleton.n_dofs)

"""Result: the immutable outcome of a solve."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from deik.model.skeleton import Skeleton


@dataclass(frozen=True, eq=False)
class GoalReport:
    """One term of the best pose: raw error (metres / radians / length units), normalised
    value 1 - exp(-mu x / scale), weight, tolerance (-1 = none), level, active (whether the
    goal applies to the problem; see Goal.active), met (within tolerance, or not active)."""

    label: str
    error: float | np.ndarray
    normalised: float | np.ndarray
    weight: float
    tolerance: float
    level: int
    active: bool | np.ndarray = True

    @property
    def met(self):
        within = np.asarray(self.error) <= self.tolerance if self.tolerance >= 0 else np.full(np.shape(self.error), True)
        return within | ~np.asarray(self.active)


@dataclass(frozen=True, eq=False)
class Result:
    """Best pose per problem. angles (*batch, D); fitness (*batch,) total weighted sum;
    goals: per-term reports (float64, recomputed from the best pose); generations and
    converged (*batch,); history (*batch, G, 2) best and mean total fitness per generation;
    wall_time seconds; device "cpu" or "gpu"."""

    skeleton: Skeleton
    angles: np.ndarray
    fitness: np.ndarray
    goals: tuple[GoalReport, ...]
    generations: np.ndarray
    converged: np.ndarray
    history: np.ndarray
    wall_time: float
    device: str
    settings: object = field(repr=False)

    def __post_init__(self):
        for value in (self.angles, self.fitness, self.generations, self.converged, self.history):
            value.setflags(write=False)

    @property
    def angles_by_joint(self) -> dict[str, np.ndarray]:
        """{joint name: its DOF values} for a single (unbatched) problem."""
        if self.angles.ndim != 1:
            raise ValueError("angles_by_joint is for a single problem; index result.angles[b] instead")
        return self.skeleton.angles_by_joint(self.angles)

    @property
    def errors(self) -> dict[str, float | np.ndarray]:
        """{goal label: raw error}."""
        return {g.label: g.error for g in self.goals}

    def to_dict(self) -> dict:
        """JSON-ready summary: pose by joint and DOF name, per-goal errors, run facts."""
        angles = self.angles.tolist()
        return {
            "skeleton": self.skeleton.name,
            "dof_names": list(self.skeleton.dof_names),
            "angles": angles,
            "angles_by_joint": {k: v.tolist() for k, v in self.angles_by_joint.items()} if self.angles.ndim == 1 else None,
            "fitness": self.fitness.tolist(),
            "goals": [
                {"label": g.label, "error": np.asarray(g.error).tolist(), "normalised": np.asarray(g.normalised).tolist(),
                 "weight": g.weight, "tolerance": g.tolerance, "level": g.level, "active": np.asarray(g.active).tolist(), "met": np.asarray(g.met).tolist()}
                for g in self.goals
            ],
            "generations": self.generations.tolist(),
            "converged": self.converged.tolist(),
            "wall_time_s": self.wall_time,
            "device": self.device,
        }

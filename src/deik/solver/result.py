"""Result: the immutable outcome of a solve."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from deik.errors import InputError
from deik.model.joints import ROTATE
from deik.model.kinematics import forward_kinematics
from deik.model.orientations import matrix_quaternion
from deik.model.skeleton import Skeleton
from deik.objectives.kinds import GAIN, TERM_LEVEL, TOLERANCE, WEIGHT
from deik.objectives.registry import kind_of
from deik.objectives.table import TermTable
from deik.solver.settings import Settings


@dataclass(frozen=True, eq=False)
class GoalReport:
    """One term of the best pose: its label, kind (the registry's name, e.g. "position") and
    the unit of its error ("m" for metres or the skeleton's length unit, "rad", or "rad+m" for
    sums over rotation and translation DOFs); raw error, normalised value
    1 - exp(-mu x / scale), weight, tolerance (-1 = none), level, active (whether the goal
    applies to the problem; see Goal.active), met (within tolerance, or not active)."""

    label: str
    kind: str
    unit: str
    error: np.ndarray
    normalised: np.ndarray
    weight: float
    tolerance: float
    level: int
    active: np.ndarray

    @property
    def met(self) -> np.ndarray:
        """Bool array of the batch shape."""
        within = self.error <= self.tolerance if self.tolerance >= 0 else np.full(self.error.shape, True)
        return np.asarray(within | ~self.active)


@dataclass(frozen=True, eq=False)
class ReportTerms:
    """What each Result of one problem reports per term (T terms, B problems), worked out once
    per Engine: the problem's TermTable `table`; `goals` (label, kind name, unit, weight,
    tolerance, level) per term; `weight_gain` (B, T) each term's weight times its per-problem
    gain; `active` (B, T) read-only, whether a goal applies to a problem; `limit` (T,) the
    tolerance (inf where none) and `free` (B, T) whether a term is met whatever its error (not
    active, or a weight that is not positive: only positive weights decide convergence)."""

    table: object
    goals: tuple
    weight_gain: np.ndarray
    active: np.ndarray
    limit: np.ndarray
    free: np.ndarray

    @classmethod
    def of(cls, table: TermTable, skeleton: Skeleton) -> ReportTerms:
        """From a problem's TermTable (objectives/table.py) on `skeleton`."""
        weight, tolerance = table.term_float[:, WEIGHT], table.term_float[:, TOLERANCE]
        gain = table.params[:, :, GAIN]
        active = gain > 0
        active.setflags(write=False)
        levels = table.term_int[:, TERM_LEVEL]
        goals = tuple(
            (label, kind_of(kind).name, kind_of(kind).unit_for(skeleton), float(w), float(tol), int(level))
            for label, kind, w, tol, level in zip(table.labels, table.kinds, weight, tolerance, levels)
        )
        return cls(
            table,
            goals,
            weight * gain,
            active,
            np.where(tolerance >= 0, tolerance, np.inf),
            ~active | (weight <= 0),
        )

    def result(
        self, skeleton: Skeleton, best: BestPoses, shape: tuple[int, ...], wall_time: float, settings: Settings
    ) -> Result:
        """The Result of the `best` poses of a solve on `skeleton` with `settings` (its device),
        fields shaped `shape` + their own axes, `wall_time` seconds. Takes best's arrays over
        (the caller hands fresh ones)."""
        best.raw.setflags(write=False)  # the goals' errors are views of it, and fitness is worked out from it later
        # the fields set as the frozen dataclass's __init__ would, without its per-field
        # object.__setattr__ (1 us of a 0.1 ms robot solve)
        result = object.__new__(Result)
        result.__dict__.update(
            skeleton=skeleton,
            angles=best.angles.reshape(shape + best.angles.shape[1:]),
            generations=best.generations.reshape(shape),
            wall_time=wall_time,
            device=settings.device,
            settings=settings,
            evaluation=Evaluation(self, best.raw, shape, best.history),
        )
        result.__post_init__()
        return result


class BestPoses(NamedTuple):
    """The best pose of each of B problems after a solve: `angles` (B, D) radians or length
    units, their raw errors `raw` (B, T) float64, `generations` (B,) run and `history`
    (B, G, 2) the best fitness and mean per generation, or a function that returns it."""

    angles: np.ndarray
    raw: np.ndarray
    generations: np.ndarray
    history: np.ndarray | Callable[[], np.ndarray]


@dataclass(frozen=True, eq=False)
class Evaluation:
    """The float64 raw errors `raw` (B, T) of a Result's best poses with the per-term facts
    `terms` they are reported with, the Result's batch `shape` and the solve's history (B, G, 2)
    (or a function that returns it, BestPoses.history): what its fitness, goals, converged and
    history are worked out from, on first use."""

    terms: ReportTerms
    raw: np.ndarray
    shape: tuple[int, ...]
    solve_history: np.ndarray | Callable[[], np.ndarray]

    def history(self) -> np.ndarray:
        """Best and mean total fitness per generation, (*shape, G, 2)."""
        history = self.solve_history() if callable(self.solve_history) else self.solve_history
        return history.reshape(self.shape + history.shape[1:])

    def fitness(self) -> np.ndarray:
        """Total weighted sum of normalised errors, (*shape,)."""
        return (self.terms.table.normalise(self.raw) * self.terms.weight_gain).sum(axis=1).reshape(self.shape)

    def converged(self) -> np.ndarray:
        """Whether every term with a positive weight is met, (*shape,)."""
        return ((self.raw <= self.terms.limit) | self.terms.free).all(axis=1).reshape(self.shape)

    def goals(self) -> tuple[GoalReport, ...]:
        """One GoalReport per term."""
        shape, norm = self.shape, self.terms.table.normalise(self.raw)
        norm.setflags(write=False)
        return tuple(
            GoalReport(label, kind, unit, error.reshape(shape), value.reshape(shape), w, tol, level, on.reshape(shape))
            for (label, kind, unit, w, tol, level), error, value, on in zip(
                self.terms.goals, self.raw.T, norm.T, self.terms.active.T
            )
        )


# the fields of a Result worked out on first use: a reused Solver's caller often reads the
# angles alone, and these cost more than the rest of the Result together
_ON_FIRST_USE = {
    "fitness": Evaluation.fitness,
    "goals": Evaluation.goals,
    "converged": Evaluation.converged,
    "history": Evaluation.history,
}


@dataclass(frozen=True, eq=False)
class Result:
    """Best pose per problem.

    Shape rule: every batched field has the leading shape `batch` = problem.batch_shape, which
    is () for a problem whose goals carry no batch axis and (B,) when a goal's target, active
    mask or reference pose carries one (even B = 1) or the problem was stacked
    (Problem.stack, solve_batch). Nothing is squeezed: angles (*batch, D); fitness (*batch,)
    total weighted sum; generations and converged (*batch,); history (*batch, G, 2) best and
    mean total fitness per generation, all read-only NumPy arrays (0-d when batch is ()); goals:
    one GoalReport per term, whose error, normalised, active and met are arrays of shape batch
    (float64 errors of the best pose). wall_time seconds; device "cpu" or "gpu". fitness, goals,
    converged and history are worked out from `evaluation` (the raw errors, the solve's
    history) when first read, then kept."""

    skeleton: Skeleton
    angles: np.ndarray
    fitness: np.ndarray = field(init=False)
    goals: tuple[GoalReport, ...] = field(init=False)
    generations: np.ndarray
    converged: np.ndarray = field(init=False)
    history: np.ndarray = field(init=False)
    wall_time: float
    device: str
    settings: object = field(repr=False)
    evaluation: Evaluation = field(repr=False)

    def __post_init__(self):
        for value in (self.angles, self.generations):
            value.setflags(write=False)

    def __getattr__(self, name: str):
        # only for attributes not yet in the instance: the fields worked out on first use
        work_out = _ON_FIRST_USE.get(name)
        if work_out is None or "evaluation" not in self.__dict__:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        value = work_out(self.evaluation)
        if isinstance(value, np.ndarray):
            value.setflags(write=False)
        object.__setattr__(self, name, value)  # frozen to callers, kept once worked out
        return value

    @property
    def angles_by_joint(self) -> dict[str, np.ndarray]:
        """{joint name: its DOF values} for a single (unbatched) problem."""
        if self.angles.ndim != 1:
            raise InputError("angles_by_joint is for a single problem; index result.angles[b] instead")
        return self.skeleton.angles_by_joint(self.angles)

    @property
    def errors(self) -> dict[str, np.ndarray]:
        """{goal label: raw error (*batch,)}."""
        return {g.label: g.error for g in self.goals}

    def world_frames(self) -> dict:
        """Where the solved pose puts every frame, by forward kinematics: {"joints": {name:
        frame}, "sites": {name: frame}}, each frame {"position": (*batch, 3) length units,
        "quaternion_wxyz": (*batch, 4) unit, w >= 0} in world coordinates."""
        kin = forward_kinematics(self.skeleton, self.angles)
        q = matrix_quaternion(kin.R_world_frame, "wxyz")
        frames = [
            {"position": kin.p_world_frame[..., f, :], "quaternion_wxyz": q[..., f, :]}
            for f in range(self.skeleton.n_frames)
        ]
        J = self.skeleton.n_joints
        return {
            "joints": dict(zip(self.skeleton.joint_names, frames[:J])),
            "sites": dict(zip(self.skeleton.site_names, frames[J:])),
        }

    def to_dict(self) -> dict:
        """JSON-ready summary: the pose by joint and DOF name (radians / length units), every
        joint's and site's world position and quaternion (world_frames), the skeleton's tree
        ("parents": each frame's parent joint, None for the root) and up direction, the
        centre of mass (*batch, 3) (None without masses), per-goal errors (in each goal's
        unit), run facts. With the tree and positions a viewer draws the pose without the
        skeleton file (`deik view pose.json`)."""
        frames = {
            group: {name: {key: value.tolist() for key, value in frame.items()} for name, frame in named.items()}
            for group, named in self.world_frames().items()
        }
        sk = self.skeleton
        parents = [None if p < 0 else sk.joint_names[p] for p in (*sk.parents, *sk.site_joint)]
        com = forward_kinematics(sk, self.angles).p_world_com if sk.total_mass > 0 else None
        return {
            "skeleton": self.skeleton.name,
            "up": sk.up.tolist(),
            "parents": dict(zip(sk.frame_names, parents)),
            "dof_names": list(self.skeleton.dof_names),
            "dof_units": ["rad" if kind == ROTATE else "m" for kind in self.skeleton.dof_kind],
            "angles": self.angles.tolist(),
            "angles_by_joint": (
                {k: v.tolist() for k, v in self.angles_by_joint.items()} if self.angles.ndim == 1 else None
            ),
            **frames,
            "centre_of_mass": None if com is None else com.tolist(),
            "fitness": self.fitness.tolist(),
            "goals": [
                {
                    "label": g.label,
                    "kind": g.kind,
                    "unit": g.unit,
                    "error": g.error.tolist(),
                    "normalised": g.normalised.tolist(),
                    "weight": g.weight,
                    "tolerance": g.tolerance,
                    "level": g.level,
                    "active": g.active.tolist(),
                    "met": g.met.tolist(),
                }
                for g in self.goals
            ],
            "generations": self.generations.tolist(),
            "converged": self.converged.tolist(),
            "wall_time_s": self.wall_time,
            "device": self.device,
        }

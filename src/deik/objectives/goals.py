"""Goals a user asks for, each compiled to one row of the term table by its `row` method.

Targets may carry a leading batch axis (B, ...) to pose B problems at once. Weights lie in
[-1, 1] (Eq. 2); `level` sets strict priority (0 highest; a lower level never buys a higher
one's error beyond its tolerance); `tolerance` is in length units / radians and decides
convergence. A goal with a target defaults to absolute tolerances, LENGTH_TOLERANCE (1 mm when
the skeleton's unit is the metre) and ANGLE_TOLERANCE (0.1 degree): docs/conventions.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.model.orientations import FORMS, passes_rotation_check, rotation_from
from deik.model.skeleton import Skeleton
from deik.model.values import real_array
from deik.objectives.goal_values import (
    check_reachable,
    dof_weights,
    need_mass,
    pack,
    reach_test,
    vector,
)
from deik.objectives.kinds import (
    AIM,
    COM,
    COM_GROUND,
    COMFORT_MAX,
    COMFORT_SUM,
    FLOOR,
    LIMITS,
    MAX_TERM_FRAMES,
    N_PARAMS,
    OBSTACLE,
    ORIENTATION,
    POSITION,
    SUPPORT_POLYGON,
)
from deik.objectives.table import TermRow

LENGTH_TOLERANCE = 1e-3  # length units: 1 mm for metres (URDF, deik.humanoid, most BVH)
ANGLE_TOLERANCE = math.radians(0.1)  # radians
NO_PARAMS = np.zeros((1, N_PARAMS))  # the parameters of a goal without targets (read-only)
NO_PARAMS.setflags(write=False)
_PLAIN = frozenset({type(None), bool, int, float, str})  # field types Goal.structure compares by value


@dataclass(frozen=True)
class Goal:
    """Shared settings: weight in [-1, 1], mu > 0, level >= 0, tolerance >= 0 or None.

    Each kind of goal names its term label (LABEL, formatted with the goal's fields) and the
    fields that may carry a leading batch axis (BATCH_FIELDS: pairs of a field and the ndim of one
    problem's value), and compiles itself in one method, `row(skeleton)`, which checks its
    fields and returns its TermRow through `_row`, the part every kind shares."""

    LABEL = ""
    BATCH_FIELDS = ()

    weight: float = field(default=1.0, kw_only=True)
    mu: float = field(default=1.0, kw_only=True)
    level: int = field(default=0, kw_only=True)
    tolerance: float | None = field(default=None, kw_only=True)
    active: object = field(default=None, kw_only=True)

    @property
    def label(self) -> str:
        """The term's label in tables and reports, e.g. "position left_hand"."""
        return self.LABEL.format_map(vars(self))

    def batched(self) -> bool:
        """Whether a target, reference or `active` mask carries a batch axis (even of one)."""
        values = ((getattr(self, name), ndim) for name, ndim in self.BATCH_FIELDS)
        return self.active is not None or any(v is not None and np.ndim(v) > ndim for v, ndim in values)

    def gain(self) -> np.ndarray:
        """Per-problem weight multiplier (B,) or (1,): 1 where the goal applies, 0 where `active`
        (a bool per problem of a batch, e.g. the frames of a contact) switches it off."""
        if self.active is None:
            return np.ones(1)
        active = np.asarray(self.active)
        if active.dtype != np.bool_ or active.ndim != 1 or active.size == 0:
            raise InputError(f"active must be a non-empty 1-D bool array (one per problem), got {self.active!r}")
        return active.astype(np.float64)

    def _applying(self, values: np.ndarray) -> np.ndarray:
        """The rows of `values` (B, ...) of the problems this goal applies in: those its `active`
        mask keeps (a target where the goal is off, a clip's frames between contacts, need not be
        reachable), else all of them."""
        if self.active is None or len(values) == 1:
            return values
        gain = self.gain()
        return values[gain > 0] if len(gain) == len(values) else values

    def _check_settings(self, label: str) -> None:
        if not (-1.0 <= self.weight <= 1.0):
            raise InputError(f"{label}: weight {self.weight!r} must lie in [-1, 1] (Eq. 2)")
        if not (self.mu > 0 and math.isfinite(self.mu)):
            raise InputError(f"{label}: mu {self.mu!r} must be a positive finite number")
        if not (isinstance(self.level, int) and self.level >= 0):
            raise InputError(f"{label}: level {self.level!r} must be an integer >= 0")
        if self.tolerance is not None and not (self.tolerance >= 0 and math.isfinite(self.tolerance)):
            raise InputError(f"{label}: tolerance {self.tolerance!r} must be >= 0 (metres or radians)")

    def row(self, skeleton: Skeleton) -> TermRow:
        """This goal compiled for `skeleton`: its checked term row, with its parameters (B,
        N_PARAMS) (B = 1 without a batch axis). Each kind of goal defines it."""
        raise NotImplementedError(f"{type(self).__name__} defines no row")

    def _row(self, kind: int, params: np.ndarray, default_tolerance: float = -1.0, **fields: object) -> TermRow:
        """The part of every row the kinds share: the settings checked, the label, weight, mu,
        level and tolerance (the goal's, else `default_tolerance`, -1 for none); `fields` are
        the kind's own (frames, scale, dof_weight, reference, pairs: see TermRow)."""
        self._check_settings(self.label)
        tolerance = default_tolerance if self.tolerance is None else float(self.tolerance)
        return TermRow(
            kind=kind,
            label=self.label,
            params=params,
            weight=float(self.weight),
            mu=float(self.mu),
            tolerance=tolerance,
            level=self.level,
            **fields,
        )

    def structure(self) -> tuple | None:
        """Everything `row` reads but the target, hashable: the goal's kind and each other
        field's name, type and value; None when a field holds anything but None, a bool, an
        int, a float or a string (an array, a mask, a tuple), whose equality a key cannot
        tell cheaply. Two goals of one structure compile to rows that differ only in their
        targets (deik.solver.structures)."""
        fields = dict(vars(self))
        fields.pop("target", None)
        values = tuple(fields.values())
        types = tuple(map(type, values))  # compared too: 1 == 1.0 == True
        return (type(self), tuple(fields), types, values) if _PLAIN.issuperset(types) else None

    def target_params(self, skeleton: Skeleton, target: ArrayLike) -> tuple[np.ndarray, bool]:
        """(params (B, N_PARAMS), batched) of this goal with `target` in place of its own,
        checked as a new goal's would be (shape, NaN, reach, rotation): what deik.Solver swaps
        in between solves. B = 1 when the target has no batch axis."""
        goal = replace(self, target=target)
        return goal.row(skeleton).params, goal.batched()

    def quick_target(self, skeleton: Skeleton) -> Callable[[ArrayLike], np.ndarray | None] | None:
        """For deik.Solver, which swaps targets between solves of a few microseconds: a function
        that checks one new target without a batch axis in plain Python, as target_params
        would, and returns the leading columns (n,) of its parameters; or None, which decides
        nothing and leaves the target to target_params (a batch axis, another form, an error to
        report). None where a goal has no quick check."""
        return None


@dataclass(frozen=True)
class Position(Goal):
    """Place joint or site `frame` at `target` (3,) length units (Eq. 5). Default tolerance:
    LENGTH_TOLERANCE."""

    LABEL = "position {frame}"
    BATCH_FIELDS = (("target", 1),)
    frame: str
    target: object

    def row(self, skeleton: Skeleton) -> TermRow:
        """The frame, the target in columns 0-2, checked within reach; scale: the reach."""
        frame = skeleton.frame_index(self.frame)
        target = vector(self.target, (3,), f"{self.frame} target")
        check_reachable(skeleton, self._applying(target), frame, self.label)
        return self._row(POSITION, pack(target), LENGTH_TOLERANCE, frames=(frame,), scale=skeleton.reach)

    def quick_target(self, skeleton: Skeleton) -> Callable[[ArrayLike], np.ndarray | None]:
        """As Goal.quick_target: a finite 3-vector within reach (goal_values.reach_test)."""
        within = reach_test(skeleton, skeleton.frame_index(self.frame))

        def quick(target: ArrayLike) -> np.ndarray | None:
            a = real_array(target, "target")  # raises as target_params' conversion would
            if a.shape != (3,):
                return None
            x, y, z = a.tolist()
            return a if math.isfinite(x + y + z) and within(x, y, z) else None  # an overflowing sum just declines

        return quick


@dataclass(frozen=True)
class Orientation(Goal):
    """Turn `frame` to a world rotation; error = angle between rotations (rad). `target` is in
    orientation `form` (deik.model.orientations.FORMS, always named): "matrix" a 3x3 rotation
    or a 4x4 pose (its rotation part), "quat-wxyz" / "quat-xyzw" a unit quaternion (4,), "rpy"
    URDF roll, pitch, yaw (3,) radians (R = Rz Ry Rx), "xyz" intrinsic Euler XYZ (3,) radians.
    A target may carry a batch axis. Default tolerance: ANGLE_TOLERANCE."""

    LABEL = "orientation {frame}"
    frame: str
    target: object
    form: str = "matrix"

    @property
    def BATCH_FIELDS(self) -> tuple[tuple[str, int], ...]:  # noqa: N802 (the class attribute of Goal): one target's ndim depends on the form
        return (("target", FORMS.get(self.form, 2)),)

    def rotation(self) -> np.ndarray:
        """The target as rotation matrices (B, 3, 3), B = 1 without a batch axis; checked."""
        R = rotation_from(self.form, self.target, f"orientation target for {self.frame!r}")
        return vector(R, (3, 3), f"{self.frame} orientation")

    def row(self, skeleton: Skeleton) -> TermRow:
        """The frame, the target rotation's 9 entries row by row in columns 0-8."""
        frame = skeleton.frame_index(self.frame)
        return self._row(ORIENTATION, pack(self.rotation()), ANGLE_TOLERANCE, frames=(frame,))

    def quick_target(self, skeleton: Skeleton) -> Callable[[ArrayLike], np.ndarray | None] | None:
        """As Goal.quick_target, for the "matrix" form: one 3x3 rotation
        (orientations.passes_rotation_check), its 9 entries row by row as pack lays them out."""
        if self.form != "matrix":
            return None

        def quick(target: ArrayLike) -> np.ndarray | None:
            a = real_array(target, "target")  # raises as target_params' conversion would
            return a.reshape(9) if a.shape == (3, 3) and passes_rotation_check(a.tolist()) else None

        return quick


@dataclass(frozen=True)
class Aim(Goal):
    """Point `frame`'s local `axis` (3,) at world point `target` (3,); error in radians.
    Default tolerance: ANGLE_TOLERANCE."""

    LABEL = "aim {frame}"
    BATCH_FIELDS = (("target", 1),)
    frame: str
    target: object
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def row(self, skeleton: Skeleton) -> TermRow:
        """The frame, the unit axis in columns 0-2, the target in columns 3-5."""
        axis = np.asarray(self.axis, float)
        if axis.shape != (3,) or not np.linalg.norm(axis) > 0:
            raise InputError(
                f"aim axis for {self.frame!r} must be non-zero (a 3-vector), got {np.asarray(self.axis).tolist()}"
            )
        params = pack((axis / np.linalg.norm(axis))[None], vector(self.target, (3,), "aim target"))
        return self._row(AIM, params, ANGLE_TOLERANCE, frames=(skeleton.frame_index(self.frame),))


@dataclass(frozen=True)
class CentreOfMass(Goal):
    """Bring the whole-body centre of mass to `target` (3,) (Eqs. 3, 4). Default tolerance:
    LENGTH_TOLERANCE."""

    LABEL = "centre of mass"
    BATCH_FIELDS = (("target", 1),)
    target: object

    def row(self, skeleton: Skeleton) -> TermRow:
        """The target in columns 0-2, checked within reach of the root's range; scale: the reach."""
        need_mass(skeleton, "centre_of_mass")
        target = vector(self.target, (3,), "centre-of-mass target")
        check_reachable(skeleton, self._applying(target), None, self.label)
        return self._row(COM, pack(target), LENGTH_TOLERANCE, scale=skeleton.reach)


@dataclass(frozen=True)
class ComOverSupport(Goal):
    """Keep the centre of mass's ground projection over `point` (3,): horizontal distance.
    Default tolerance: LENGTH_TOLERANCE."""

    LABEL = "com over support"
    BATCH_FIELDS = (("point", 1),)
    point: object

    def row(self, skeleton: Skeleton) -> TermRow:
        """The support point in columns 0-2; scale: the reach."""
        need_mass(skeleton, "com_over_support")
        params = pack(vector(self.point, (3,), "support point"))
        return self._row(COM_GROUND, params, LENGTH_TOLERANCE, scale=skeleton.reach)


@dataclass(frozen=True)
class ComInPolygon(Goal):
    """Keep the centre of mass's ground projection inside the convex hull of `frames`' ground
    projections (e.g. heel and toe sites of the standing feet); error = distance outside."""

    LABEL = "com in support polygon"
    frames: tuple[str, ...]

    def row(self, skeleton: Skeleton) -> TermRow:
        need_mass(skeleton, "com_in_polygon")
        if isinstance(self.frames, str):
            raise InputError(f"support polygon: give a list of frame names, not the one string {self.frames!r}")
        if not 1 <= len(self.frames) <= MAX_TERM_FRAMES:
            raise InputError(f"support polygon needs 1 to {MAX_TERM_FRAMES} frames, got {len(self.frames)}")
        twice = sorted({f for f in self.frames if list(self.frames).count(f) > 1})
        if twice:
            raise InputError(f"support polygon lists {twice[0]!r} more than once: name each corner once")
        frames = tuple(skeleton.frame_index(f) for f in self.frames)
        return self._row(SUPPORT_POLYGON, NO_PARAMS, 0.0, frames=frames, scale=skeleton.reach)


@dataclass(frozen=True)
class Comfort(Goal):
    """Stay near a reference pose: sum (Eq. 6) or max (Eq. 7) of weighted |angle - reference|.

    `joint_weights`: None (all 1), "start" / "end" (linear ramp keeping the chain straight near
    its start or end, Fig. 2b/2c), a dict {joint name: weight} or an array (D,).
    `reference`: pose (D,) or (B, D); default the skeleton's reference pose. A continuous
    joint's reference past its limits is the same angle inside them (Skeleton.wrapped: 5 rad
    is -1.28 rad on a joint limited to +-pi; held at +pi before).
    """

    LABEL = "comfort ({mode})"
    BATCH_FIELDS = (("reference", 1),)
    mode: str = "sum"
    joint_weights: object = None
    reference: object = None
    mu: float = field(default=0.1, kw_only=True)

    def row(self, skeleton: Skeleton) -> TermRow:
        """The per-DOF weights and the reference poses (B, D), the skeleton's by default."""
        if self.mode not in ("sum", "max"):
            raise InputError(f"comfort mode must be 'sum' or 'max', got {self.mode!r}")
        kind = COMFORT_SUM if self.mode == "sum" else COMFORT_MAX
        reference = skeleton.reference[None] if self.reference is None else self.reference
        reference = skeleton.wrapped(vector(reference, (skeleton.n_dofs,), "comfort reference"))
        return self._row(kind, NO_PARAMS, dof_weight=dof_weights(skeleton, self.joint_weights), reference=reference)


@dataclass(frozen=True)
class Obstacle(Goal):
    """A sphere (`centre` (3,), `radius`) that every bone, a capsule of `bone_radius`, must
    stay out of; error = summed penetration depth (length units), met at 0."""

    LABEL = "obstacle"
    BATCH_FIELDS = (("centre", 1),)
    centre: object
    radius: float
    bone_radius: float = 0.0

    def row(self, skeleton: Skeleton) -> TermRow:
        """The centre in columns 0-2, the radius in 3 and the bone radius in 4; met at 0."""
        if not (self.radius > 0 and self.bone_radius >= 0):
            raise InputError(f"obstacle radius must be > 0 and bone_radius >= 0, got {self.radius}, {self.bone_radius}")
        centre = vector(self.centre, (3,), "obstacle centre")
        params = pack(centre, np.full((1, 1), self.radius), np.full((1, 1), self.bone_radius))
        return self._row(OBSTACLE, params, 0.0, scale=skeleton.reach)


@dataclass(frozen=True)
class Floor(Goal):
    """A floor at `height` (length units along skeleton.up) that every joint and site stays at
    or above (so every bone does: a segment reaches lowest at one of its ends); error = summed
    depth below it (length units). `clearance` (F,) per joint then site (length units, NaN
    for a point the floor ignores), if given, keeps each point that far above the floor: the
    body's surface around it (a limb's radius) stays on or above it. Default tolerance:
    LENGTH_TOLERANCE."""

    LABEL = "floor"
    BATCH_FIELDS = (("height", 0),)
    height: object
    clearance: object = None

    def row(self, skeleton: Skeleton) -> TermRow:
        """The height in column 0 (one per problem with a batch axis); scale: the reach; with
        `clearance`, one pair (f, f, clearance) per point the floor keeps above it."""
        height = np.asarray(self.height, float)
        if height.ndim > 1 or not np.isfinite(height).all():
            raise InputError(f"floor height must be a finite number (or one per problem), got {self.height!r}")
        return self._row(
            FLOOR, pack(height.reshape(-1, 1)), LENGTH_TOLERANCE, scale=skeleton.reach, pairs=self._pairs(skeleton)
        )

    def _pairs(self, skeleton: Skeleton) -> tuple:
        if self.clearance is None:
            return ()
        clearance = np.asarray(self.clearance, float)
        if clearance.shape != (skeleton.n_frames,) or np.isinf(clearance).any() or (clearance < 0).any():
            raise InputError(
                f"floor clearance must be (F,) = ({skeleton.n_frames},) finite lengths >= 0 or NaN, one per joint "
                f"then site, got shape {clearance.shape}"
            )
        return tuple((int(f), int(f), float(clearance[f])) for f in np.flatnonzero(np.isfinite(clearance)))


@dataclass(frozen=True)
class LimitsPenalty(Goal):
    """The joint-limit term that limits="penalty" adds (not a user goal): summed violation of
    the limits, radians and length units, met at 0. Problem puts it on a level above every
    goal, so its `level` may be negative (levels are made dense when the table is compiled)."""

    LABEL = "joint limits"

    def row(self, skeleton: Skeleton) -> TermRow:
        """Weight 1, met at 0, on its own level (which may be negative: no settings check)."""
        return TermRow(kind=LIMITS, label=self.label, params=NO_PARAMS, tolerance=0.0, level=self.level)

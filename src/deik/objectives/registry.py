"""The registry of goal kinds: one row per term kind, the one place that says what a kind is.

Each row names the kind's integer code (deik.objectives.kinds), its name, the unit of its raw
error, its goal class (which builds the term row and its label), its NumPy oracle
(objectives/term_errors.py), its problem-file schema (the `type` of a [[goal]] table, its
required and optional fields) and whether the LM polish differentiates it (the kernel's
device_polish.term_rows). The table's KIND_NAMES, the TOML reader's GOAL_TYPES, the unit
column of reports and the oracle's dispatch are all read from here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from deik.model.joints import TRANSLATE
from deik.model.skeleton import Skeleton
from deik.objectives import goals as g
from deik.objectives import kinds as k
from deik.objectives import term_errors as errors

LENGTH, ANGLE = "m", "rad"  # "m" stands for metres or the skeleton's length unit


def dof_unit(skeleton: Skeleton) -> str:
    """Unit of a sum over DOFs: radians for rotations, length units for translations, "rad+m"
    when the skeleton has both."""
    translates = skeleton.dof_kind == TRANSLATE
    return LENGTH if translates.all() else (ANGLE if not translates.any() else f"{ANGLE}+{LENGTH}")


@dataclass(frozen=True)
class GoalKind:
    """One term kind. `unit`: "m", "rad", or a function of the skeleton for kinds that sum over
    DOFs; `file_type`, `required`, `optional`: the [[goal]] table's type and fields besides
    the common ones (file_type None: not written in files); `polished`: the LM polish
    differentiates it (the others are left to DE)."""

    kind: int
    name: str
    goal: type
    oracle: Callable
    unit: str | Callable[[Skeleton], str]
    polished: bool
    file_type: str | None = None
    required: tuple[str, ...] = ()
    optional: tuple[str, ...] = ()

    @property
    def label(self) -> str:
        """The label template of its terms in tables and reports, e.g. "position {frame}"."""
        return self.goal.LABEL

    def unit_for(self, skeleton: Skeleton) -> str:
        """Unit of the raw error on `skeleton`."""
        return self.unit(skeleton) if callable(self.unit) else self.unit


COMMON_FIELDS = ("weight", "mu", "level", "tolerance")
KINDS = (
    GoalKind(k.POSITION, "position", g.Position, errors.position, LENGTH, True,
             "position", ("frame", "target")),
    GoalKind(k.ORIENTATION, "orientation", g.Orientation, errors.orientation, ANGLE, True,
             "orientation", ("frame",), ("target", "euler", "degrees")),
    GoalKind(k.AIM, "aim", g.Aim, errors.aim, ANGLE, False, "aim", ("frame", "target"), ("axis",)),
    GoalKind(k.COM, "centre_of_mass", g.CentreOfMass, errors.centre_of_mass, LENGTH, True, "com", ("target",)),
    GoalKind(k.COM_GROUND, "com_over_support", g.ComOverSupport, errors.com_over_support, LENGTH, True,
             "com_over_support", ("point",)),
    GoalKind(k.SUPPORT_POLYGON, "support_polygon", g.ComInPolygon, errors.support_polygon, LENGTH, False,
             "com_in_polygon", ("frames",)),
    GoalKind(k.COMFORT_SUM, "comfort_sum", g.Comfort, errors.comfort_sum, dof_unit, False,
             "comfort", (), ("mode", "joint_weights")),
    GoalKind(k.COMFORT_MAX, "comfort_max", g.Comfort, errors.comfort_max, dof_unit, False,
             "comfort", (), ("mode", "joint_weights")),
    GoalKind(k.LIMITS, "joint_limits", g.LimitsPenalty, errors.joint_limits, dof_unit, False),
    GoalKind(k.OBSTACLE, "obstacle", g.Obstacle, errors.obstacle, LENGTH, False,
             "obstacle", ("centre", "radius"), ("bone_radius",)),
)
assert [row.kind for row in KINDS] == list(range(len(KINDS))), "KINDS is indexed by kind code"

KIND_NAMES = tuple(row.name for row in KINDS)
# file type -> its row (the two comfort kinds share the "comfort" table; its mode picks one)
FILE_TYPES = {row.file_type: row for row in KINDS if row.file_type is not None}


def kind_of(code: int) -> GoalKind:
    """The row of term kind `code`."""
    return KINDS[int(code)]

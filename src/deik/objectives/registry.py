"""The registry of goal kinds: one row per term kind, the one place that says what a kind is.

Each row names the kind's integer code (deik.objectives.kinds), its name, the unit of its raw
error, its goal class (which builds the term row and its label), its NumPy oracle, its
problem-file schema (the `type` of a [[goal]] table, its required and optional fields) and
whether the LM polish differentiates it (the kernel's device_polish.term_rows). The table's
KIND_NAMES, the TOML reader's GOAL_TYPES, the unit column of reports and the oracle's dispatch
(objectives/reference.py) are all read from here.

The oracles live here too, one function per kind: the readable NumPy twin of the kernel's
device function, taking the evaluated poses (`Posed`) and one term (`Term`) and returning the
raw error (N,) of N poses in the row's unit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from deik.model.capsules import bone_starts
from deik.model.geometry import polygon_distance, segment_distance, segments_distance
from deik.model.joints import TRANSLATE
from deik.model.rotations import direction_angle, rotation_angle
from deik.model.skeleton import Skeleton
from deik.objectives import goals as g
from deik.objectives import kinds as k
from deik.objectives.self_collision import SelfCollision

LENGTH, ANGLE = "m", "rad"  # "m" stands for metres or the skeleton's length unit


def dof_unit(skeleton: Skeleton) -> str:
    """Unit of a sum over DOFs: radians for rotations, length units for translations, "rad+m"
    when the skeleton has both."""
    translates = skeleton.dof_kind == TRANSLATE
    return LENGTH if translates.all() else (ANGLE if not translates.any() else f"{ANGLE}+{LENGTH}")


@dataclass(frozen=True, kw_only=True)
class Posed:
    """N poses (N, D) of `skeleton` and their forward kinematics: frame rotations R (N, F, 3, 3),
    frame positions p (N, F, 3), centre of mass com (N, 3); ground (3, 3): two horizontal
    axes, then up."""

    skeleton: Skeleton
    poses: np.ndarray
    R: np.ndarray
    p: np.ndarray
    com: np.ndarray
    ground: np.ndarray


@dataclass(frozen=True, kw_only=True)
class Term:
    """One term row as each pose sees it: frames (k,) frame indices, params (N, N_PARAMS) the
    targets of each pose's problem, dof_weight (D,), reference (N, D) comfort reference poses,
    pairs (K, 2) the bone pairs of a self-collision term (a floor term: its points, (f, f)) and
    pair_radius (K,) their radii's sum (a floor point's clearance)."""

    frames: np.ndarray
    params: np.ndarray
    dof_weight: np.ndarray
    reference: np.ndarray
    pairs: np.ndarray
    pair_radius: np.ndarray

    @property
    def frame(self) -> int:
        return int(self.frames[0])


def position(x: Posed, term: Term) -> np.ndarray:
    """Distance of the frame from its target params[:3]."""
    return np.linalg.norm(x.p[:, term.frame] - term.params[:, :3], axis=-1)


def orientation(x: Posed, term: Term) -> np.ndarray:
    """Angle between the frame's rotation and the target params[:9] (row-major 3x3)."""
    return rotation_angle(term.params[:, :9].reshape(-1, 3, 3), x.R[:, term.frame])


def aim(x: Posed, term: Term) -> np.ndarray:
    """Angle between the frame's local axis params[:3] (in the world) and the direction to the
    target params[3:6]."""
    g = term.params
    axis = np.einsum("nij,nj->ni", x.R[:, term.frame], g[:, :3])
    return direction_angle(axis, g[:, 3:6] - x.p[:, term.frame])


def centre_of_mass(x: Posed, term: Term) -> np.ndarray:
    """Distance of the centre of mass from its target params[:3]."""
    return np.linalg.norm(x.com - term.params[:, :3], axis=-1)


def com_over_support(x: Posed, term: Term) -> np.ndarray:
    """Horizontal distance of the centre of mass from the support point params[:3]."""
    d = x.com - term.params[:, :3]
    d = d - (d @ x.ground[2])[:, None] * x.ground[2]
    return np.linalg.norm(d, axis=-1)


def support_polygon(x: Posed, term: Term) -> np.ndarray:
    """Ground distance of the centre of mass outside the convex hull of the frames."""
    flat = x.ground[:2].T
    return polygon_distance(x.com @ flat, x.p[:, term.frames] @ flat)


def _comfort(x: Posed, term: Term) -> np.ndarray:
    return term.dof_weight * np.abs(x.poses - term.reference)


def comfort_sum(x: Posed, term: Term) -> np.ndarray:
    """Weighted sum of |q - reference| (Eq. 6)."""
    return _comfort(x, term).sum(axis=1)


def comfort_max(x: Posed, term: Term) -> np.ndarray:
    """Largest weighted |q - reference| (Eq. 7)."""
    return _comfort(x, term).max(axis=1)


def joint_limits(x: Posed, term: Term) -> np.ndarray:
    """Summed violation of the joint limits."""
    sk, q = x.skeleton, x.poses
    return (np.maximum(sk.lower - q, 0) + np.maximum(q - sk.upper, 0)).sum(axis=1)


def obstacle(x: Posed, term: Term) -> np.ndarray:
    """Summed penetration of every bone (a capsule of radius params[4]) into the sphere of
    centre params[:3] and radius params[3]."""
    sk, g = x.skeleton, term.params
    starts = np.concatenate([sk.parents[1:], sk.site_joint])
    ends = np.arange(1, sk.n_frames)
    dist = segment_distance(g[:, None, :3], x.p[:, starts], x.p[:, ends])
    return np.maximum(g[:, None, 3] + g[:, None, 4] - dist, 0).sum(axis=1)


def self_collision(x: Posed, term: Term) -> np.ndarray:
    """Summed penetration of the bone-pair capsules: radius a + radius b + margin params[0]
    minus the distance between the two bone segments, where positive."""
    start, a, b = bone_starts(x.skeleton), term.pairs[:, 0], term.pairs[:, 1]
    dist = segments_distance(x.p[:, start[a]], x.p[:, a], x.p[:, start[b]], x.p[:, b])
    return np.maximum(term.pair_radius + term.params[:, None, 0] - dist, 0).sum(axis=1)


def floor(x: Posed, term: Term) -> np.ndarray:
    """Summed depth of every joint and site below the floor at height params[0] along up, or of
    the points the term lists (pairs (frame, frame), each its clearance above the floor)."""
    heights = x.p @ x.ground[2]
    if len(term.pairs):
        return np.maximum(term.params[:, None, 0] + term.pair_radius - heights[:, term.pairs[:, 0]], 0).sum(axis=1)
    return np.maximum(term.params[:, None, 0] - heights, 0).sum(axis=1)


@dataclass(frozen=True, kw_only=True)
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
ORIENTATION_FORMS = ("target", "pose", "quaternion_wxyz", "quaternion_xyzw", "rpy_degrees", "euler", "degrees")
KINDS = (
    GoalKind(
        kind=k.POSITION,
        name="position",
        goal=g.Position,
        oracle=position,
        unit=LENGTH,
        polished=True,
        file_type="position",
        required=("frame", "target"),
    ),
    GoalKind(
        kind=k.ORIENTATION,
        name="orientation",
        goal=g.Orientation,
        oracle=orientation,
        unit=ANGLE,
        polished=True,
        file_type="orientation",
        required=("frame",),
        optional=ORIENTATION_FORMS,
    ),
    GoalKind(
        kind=k.AIM,
        name="aim",
        goal=g.Aim,
        oracle=aim,
        unit=ANGLE,
        polished=False,
        file_type="aim",
        required=("frame", "target"),
        optional=("axis",),
    ),
    GoalKind(
        kind=k.COM,
        name="centre_of_mass",
        goal=g.CentreOfMass,
        oracle=centre_of_mass,
        unit=LENGTH,
        polished=True,
        file_type="com",
        required=("target",),
    ),
    GoalKind(
        kind=k.COM_GROUND,
        name="com_over_support",
        goal=g.ComOverSupport,
        oracle=com_over_support,
        unit=LENGTH,
        polished=True,
        file_type="com_over_support",
        required=("point",),
    ),
    GoalKind(
        kind=k.SUPPORT_POLYGON,
        name="support_polygon",
        goal=g.ComInPolygon,
        oracle=support_polygon,
        unit=LENGTH,
        polished=False,
        file_type="com_in_polygon",
        required=("frames",),
    ),
    GoalKind(
        kind=k.COMFORT_SUM,
        name="comfort_sum",
        goal=g.Comfort,
        oracle=comfort_sum,
        unit=dof_unit,
        polished=False,
        file_type="comfort",
        optional=("mode", "joint_weights"),
    ),
    GoalKind(
        kind=k.COMFORT_MAX,
        name="comfort_max",
        goal=g.Comfort,
        oracle=comfort_max,
        unit=dof_unit,
        polished=False,
        file_type="comfort",
        optional=("mode", "joint_weights"),
    ),
    GoalKind(
        kind=k.LIMITS, name="joint_limits", goal=g.LimitsPenalty, oracle=joint_limits, unit=dof_unit, polished=False
    ),
    GoalKind(
        kind=k.OBSTACLE,
        name="obstacle",
        goal=g.Obstacle,
        oracle=obstacle,
        unit=LENGTH,
        polished=False,
        file_type="obstacle",
        required=("centre", "radius"),
        optional=("bone_radius",),
    ),
    GoalKind(
        kind=k.SELF_COLLISION,
        name="self_collision",
        goal=SelfCollision,
        oracle=self_collision,
        unit=LENGTH,
        polished=False,
        file_type="self_collision",
        optional=("margin", "radii", "skip"),
    ),
    GoalKind(
        kind=k.FLOOR,
        name="floor",
        goal=g.Floor,
        oracle=floor,
        unit=LENGTH,
        polished=False,
        file_type="floor",
        required=("height",),
    ),
)
assert [row.kind for row in KINDS] == list(range(len(KINDS))), "KINDS is indexed by kind code"

KIND_NAMES = tuple(row.name for row in KINDS)
# file type -> its row (the two comfort kinds share the "comfort" table; its mode picks one)
FILE_TYPES = {row.file_type: row for row in KINDS if row.file_type is not None}


def kind_of(code: int) -> GoalKind:
    """The row of term kind `code`."""
    return KINDS[int(code)]

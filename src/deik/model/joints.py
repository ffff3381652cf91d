"""Joint, site and segment specifications (deik.model.build turns them into a Skeleton).

A joint's local transform is T(offset) R(rotation) followed by its degrees of freedom in order,
each a rotation about or a translation along an axis of the joint's own frame. A DOF may mimic
another (URDF `<mimic>`): its value is multiplier * source + offset, and it is not a variable.
Euler channels "ZXY" are three rotation DOFs (Z, then X, then Y: R = Rz Rx Ry), as in BVH files.
Units: metres (or the file's length unit) and radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.model.rotations import AXES

ROTATE, TRANSLATE = 0, 1


@dataclass(frozen=True)
class Dof:
    """One degree of freedom: `kind` ROTATE (radians) or TRANSLATE (length units) along `axis`.
    Its name is `name` when given, else "joint.label". `mimic` = (source DOF name, multiplier,
    offset) makes it follow another DOF instead of being a variable (limits then unused)."""

    kind: int
    axis: tuple[float, float, float]
    lower: float = -math.pi
    upper: float = math.pi
    reference: float = 0.0
    label: str = ""
    name: str = ""
    mimic: tuple[str, float, float] | None = None


@dataclass(frozen=True)
class Joint:
    """A joint: `parent` name (None for the root), `offset` (3,) and fixed `rotation` (3, 3) of
    its rest frame in the parent frame, its DOFs, and an optional point mass (kg) at its origin
    (the paper's Eq. 3). `label`: the name a pose keys its DOF values by when it is not `name`
    (a URDF link's frame is `name`, the URDF joint that moves it the label); default `name`."""

    name: str
    parent: str | None
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    dofs: tuple[Dof, ...] = ()
    mass: float = 0.0
    rotation: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    label: str = ""


@dataclass(frozen=True)
class Site:
    """A named frame rigidly attached to `joint` (end site, tool frame): offset and rotation."""

    name: str
    joint: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


@dataclass(frozen=True)
class Segment:
    """A body segment's mass (kg) carried by `joint`, centred at `com_offset` in the joint frame."""

    joint: str
    mass: float
    com_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = ""


def euler(
    order: str, lower: ArrayLike = -math.pi, upper: ArrayLike = math.pi, reference: ArrayLike = 0.0
) -> tuple[Dof, ...]:
    """Rotation DOFs for Euler channels, e.g. euler("ZXY"); limits scalar or one per channel."""
    order = order.upper()
    if not order or any(c not in AXES for c in order):
        raise InputError(f"euler order {order!r} must use only the letters X, Y and Z")
    n = len(order)
    lo, hi, ref = (np.broadcast_to(np.asarray(v, float), (n,)) for v in (lower, upper, reference))
    return tuple(
        Dof(ROTATE, AXES[c], float(lo[k]), float(hi[k]), float(ref[k]), f"{c}rotation") for k, c in enumerate(order)
    )


def hinge(
    axis: ArrayLike, lower: float = -math.pi, upper: float = math.pi, reference: float = 0.0, label: str = "hinge"
) -> tuple[Dof, ...]:
    """One rotation DOF about an arbitrary `axis` (normalised here)."""
    a = np.asarray(axis, dtype=float)
    norm = float(np.linalg.norm(a))
    if a.shape != (3,) or not math.isfinite(norm) or norm < 1e-12:
        raise InputError(f"hinge axis must be a finite non-zero 3-vector, got {axis!r}")
    return (Dof(ROTATE, tuple(a / norm), float(lower), float(upper), float(reference), label),)


def translation(axes: str = "XYZ", lower: ArrayLike = -math.inf, upper: ArrayLike = math.inf) -> tuple[Dof, ...]:
    """Translation DOFs along the named axes, e.g. a free-floating root: translation("XYZ")."""
    if not axes or any(c not in AXES for c in axes.upper()):
        raise InputError(f"translation axes {axes!r} must use only the letters X, Y and Z")
    return tuple(Dof(TRANSLATE, AXES[c], float(lower), float(upper), 0.0, f"{c}position") for c in axes.upper())

"""Joint, site and segment specifications, and `build_skeleton`, which turns them into a Skeleton.

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

from deik.rotations import AXES

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
    (the paper's Eq. 3)."""

    name: str
    parent: str | None
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    dofs: tuple[Dof, ...] = ()
    mass: float = 0.0
    rotation: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


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


def euler(order: str, lower=-math.pi, upper=math.pi, reference=0.0) -> tuple[Dof, ...]:
    """Rotation DOFs for Euler channels, e.g. euler("ZXY"); limits scalar or one per channel."""
    order = order.upper()
    if not order or any(c not in AXES for c in order):
        raise ValueError(f"euler order {order!r} must use only the letters X, Y and Z")
    n = len(order)
    lo, hi, ref = (np.broadcast_to(np.asarray(v, float), (n,)) for v in (lower, upper, reference))
    return tuple(
        Dof(ROTATE, AXES[c], float(lo[k]), float(hi[k]), float(ref[k]), f"{c}rotation")
        for k, c in enumerate(order)
    )


def hinge(axis, lower=-math.pi, upper=math.pi, reference=0.0, label="hinge") -> tuple[Dof, ...]:
    """One rotation DOF about an arbitrary `axis` (normalised here)."""
    a = np.asarray(axis, dtype=float)
    norm = float(np.linalg.norm(a))
    if a.shape != (3,) or not math.isfinite(norm) or norm < 1e-12:
        raise ValueError(f"hinge axis must be a finite non-zero 3-vector, got {axis!r}")
    return (Dof(ROTATE, tuple(a / norm), float(lower), float(upper), float(reference), label),)


def translation(axes: str = "XYZ", lower=-math.inf, upper=math.inf) -> tuple[Dof, ...]:
    """Translation DOFs along the named axes, e.g. a free-floating root: translation("XYZ")."""
    if not axes or any(c not in AXES for c in axes.upper()):
        raise ValueError(f"translation axes {axes!r} must use only the letters X, Y and Z")
    return tuple(
        Dof(TRANSLATE, AXES[c], float(lower), float(upper), 0.0, f"{c}position")
        for c in axes.upper()
    )


def _topological_order(joints: list[Joint]) -> list[int]:
    """Depth-first order from the root (parents first, siblings in given order)."""
    by_name: dict[str, int] = {}
    for k, j in enumerate(joints):
        if j.name in by_name:
            raise ValueError(f"duplicate joint name {j.name!r}; every joint needs its own name")
        by_name[j.name] = k
    roots = [k for k, j in enumerate(joints) if j.parent is None]
    if len(roots) != 1:
        names = [joints[k].name for k in roots]
        raise ValueError(f"a skeleton needs exactly one root (parent=None), found {names}")
    children: list[list[int]] = [[] for _ in joints]
    for k, j in enumerate(joints):
        if j.parent is not None:
            if j.parent not in by_name:
                raise ValueError(f"joint {j.name!r} names unknown parent {j.parent!r}")
            children[by_name[j.parent]].append(k)
    order, stack = [], [roots[0]]
    while stack:
        k = stack.pop()
        order.append(k)
        stack.extend(reversed(children[k]))
    if len(order) < len(joints):
        k = next(i for i in range(len(joints)) if i not in set(order))
        path = []
        while k not in path:
            path.append(k)
            k = by_name[joints[k].parent]
        cycle = [joints[i].name for i in path[path.index(k):]] + [joints[k].name]
        raise ValueError(f"joint parents form a cycle: {' -> '.join(cycle)}")
    return order


def build_skeleton(joints, sites=(), segments=(), up=(0.0, 1.0, 0.0), name="skeleton"):
    """Build a validated Skeleton from Joint/Site/Segment specs given in any order."""
    from deik.skeleton import Skeleton

    joints = list(joints)
    order = _topological_order(joints)
    joints = [joints[k] for k in order]
    index = {j.name: k for k, j in enumerate(joints)}
    for j in joints:
        free = [d.mimic is None for d in j.dofs]
        if free != sorted(free, reverse=True):
            raise ValueError(f"joint {j.name!r}: mimic DOFs must come after its free DOFs")
    dofs = [(k, d) for k, j in enumerate(joints) for d in j.dofs if d.mimic is None]
    mimics = [(k, d) for k, j in enumerate(joints) for d in j.dofs if d.mimic is not None]
    dof_names = tuple(_dof_name(joints[k], d) for k, d in dofs)
    dof_start = np.cumsum([0] + [sum(d.mimic is None for d in j.dofs) for j in joints])
    masses = [(index[j.name], (0.0, 0.0, 0.0), j.mass) for j in joints if j.mass != 0.0]
    for s in segments:
        if s.joint not in index:
            raise ValueError(f"segment {s.name!r} names unknown joint {s.joint!r}")
        masses.append((index[s.joint], s.com_offset, s.mass))
    for s in sites:
        if s.joint not in index:
            raise ValueError(f"site {s.name!r} names unknown joint {s.joint!r}")
    return Skeleton(
        name=name,
        joint_names=tuple(j.name for j in joints),
        parents=np.array([index[j.parent] if j.parent else -1 for j in joints], np.int32),
        offsets=np.array([j.offset for j in joints], np.float64).reshape(-1, 3),
        joint_dof_start=dof_start.astype(np.int32),
        dof_names=dof_names,
        dof_joint=np.array([k for k, _ in dofs], np.int32),
        dof_kind=np.array([d.kind for _, d in dofs], np.int32),
        dof_axis=np.array([d.axis for _, d in dofs], np.float64).reshape(-1, 3),
        lower=np.array([d.lower for _, d in dofs], np.float64),
        upper=np.array([d.upper for _, d in dofs], np.float64),
        reference=np.array([d.reference for _, d in dofs], np.float64),
        site_names=tuple(s.name for s in sites),
        site_joint=np.array([index[s.joint] for s in sites], np.int32),
        site_offset=np.array([s.offset for s in sites], np.float64).reshape(-1, 3),
        site_rotation=np.array([s.rotation for s in sites], np.float64).reshape(-1, 3, 3),
        mass_joint=np.array([m[0] for m in masses], np.int32),
        mass_offset=np.array([m[1] for m in masses], np.float64).reshape(-1, 3),
        mass_value=np.array([m[2] for m in masses], np.float64),
        up=np.asarray(up, np.float64),
        joint_rotation=np.array([j.rotation for j in joints], np.float64).reshape(-1, 3, 3),
        **_mimic_arrays(joints, mimics, dof_names),
    )


def _dof_name(joint: Joint, dof: Dof) -> str:
    return dof.name or f"{joint.name}.{dof.label or 'dof'}"


def _mimic_arrays(joints, mimics, dof_names) -> dict:
    """Skeleton mimic fields from [(joint index, Dof)]; sources are resolved to DOF indices."""
    sources = []
    for k, d in mimics:
        source = d.mimic[0]
        if source not in dof_names:
            raise ValueError(
                f"DOF {_dof_name(joints[k], d)!r} mimics unknown DOF {source!r}; "
                "a mimic source must be a free DOF of the same skeleton"
            )
        sources.append(dof_names.index(source))
    return dict(
        mimic_names=tuple(_dof_name(joints[k], d) for k, d in mimics),
        mimic_joint=np.array([k for k, _ in mimics], np.int32),
        mimic_kind=np.array([d.kind for _, d in mimics], np.int32),
        mimic_axis=np.array([d.axis for _, d in mimics], np.float64).reshape(-1, 3),
        mimic_source=np.array(sources, np.int32),
        mimic_scale=np.array([d.mimic[1] for _, d in mimics], np.float64),
        mimic_bias=np.array([d.mimic[2] for _, d in mimics], np.float64),
    )

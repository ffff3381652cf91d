"""URDF robots in: `read_urdf(path, base=None, tip=None) -> Skeleton`, parsed with yourdfpy.

Links become frames. A link reached through a moving joint (revolute, continuous, prismatic,
or one that mimics another) is a skeleton joint named after the link, with one DOF named after
the URDF joint; the base link is the root joint, fixed in the world. A link reached through a
fixed joint is merged into its nearest moving ancestor and kept as a `Site` (tool frames such as
`panda_hand_tcp`), so fixed joints cost the kernels nothing. Inertial masses become segments
at their inertial origins. Continuous joints get [-pi, pi], which covers every angle; mimic
joints follow their source and their own limits are not enforced. Geometry is never read:
`<visual>` and `<collision>` are stripped before parsing, so no mesh is loaded.
Units are the file's: metres, kilograms, radians.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass

import numpy as np

from deik.io.errors import FileFormatError
from deik.io.urdf_tree import LinkTree, read_xml
from deik.model.joints import ROTATE, TRANSLATE, Dof, Joint, Segment, Site
from deik.model.build import build_skeleton
from deik.suggest import did_you_mean

MOVING = {"revolute": ROTATE, "continuous": ROTATE, "prismatic": TRANSLATE}
SUPPORTED = ("revolute", "continuous", "prismatic", "fixed")


@dataclass(frozen=True)
class _Rigid:
    """A link's frame relative to the skeleton joint that carries it."""

    carrier: str
    R: np.ndarray
    p: np.ndarray


def read_urdf(path, base: str | None = None, tip=None, up=(0.0, 0.0, 1.0)):
    """Skeleton of the robot in URDF file `path`: the sub-tree below link `base` (default: the
    root link), cut to the paths from `base` to `tip` (a link name or a list of them; default:
    every link below `base`). `up` (3,): world up for balance goals (URDF's convention is +Z)."""
    source = str(path)
    root_element = read_xml(path)
    robot = _parse_with_yourdfpy(root_element, source)
    tree = LinkTree(robot, root_element, source)
    links = tree.select(base, tip)
    for name in links[1:]:
        _check_joint(tree, tree.joint_of[name])
    return _build(tree, links, up, robot.name or "robot")


def _parse_with_yourdfpy(root_element, source: str):
    import yourdfpy
    from lxml import etree

    for element in root_element.xpath("//visual | //collision"):
        element.getparent().remove(element)
    data = etree.tostring(root_element)
    try:
        urdf = yourdfpy.URDF.load(
            io.BytesIO(data), load_meshes=False, build_scene_graph=False,
            build_collision_scene_graph=False, load_collision_meshes=False,
        )
    except Exception as error:  # yourdfpy raises many kinds; all mean the same thing here
        raise FileFormatError(source, f"yourdfpy could not read it: {error}") from None
    return urdf.robot


def _check_joint(tree: LinkTree, joint) -> None:
    """Refuse unsupported joint types, missing or bad limits and non-finite numbers."""
    fail = tree.failure(joint.name)
    if joint.type not in SUPPORTED:
        fail(f"joint type {joint.type!r} is not supported; deik reads {', '.join(SUPPORTED)} (and mimic) joints")
    numbers = [joint.origin] if joint.origin is not None else []
    if joint.type in MOVING:
        numbers.append(joint.axis)
        if not np.isfinite(np.asarray(joint.axis, float)).all() or np.linalg.norm(joint.axis) < 1e-12:
            fail(f"axis {joint.axis} must be a finite non-zero vector")
    if not all(np.isfinite(np.asarray(n, float)).all() for n in numbers):
        fail("origin or axis holds NaN or infinite numbers")
    if joint.mimic is not None:
        if joint.mimic.joint not in tree.joints:
            fail(f"mimics unknown joint {joint.mimic.joint!r}{did_you_mean(joint.mimic.joint, tree.joints)}")
        values = (joint.mimic.multiplier, joint.mimic.offset)
        if not all(v is not None and math.isfinite(v) for v in values):
            fail("mimic multiplier and offset must be finite numbers")
        return
    if joint.type in ("revolute", "prismatic"):
        limit = joint.limit
        if limit is None or limit.lower is None or limit.upper is None:
            fail(f"a {joint.type} joint needs <limit lower=... upper=...>; add them (or make it continuous)")
        if not (math.isfinite(limit.lower) and math.isfinite(limit.upper)):
            fail(f"limits {limit.lower}, {limit.upper} must be finite numbers")
        if limit.lower > limit.upper:
            fail(f"lower limit {limit.lower} is above upper limit {limit.upper}; swap them")


def _dof(joint) -> Dof:
    kind = MOVING[joint.type]
    axis = np.asarray(joint.axis, float)
    axis = tuple(axis / np.linalg.norm(axis))
    if joint.mimic is not None:
        return Dof(kind, axis, name=joint.name, label=joint.type,
                   mimic=(joint.mimic.joint, joint.mimic.multiplier, joint.mimic.offset))
    if joint.type == "continuous":
        return Dof(kind, axis, -math.pi, math.pi, 0.0, joint.type, joint.name)
    lower, upper = joint.limit.lower, joint.limit.upper
    reference = min(max(0.0, lower), upper)
    return Dof(kind, axis, lower, upper, reference, joint.type, joint.name)


def _is_moving(joint) -> bool:
    return joint.type in MOVING


def _build(tree: LinkTree, links: list[str], up, name: str):
    frames = {links[0]: _Rigid(links[0], np.eye(3), np.zeros(3))}
    joints = [Joint(links[0], None)]
    sites, segments = [], []
    selected = set(links)
    for link in links[1:]:
        joint = tree.joint_of[link]
        parent = frames[joint.parent]
        origin = joint.origin if joint.origin is not None else np.eye(4)  # URDF: no <origin> is the identity
        R_origin, p_origin = origin[:3, :3], origin[:3, 3]
        R = parent.R @ R_origin
        p = parent.p + parent.R @ p_origin
        if _is_moving(joint):
            if joint.mimic is not None and tree.joint_child(joint.mimic.joint) not in selected:
                tree.failure(joint.name)(
                    f"mimics {joint.mimic.joint!r}, which is outside the selected chain; "
                    "choose a base and tip that include it"
                )
            joints.append(Joint(link, parent.carrier, tuple(p), (_dof(joint),), rotation=_rows(R)))
            frames[link] = _Rigid(link, np.eye(3), np.zeros(3))
        else:
            sites.append(Site(link, parent.carrier, tuple(p), _rows(R)))
            frames[link] = _Rigid(parent.carrier, R, p)
    for link in links:
        inertial = tree.links[link].inertial
        if inertial is None or not inertial.mass:
            continue
        if not (math.isfinite(inertial.mass) and inertial.mass > 0):
            tree.failure(link, "link")(f"mass {inertial.mass} must be a positive finite number of kg")
        frame = frames[link]
        origin = inertial.origin if inertial.origin is not None else np.eye(4)
        if not np.isfinite(origin).all():
            tree.failure(link, "link")("inertial origin holds NaN or infinite numbers")
        offset = frame.p + frame.R @ origin[:3, 3]
        segments.append(Segment(frame.carrier, float(inertial.mass), tuple(offset), link))
    return build_skeleton(joints, sites, segments, up=up, name=name)


def _rows(R: np.ndarray) -> tuple:
    """A rotation matrix as nested tuples, re-orthonormalised against rounding in the file."""
    U, _, Vt = np.linalg.svd(R)
    return tuple(map(tuple, U @ Vt))

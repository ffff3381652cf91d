"""URDF robots in: `read_urdf(path, base=None, tip=None) -> Skeleton`.

Links become frames. A link reached through a moving joint (revolute, continuous, prismatic,
or one that mimics another) is a skeleton joint named after the link, with one DOF named after
the URDF joint; the base link is the root joint, fixed in the world (by default the root link,
or its one child where a floating joint joins them: a `world` link holding the robot free, the
freedom `deik retarget` gives any robot with its floating root). A spherical joint (a ball,
as pybullet writes one) is three rotations about the frame's Z, X and Y axes in that order (the
BVH order, R = Rz Rx Ry; its DOFs JOINT.Zrotation, JOINT.Xrotation, JOINT.Yrotation), each over
a whole turn; its `<limit>`, a cone in pybullet, bounds no angle of them, and is refused. A link
reached through a
fixed joint is merged into its nearest moving ancestor and kept as a `Site` (tool frames such as
`panda_hand_tcp`), so fixed joints cost the kernels nothing. Inertial masses become segments
at their inertial origins. Continuous joints get [-pi, pi], which covers every angle; mimic
joints follow their source and their own limits are not enforced; a revolute joint whose limits
lie beyond +-1e6 radians over more than a whole turn (Gazebo's SDF exports write +-1e16 for a
joint that turns freely) is continuous too. Geometry (`<visual>`,
`<collision>`) is never read, so no mesh is loaded. Every value of the file is checked
(`urdf_elements`); the joint types and limits only on the selected links, so an unsupported
joint elsewhere in the robot does not matter. Units are the file's: metres, kilograms, radians.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import FileFormatError
from deik.io.files import FilePath
from deik.io.urdf.elements import UrdfJoint, read_joint, read_link
from deik.io.urdf.safe_xml import read_xml
from deik.io.urdf.tree import LinkTree
from deik.model.build import build_skeleton
from deik.model.geometry import unit_up
from deik.model.joints import ROTATE, TRANSLATE, Dof, Joint, Segment, Site, euler
from deik.model.orientations import rpy_matrix
from deik.model.skeleton import MAX_LIMIT, Skeleton
from deik.suggest import did_you_mean

MOVING = {"revolute": ROTATE, "continuous": ROTATE, "prismatic": TRANSLATE}
SPHERICAL = "ZXY"  # a ball joint's rotation axes, in order
SUPPORTED = ("revolute", "continuous", "prismatic", "spherical", "fixed")


@dataclass(frozen=True)
class _Rigid:
    """A link's frame relative to the skeleton joint that carries it."""

    carrier: str
    R: np.ndarray
    p: np.ndarray


def read_urdf(
    path: FilePath, base: str | None = None, tip: str | Sequence[str] | None = None, up: ArrayLike = (0.0, 0.0, 1.0)
) -> Skeleton:
    """Skeleton of the robot in URDF file `path`: the sub-tree below link `base` (default: the
    root link), cut to the paths from `base` to `tip` (a link name or a list of them; default:
    every link below `base`). `up` (3,): world up for balance goals (URDF's convention is +Z)."""
    source, up = str(path), unit_up(up)
    root = read_xml(path)
    links = [read_link(element, source) for element in root.iterchildren("link")]
    joints = [read_joint(element, source) for element in root.iterchildren("joint")]
    tree = LinkTree(links, joints, source)
    selected = tree.select(_below_a_floating_root(tree) if base is None else base, tip)
    for name in selected[1:]:
        _check_joint(tree, tree.joint_of[name])
    try:
        return _build(tree, selected, up, root.get("name") or "robot")
    except FileFormatError:
        raise
    except ValueError as error:  # a value every element allows but the robot as a whole does not
        raise FileFormatError(source, f"cannot build the robot: {error}") from None


def read_velocity_limits(path: FilePath) -> dict[str, float]:
    """{joint name: velocity limit} of every joint of the URDF file `path` whose `<limit>`
    gives one (rad/s for a rotation, m/s for a translation); FileFormatError as read_urdf."""
    source = str(path)
    joints = [read_joint(element, source) for element in read_xml(path).iterchildren("joint")]
    return {name: joint.velocity for joint in joints if joint.velocity is not None for name in _dof_names(joint)}


def _dof_names(joint: UrdfJoint) -> tuple[str, ...]:
    """The names of the DOFs `joint` moves: its own name, or one per axis of a ball joint."""
    if joint.type == "spherical":
        return tuple(f"{joint.name}.{axis}rotation" for axis in SPHERICAL)
    return (joint.name,)


def _below_a_floating_root(tree: LinkTree) -> str | None:
    """The root link's one child when a floating joint joins them (a `world` link holding the
    robot free, as simulators write it): the base deik fixes in the world; else None (the root)."""
    children = tree.children[tree.root]
    if len(children) == 1 and tree.joint_of[children[0]].type == "floating":
        return children[0]
    return None


def _check_joint(tree: LinkTree, joint: UrdfJoint) -> None:
    """Refuse unsupported joint types, zero axes, bad mimic sources and missing or inverted limits."""
    fail = tree.failure(joint.name)
    if joint.type == "floating":
        fail(
            "a floating joint frees the robot's base, and deik fixes a URDF robot's base in the world: "
            f"read it from the child link with --base {joint.child} (`deik retarget` gives it a floating root)"
        )
    if joint.type not in SUPPORTED:
        fail(f"joint type {joint.type!r} is not supported; deik reads {', '.join(SUPPORTED)} (and mimic) joints")
    if joint.type == "spherical":
        if joint.mimic is not None:
            fail("a spherical joint cannot mimic another joint; mimic joints have one axis")
        if joint.lower is not None or joint.upper is not None:
            fail(
                "a spherical joint's <limit lower upper> bounds a cone (pybullet's swing), not its three angles, "
                "which deik keeps within a whole turn: remove the limits, or write the ball as three revolute "
                "joints with limits of their own"
            )
        return
    if joint.type in MOVING and np.linalg.norm(joint.axis) < 1e-12:
        fail(f"axis {joint.axis} must be a non-zero vector")
    if joint.mimic is not None:
        source = tree.joints.get(joint.mimic.joint)
        if source is None:
            fail(f"mimics unknown joint {joint.mimic.joint!r}{did_you_mean(joint.mimic.joint, tree.joints)}")
        if source.type not in MOVING or source.mimic is not None:
            fail(
                f"mimics {source.name!r}, a {'mimic' if source.mimic else source.type} joint; "
                "a mimic must follow a revolute, continuous or prismatic joint that is not a mimic itself"
            )
        return
    if joint.type in ("revolute", "prismatic"):
        if joint.lower is None or joint.upper is None:
            fail(f"a {joint.type} joint needs <limit lower=... upper=...>; add them (or make it continuous)")
        if joint.lower > joint.upper:
            fail(f"lower limit {joint.lower} is above upper limit {joint.upper}; swap them")


def _dofs(joint: UrdfJoint) -> tuple[Dof, ...]:
    """The DOFs of moving `joint`: one, or three for a ball joint (module notes)."""
    if joint.type == "spherical":
        return tuple(
            replace(dof, label=joint.type, name=name) for dof, name in zip(euler(SPHERICAL), _dof_names(joint))
        )
    return (_dof(joint),)


def _turns_freely(joint: UrdfJoint) -> bool:
    """Whether revolute `joint`'s limits lie beyond +-MAX_LIMIT radians, over more than a whole
    turn: how Gazebo's SDF exports write a joint that turns freely (+-1e16), which is continuous."""
    if joint.type != "revolute":
        return False
    bound = max(abs(joint.lower), abs(joint.upper))
    return bound > MAX_LIMIT and joint.upper - joint.lower >= 2 * math.pi


def _dof(joint: UrdfJoint) -> Dof:
    kind = MOVING[joint.type]
    axis = tuple(joint.axis / np.linalg.norm(joint.axis))
    if joint.mimic is not None:
        return Dof(
            kind,
            axis,
            name=joint.name,
            label=joint.type,
            mimic=(joint.mimic.joint, joint.mimic.multiplier, joint.mimic.offset),
        )
    if joint.type == "continuous" or _turns_freely(joint):
        return Dof(kind, axis, -math.pi, math.pi, 0.0, joint.type, joint.name)
    reference = min(max(0.0, joint.lower), joint.upper)
    return Dof(kind, axis, joint.lower, joint.upper, reference, joint.type, joint.name)


def _build(tree: LinkTree, links: list[str], up, name: str):
    frames = {links[0]: _Rigid(links[0], np.eye(3), np.zeros(3))}
    joints = [Joint(links[0], None)]
    sites, segments = [], []
    selected = set(links)
    # one batched call: rotations one at a time were most of the reading time of long chains
    origins = rpy_matrix(np.array([tree.joint_of[link].rpy for link in links[1:]]).reshape(-1, 3))
    for link, R_origin in zip(links[1:], origins):
        joint = tree.joint_of[link]
        parent = frames[joint.parent]
        R = parent.R @ R_origin
        p = parent.p + parent.R @ joint.xyz
        if joint.type != "fixed":
            if joint.mimic is not None and tree.joint_child(joint.mimic.joint) not in selected:
                tree.failure(joint.name)(
                    f"mimics {joint.mimic.joint!r}, which is outside the selected chain; "
                    "choose a base and tip that include it"
                )
            joints.append(Joint(link, parent.carrier, tuple(p), _dofs(joint), rotation=_rows(R), label=joint.name))
            frames[link] = _Rigid(link, np.eye(3), np.zeros(3))
        else:
            sites.append(Site(link, parent.carrier, tuple(p), _rows(R)))
            frames[link] = _Rigid(parent.carrier, R, p)
    for link in links:
        mass, com = tree.links[link].mass, tree.links[link].com
        if mass:
            frame = frames[link]
            segments.append(Segment(frame.carrier, mass, tuple(frame.p + frame.R @ com), link))
    return build_skeleton(joints, sites, segments, up=up, name=name)


def _rows(R: np.ndarray) -> tuple:
    """A rotation matrix as nested tuples, re-orthonormalised against rounding in the file."""
    U, _, Vt = np.linalg.svd(R)
    return tuple(map(tuple, U @ Vt))

"""URDF `<link>` and `<joint>` elements as checked values: `read_link`, `read_joint`.

Numbers must be plain decimals (`-1.5`, `2e-3`, `.5`): `1_000`, `0x10`, `nan`, `inf` and empty
text are refused, although Python's float() takes some of them, and so is a number too large for
a 64-bit float. A vector holds exactly 3 numbers; a xacro expression (`$(arg x)`) is named as
one. Defaults are the URDF spec's: no `<origin>` is the identity, no `<axis>` is 1 0 0, a
mimic's multiplier is 1 and its offset 0, a link without `<inertial>` or `<mass>` has no mass.
An element read once (`<origin>`, `<limit>`, ...) may appear once. Lengths, angles of an origin,
axes and mimic offsets lie within +-1e6 (deik.model.skeleton.MAX_LENGTH) and mimic multipliers
too: beyond, poses lose all precision. Errors name the file, the line of the element at fault,
the link or joint, and the fix. Units are the file's: metres, kilograms, radians.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from deik.errors import FileFormatError
from deik.model.skeleton import MAX_LENGTH, MAX_MASS, MAX_MIMIC_SCALE

if TYPE_CHECKING:  # lxml is imported by the reader, when a file is read
    from lxml import etree

DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
WORD = re.compile(r"[^ \t\r\n]+")  # XML whitespace only: a no-break space is not a separator


@dataclass(frozen=True)
class Mimic:
    """`<mimic>`: this joint's value = multiplier * value of `joint` + offset."""

    joint: str
    multiplier: float
    offset: float


@dataclass(frozen=True)
class UrdfJoint:
    """A `<joint>`: its `<origin>` as translation xyz (3,) and roll-pitch-yaw rpy (3,) of the joint
    frame in the parent link's frame, axis (3,) as written (not normalised), limits or None where
    absent; `velocity` the `<limit velocity>` (rad/s or m/s) or None."""

    name: str
    type: str
    parent: str
    child: str
    xyz: np.ndarray
    rpy: np.ndarray
    axis: np.ndarray
    lower: float | None
    upper: float | None
    mimic: Mimic | None
    line: int
    velocity: float | None = None


@dataclass(frozen=True)
class UrdfLink:
    """A `<link>`: its mass (kg, 0 when none) centred at com (3,) in the link frame."""

    name: str
    mass: float
    com: np.ndarray
    line: int


def read_joint(element: etree._Element, source: str) -> UrdfJoint:
    """The checked values of `<joint>` `element` (lxml) of file `source`."""
    name = _name(element, source)
    e = _Checked(element, source)
    kind = element.get("type")
    if not kind:
        e.fail("needs a type attribute: revolute, continuous, prismatic or fixed")
    ends = []
    for part in ("parent", "child"):
        end = e.child(element, part)
        if end is None or not end.get("link"):
            e.fail(f'needs <{part} link="..."/>')
        ends.append(end.get("link"))
    xyz, rpy = e.origin(e.child(element, "origin"))
    axis = e.numbers(e.child(element, "axis"), "xyz", 3, (1.0, 0.0, 0.0))
    limit = e.child(element, "limit")
    lower, upper = (e.numbers(limit, bound, 1, (None,), math.inf)[0] for bound in ("lower", "upper"))
    velocity = e.numbers(limit, "velocity", 1, (None,), math.inf)[0]
    if velocity is not None and velocity < 0:
        e.fail(f'<limit velocity="{velocity:g}">: a velocity limit must be > 0, or 0 for none (rad/s or m/s)', limit)
    velocity = velocity or None  # 0: none given, as CAD exporters write an unknown limit
    return UrdfJoint(name, kind, *ends, xyz, rpy, np.array(axis), lower, upper, e.mimic(), element.sourceline, velocity)


def read_link(element: etree._Element, source: str) -> UrdfLink:
    """The checked values of `<link>` `element` (lxml) of file `source`."""
    name = _name(element, source)
    e = _Checked(element, source)
    inertial = e.child(element, "inertial")
    com, _ = e.origin(e.child(inertial, "origin"))
    mass_element = e.child(inertial, "mass")
    if mass_element is not None and mass_element.get("value") is None:
        e.fail('<mass> needs value="..." in kilograms', mass_element)
    (mass,) = e.numbers(mass_element, "value", 1, (0.0,), bound=math.inf)
    if mass < 0:
        e.fail(f"mass {mass} must be a positive number of kg, or 0 for a massless link", mass_element)
    if mass > MAX_MASS:
        e.fail(
            f"mass {mass:g} kg is above the {MAX_MASS:g} kg deik accepts; URDF masses are in kilograms", mass_element
        )
    return UrdfLink(name, mass, com, element.sourceline)


def _name(element, source: str) -> str:
    name = element.get("name")
    if not name:
        raise FileFormatError(source, f"a <{element.tag}> without a name attribute", line=element.sourceline)
    return name


class _Checked:
    """Reads the children of one `<link>` or `<joint>`; every error names it and the child's line."""

    def __init__(self, element, source: str):
        self.element, self.source = element, source
        self.label = f"{element.tag} {element.get('name')!r}"

    def fail(self, problem: str, at=None):
        line = (self.element if at is None else at).sourceline
        raise FileFormatError(self.source, problem, line=line, element=self.label)

    def child(self, parent, tag: str):
        """The one `<tag>` child of `parent` (None when either is absent)."""
        if parent is None:
            return None
        found = parent.findall(tag)
        if len(found) > 1:
            self.fail(f"has {len(found)} <{tag}> elements in one <{parent.tag}>; keep one", found[1])
        return found[0] if found else None

    def numbers(self, at, attribute: str, count: int, default: tuple, bound: float = MAX_LENGTH) -> tuple:
        """The `count` numbers of attribute `attribute` of element `at`, each within +-`bound`;
        `default` when either is absent."""
        text = None if at is None else at.get(attribute)
        if text is None:
            return default
        shown = f'<{at.tag} {attribute}="{text}">'
        if "$(" in text or "${" in text:
            self.fail(f"{shown} holds a xacro expression; expand it first: xacro ROBOT.urdf.xacro > ROBOT.urdf", at)
        words = WORD.findall(text)
        if len(words) != count:
            needed = "one number" if count == 1 else f"{count} numbers separated by spaces"
            self.fail(f"{shown} holds {len(words)} numbers; write {needed}", at)
        values = []
        for word in words:
            if not DECIMAL.fullmatch(word):
                self.fail(f"{shown}: {word!r} is not a plain decimal number; write numbers like 2, -0.5 or 1.5e-3", at)
            value = float(word)
            if not math.isfinite(value):
                self.fail(f"{shown}: {word:.40} is too large for a 64-bit float", at)
            if abs(value) > bound:
                self.fail(f"{shown}: {value:g} is beyond +-{bound:g}, where poses lose all precision", at)
            values.append(value)
        return tuple(values)

    def origin(self, at) -> tuple[np.ndarray, np.ndarray]:
        """`<origin xyz rpy>` as translation xyz (3,) and roll-pitch-yaw rpy (3,); absent parts are zero."""
        xyz = self.numbers(at, "xyz", 3, (0.0, 0.0, 0.0))
        rpy = self.numbers(at, "rpy", 3, (0.0, 0.0, 0.0))
        return np.array(xyz), np.array(rpy)

    def mimic(self) -> Mimic | None:
        at = self.child(self.element, "mimic")
        if at is None:
            return None
        if not at.get("joint"):
            self.fail('<mimic> needs joint="..." naming the joint it follows', at)
        (multiplier,) = self.numbers(at, "multiplier", 1, (1.0,), bound=MAX_MIMIC_SCALE)
        (offset,) = self.numbers(at, "offset", 1, (0.0,))
        return Mimic(at.get("joint"), multiplier, offset)

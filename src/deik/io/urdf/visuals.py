"""What a URDF robot looks like: `read_visuals(path) -> {link: [Visual, ...]}`, from each link's
`<visual>` elements, for the 3-D view (the solver never reads them: deik.io.urdf.robot).

A visual is a box, a cylinder (along its Z axis), a sphere, a capsule (the common extension,
along Z) or a mesh file, placed by its `<origin>` in the link's frame and coloured by its
`<material>` (inline or named at the robot's level) when it has one. A mesh's `filename` is
resolved to a file here (`resolve_mesh`): `package://NAME/rest` in a folder NAME beside the URDF
or above it (or on ROS_PACKAGE_PATH), `file://` as an absolute path, anything else relative to
the URDF's folder; None when no such file exists (the view then draws the link another way).
Numbers are checked as the reader checks them; errors name the file, the line and the link.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from deik.io.files import FilePath
from deik.io.urdf.elements import _Checked
from deik.io.urdf.safe_xml import read_xml

PRIMITIVES = {
    "box": ("size", 3),
    "cylinder": ("radius length", 2),
    "sphere": ("radius", 1),
    "capsule": ("radius length", 2),
}


@dataclass(frozen=True, eq=False)
class Visual:
    """One `<visual>` of a link: `kind` ("box", "cylinder", "sphere", "capsule" or "mesh"),
    `size` its dimensions (box: x, y, z; cylinder and capsule: radius, length; sphere: radius;
    mesh: its scale x, y, z), placed at `xyz` (3,) and turned by roll-pitch-yaw `rpy` (3,)
    radians in the link's frame; `mesh` the `filename` as written and `path` the file it names
    (None when not found or not a mesh); `rgba` (4,) 0-1 or None without a colour."""

    kind: str
    size: tuple[float, ...]
    xyz: np.ndarray
    rpy: np.ndarray
    mesh: str | None = None
    path: Path | None = None
    rgba: tuple[float, ...] | None = None


def read_visuals(path: FilePath) -> dict[str, list[Visual]]:
    """{link name: its visuals, in file order} of the URDF file at `path` (links without a
    `<visual>` are left out); FileFormatError naming the line of a malformed one."""
    source = str(path)
    robot = read_xml(path)
    named = {}
    for material in robot.iterchildren("material"):
        colour = _colour(_Checked(material, source), material)
        if material.get("name") and colour is not None:
            named[material.get("name")] = colour
    visuals = {}
    for link in robot.iterchildren("link"):
        checked = _Checked(link, source)
        found = [_visual(checked, element, named, Path(source).parent) for element in link.iterchildren("visual")]
        if found:
            visuals[link.get("name")] = found
    return visuals


def _visual(checked: _Checked, element, named: dict, folder: Path) -> Visual:
    xyz, rpy = checked.origin(checked.child(element, "origin"))
    geometry = checked.child(element, "geometry")
    shapes = [] if geometry is None else [child for child in geometry if isinstance(child.tag, str)]
    if len(shapes) != 1:
        checked.fail("a <visual> needs a <geometry> holding one box, cylinder, sphere, capsule or mesh", element)
    shape = shapes[0]
    material = checked.child(element, "material")
    rgba = _colour(checked, material) if material is not None else None
    if rgba is None and material is not None:
        rgba = named.get(material.get("name"))
    if shape.tag == "mesh":
        filename = shape.get("filename")
        if not filename:
            checked.fail('<mesh> needs filename="..."', shape)
        scale = checked.numbers(shape, "scale", 3, (1.0, 1.0, 1.0))
        return Visual("mesh", scale, xyz, rpy, filename, resolve_mesh(filename, folder), rgba)
    if shape.tag not in PRIMITIVES:
        checked.fail(f"<{shape.tag}> is not a URDF geometry; use box, cylinder, sphere, capsule or mesh", shape)
    names, count = PRIMITIVES[shape.tag]
    size = tuple(
        value
        for name in names.split()
        for value in checked.numbers(shape, name, count if name == "size" else 1, (None,))
    )
    if None in size or not all(value > 0 for value in size):
        checked.fail(f"<{shape.tag}> needs positive {' and '.join(names.split())} (metres)", shape)
    return Visual(shape.tag, size, xyz, rpy, rgba=rgba)


def _colour(checked: _Checked, material) -> tuple[float, ...] | None:
    """The rgba (4,) of a `<material>`'s `<color>`, or None without one."""
    colour = checked.child(material, "color")
    if colour is None:
        return None
    rgba = checked.numbers(colour, "rgba", 4, (None,) * 4)
    if None in rgba or not all(0 <= value <= 1 for value in rgba):
        checked.fail('<color rgba="..."> needs 4 numbers from 0 to 1', colour)
    return rgba


def resolve_mesh(filename: str, folder: Path) -> Path | None:
    """The file a URDF mesh `filename` names (see the module notes), or None when there is none."""
    if filename.startswith("package://"):
        package, _, rest = filename.removeprefix("package://").partition("/")
        roots = [folder, *folder.resolve().parents]
        roots += [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
        candidates = [root / package / rest for root in roots] + [root / rest for root in roots if root.name == package]
    elif filename.startswith("file://"):
        candidates = [Path(filename.removeprefix("file://"))]
    else:
        candidates = [folder / filename]
    return next((path for path in candidates if path.is_file()), None)

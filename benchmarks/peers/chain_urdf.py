"""Cut a URDF down to the single path from a base link to a tip link (standard library only).

Every peer loads the same cut file, so each sees exactly the joints deik's `read_urdf(path,
base, tip)` keeps, in the same order (base to tip), with nothing else that could move.
`<visual>`, `<collision>`, materials and transmissions are dropped; `<inertial>` is kept.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

MOVING = ("revolute", "continuous", "prismatic")


def chain_path(root: ET.Element, base: str, tip: str) -> list[ET.Element]:
    """The `<joint>` elements from link `base` down to link `tip`, base first."""
    by_child = {j.find("child").get("link"): j for j in root.findall("joint")}
    path, link = [], tip
    while link != base:
        if link not in by_child:
            raise ValueError(f"link {tip!r} does not lie below link {base!r}")
        joint = by_child[link]
        path.append(joint)
        link = joint.find("parent").get("link")
    return path[::-1]


def cut_urdf(urdf: str | Path, base: str, tip: str, out: str | Path) -> list[str]:
    """Write the base-to-tip path of `urdf` to `out`; returns the moving joint names, base first."""
    root = ET.parse(urdf).getroot()
    joints = chain_path(root, base, tip)
    keep = {base} | {j.find("child").get("link") for j in joints}
    robot = ET.Element("robot", name=root.get("name", "robot"))
    for link in root.findall("link"):
        if link.get("name") in keep:
            copy = ET.SubElement(robot, "link", name=link.get("name"))
            copy.extend(e for e in link if e.tag == "inertial")
    for joint in joints:
        robot.append(joint)
    ET.ElementTree(robot).write(out, encoding="unicode", xml_declaration=True)
    return [j.get("name") for j in joints if j.get("type") in MOVING and j.find("mimic") is None]

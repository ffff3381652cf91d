"""What every picture of a skeleton marks, in a PNG and in the 3-D view: its bones, its root, its
tips (the frames no bone leaves: end effectors and end sites) and its sites; where a problem's
goals put targets; and the length unit the axes are labelled in.

Frames are joints then sites, as in Skeleton.frame_names; a frame's parent is its parent joint
(a site's is the joint that carries it), -1 for the root.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from deik.io.segments import bone_side
from deik.model.skeleton import Skeleton
from deik.objectives import goals as g
from deik.solver.problem import Problem

CHAIN_UNIT = "link lengths"
URDF_METRES_AT_MOST = 50.0  # units end to end (twice the root's farthest): a 25 m robot

# One colour per kind of mark (RGB, 0-255), the same in PNGs and in the 3-D view, each distinct
# enough to be found in a picture by its colour (the picture tests do). Bones are coloured by side
# as a ship's or an aircraft's lights are: left (port) red (a crimson apart from the targets' red),
# right (starboard) green, the middle (spine, head, a robot's links) blue.
COLOURS = {
    "bone": (31, 119, 180),
    "left": (150, 20, 60),
    "right": (0, 150, 120),
    "joint": (20, 50, 100),
    "root": (44, 160, 44),
    "tip": (227, 119, 194),
    "site": (140, 86, 75),
    "target": (214, 39, 40),
    "centre of mass": (255, 127, 14),
    "support": (23, 190, 207),
    "obstacle": (148, 103, 189),
    "contact": (188, 189, 34),
    "compare": (150, 150, 150),
}


def colour(kind: str) -> tuple[float, float, float]:
    """COLOURS[kind] as matplotlib's 0-1 floats."""
    return tuple(c / 255 for c in COLOURS[kind])


def frame_parents(skeleton: Skeleton) -> np.ndarray:
    """(F,) int: the parent joint of every joint then site, -1 for the root."""
    return np.concatenate([skeleton.parents, skeleton.site_joint]).astype(np.int64)


def bones(parents: ArrayLike) -> np.ndarray:
    """(K, 2) int: [parent, child] frame indices of every bone of a tree `parents` (F,)."""
    parents = np.asarray(parents, np.int64)
    children = np.flatnonzero(parents >= 0)
    return np.stack([parents[children], children], axis=1)


def bone_sides(parents: ArrayLike, names: Sequence[str]) -> list[str]:
    """The colour kind of every bone of bones(parents): "left" or "right" when the name of its
    child frame, else of its parent, says a side (LeftKnee, left_hand, hip_r: deik.io.segments
    .bone_side), else "bone". `names` (F,) are the frames' names."""
    sides = []
    for parent, child in bones(parents):
        side = bone_side(names[child]) or bone_side(names[parent])
        sides.append(side or "bone")
    return sides


def roots(parents: ArrayLike) -> np.ndarray:
    """Indices of the frames without a parent (one for a skeleton)."""
    return np.flatnonzero(np.asarray(parents) < 0)


def tips(parents: ArrayLike, points: ArrayLike) -> np.ndarray:
    """Indices of the ends of every chain (end effectors, end sites, a robot's tool frame), from
    the tree `parents` (F,) and one pose's frame positions `points` (F, 3): the frames no bone
    leaves, less those on the way from their parent to a farther child of it (a URDF's fixed
    links between the last joint and its tool frame, a marker on a bone)."""
    parents, points = np.asarray(parents, np.int64), np.asarray(points, float)
    has_child = np.zeros(len(parents), bool)
    has_child[parents[parents >= 0]] = True
    scale = max(float(np.ptp(points, axis=0).max(initial=0.0)), 1e-12)
    out = []
    for leaf in np.flatnonzero(~has_child):
        parent = parents[leaf]
        on_the_way = False
        for other in np.flatnonzero(parents == parent) if parent >= 0 else ():
            offset, farther = points[leaf] - points[parent], points[other] - points[parent]
            length = float(farther @ farther)
            if other != leaf and length > offset @ offset:
                along = np.clip(offset @ farther / length, 0.0, 1.0)
                on_the_way |= bool(np.linalg.norm(offset - along * farther) < 1e-6 * scale)
        if not on_the_way:
            out.append(leaf)
    return np.asarray(out, np.int64)


def spread_out(points: ArrayLike, indices: Iterable[int], fraction: float = 0.06) -> list[int]:
    """Of `indices` into `points` (F, k), those that lie at least `fraction` of the points' size
    from every one kept before them: the tips to name, so that labels never print over each
    other (a foot's heel and toes get one name)."""
    points = np.asarray(points, float)
    size = max(float(np.ptp(points, axis=0).max()), 1e-12)
    kept: list[int] = []
    for k in indices:
        if all(np.linalg.norm(points[k] - points[other]) >= fraction * size for other in kept):
            kept.append(int(k))
    return kept


def length_unit(skeleton: Skeleton, kind: str | None = None, given: str | None = None) -> tuple[str, str]:
    """(unit, where it comes from) for axis labels. `given` (e.g. --units) wins; `kind` is how the
    skeleton was loaded (deik.io.load.Loaded.kind: "urdf", "bvh", "builtin"; None for one built
    in Python). URDF lengths are metres, unless the robot spans URDF_METRES_AT_MOST units or more
    from end to end, as one written in centimetres or millimetres does (a CAD export): then, as
    for a BVH file, which does not say, the unit is read from the body's size (a person some 1.7
    units tall is in metres, 30 in the CMU database's unit, 170 in centimetres:
    deik.cleanup.units.guess_unit) and said so.
    The built-in humanoid is in metres; the paper's chains count link lengths; any other
    skeleton's unit is its own ("length units")."""
    from deik.cleanup.units import guess_unit, span

    if given:
        return given, "given"
    if kind == "urdf":
        size = 2.0 * span(skeleton)
        if size < URDF_METRES_AT_MOST:
            return "m", "URDF"
        return guess_unit(skeleton), f"read from the robot's size, {size:.4g} units (a URDF in metres spans less)"
    if kind == "bvh":
        unit = guess_unit(skeleton)
        cmu = ", the CMU database's 1/0.45 inch" if unit == "cmu" else ""
        return unit, f"read from the body's size (a BVH file does not state its unit){cmu}"
    if kind in ("builtin", None) and skeleton.name == "humanoid":
        return "m", "built-in"
    if kind in ("builtin", None) and skeleton.name.startswith("chain"):
        return CHAIN_UNIT, "built-in chain"
    return "length units", "the skeleton's own"


def goal_targets(problem: Problem) -> list[dict]:
    """Every point a problem's goals aim for, as JSON-ready records in the skeleton's length
    units: {"goal": label, "kind": "target" | "support", "position": (*batch, 3)} for Position,
    Aim and CentreOfMass targets and a ComOverSupport point; {"goal", "kind": "obstacle",
    "centre": (*batch, 3), "radius"} for an Obstacle. Goals without a point (Orientation,
    Comfort, ...) have none."""
    out = []
    for goal in problem.goals:
        if isinstance(goal, (g.Position, g.Aim, g.CentreOfMass)):
            out.append({"goal": goal.label, "kind": "target", "position": np.asarray(goal.target, float).tolist()})
        elif isinstance(goal, g.ComOverSupport):
            out.append({"goal": goal.label, "kind": "support", "position": np.asarray(goal.point, float).tolist()})
        elif isinstance(goal, g.Obstacle):
            centre = np.asarray(goal.centre, float).tolist()
            out.append({"goal": goal.label, "kind": "obstacle", "centre": centre, "radius": float(goal.radius)})
    return out

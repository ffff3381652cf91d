"""The solid body `deik view` draws over a figure's bones, as triangle meshes fixed to its frames.

A URDF robot shows its visual geometry (deik.io.urdf.visuals): its mesh files (STL, OBJ, DAE,
read by trimesh, with pycollada for DAE) where they are found, its boxes, cylinders, spheres and
capsules otherwise. A link whose mesh cannot be found or read, and every link of a robot with
no visual at all, falls back to a capsule along each bone that leaves it (ROBOT_RADIUS of the
robot's height thick). A BVH character or a built-in skeleton gets a capsule along each bone,
its radius the one self-collision gives the bone's joint (deik.model.capsules.default_radii:
from the segment masses, or a tenth of the bone without masses), at least MIN_RADIUS of the
body's height. Solids of the left side are crimson and of the right side green, as the bones
(viz.marks.COLOURS); those of the middle take a robot link's URDF colour, else blue.

trimesh (a dependency of viser, in the `view` extra) builds and reads the meshes; it is imported
here only, when a view is built.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from deik.io.segments import bone_side
from deik.io.urdf.visuals import Visual, read_visuals
from deik.model.capsules import MASSLESS_RADIUS, default_radii
from deik.model.orientations import quaternion_matrix, rpy_matrix
from deik.model.skeleton import Skeleton
from deik.viz.marks import COLOURS, bone_sides, bones
from deik.viz.scene import Figure

MIN_RADIUS = 0.012  # of the body's height: a neck or clavicle without mass stays visible
ROBOT_RADIUS = 0.04  # of a robot's height: the capsules of links without visual geometry
SEGMENTS = 12  # facets around a capsule, cylinder or sphere


@dataclass(frozen=True, eq=False)
class Shape:
    """One solid of the body: a triangle mesh `vertices` (V, 3), `faces` (M, 3) int in the
    coordinates of frame `frame` (an index into the figure's joints then sites), drawn in
    `colour` (RGB 0-255); `kind` says what it stands for ("mesh", "box", "cylinder", "sphere",
    "capsule")."""

    frame: int
    vertices: np.ndarray
    faces: np.ndarray
    colour: tuple[int, int, int]
    kind: str


@dataclass(frozen=True, eq=False)
class Body:
    """A figure's solids (`shapes`) and a line saying where they come from (`note`)."""

    shapes: tuple[Shape, ...]
    note: str


def _trimesh():
    import trimesh

    return trimesh


def _placed(mesh, frame: int, transform: np.ndarray, colour, kind: str) -> Shape:
    """`mesh` (a trimesh.Trimesh) moved by the 4x4 `transform` into frame `frame`."""
    vertices = np.asarray(mesh.vertices, float) @ transform[:3, :3].T + transform[:3, 3]
    return Shape(frame, vertices, np.asarray(mesh.faces, np.int64), tuple(int(c) for c in colour), kind)


def _along(start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """4x4: +Z turned onto the direction from `start` to `end`, origin at their middle."""
    transform = np.eye(4)
    transform[:3, 3] = (start + end) / 2
    direction = end - start
    length = np.linalg.norm(direction)
    if length > 0:
        z = direction / length
        seed = np.eye(3)[int(np.argmin(np.abs(z)))]
        x = np.cross(seed, z)
        x /= np.linalg.norm(x)
        transform[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
    return transform


def _in_frames(figure: Figure) -> tuple[np.ndarray, np.ndarray]:
    """(bones (K, 2) [start, end] frame indices, each bone's end (K, 3) in its start frame's
    coordinates), from the figure's first step."""
    pairs = bones(figure.parents)
    p, q = figure.positions[0], figure.quaternions_wxyz[0]
    R = quaternion_matrix(q[pairs[:, 0]], "wxyz")
    ends = np.einsum("kji,kj->ki", R, p[pairs[:, 1]] - p[pairs[:, 0]])
    return pairs, ends


def body_height(figure: Figure) -> float:
    """The extent of the figure's first step, length units (the largest of x, y, z)."""
    return max(float(np.ptp(figure.positions[0], axis=0).max()), 1e-9)


def bone_capsules(figure: Figure, radii: np.ndarray | None = None, only: Sequence[int] | None = None) -> list[Shape]:
    """A capsule along every bone of `figure` (or every bone leaving a frame of `only`), of the
    radius of the joint it leaves (`radii` (J,); None: MASSLESS_RADIUS of the longest bone
    leaving it) for that joint's main bone (its longest on the joint's own side), of at most the
    radius of the joint it reaches for the others, and at least MIN_RADIUS of the body's height; coloured by side."""
    trimesh = _trimesh()
    pairs, ends = _in_frames(figure)
    lengths = np.linalg.norm(ends, axis=1)
    if radii is None:
        radii = np.zeros(figure.n_joints)
        np.maximum.at(radii, pairs[:, 0], MASSLESS_RADIUS * lengths)
    # a joint's radius thickens its main bone: the longest of those that stay on its side (a
    # spine, a thigh); its other bones (from a chest out to the shoulders, from the hips out to
    # each hip joint) are no thicker than the joint they reach, so a torso does not swell into
    # the shoulders
    sides = bone_sides(figure.parents, figure.names)
    same = np.array([side == (bone_side(figure.names[start]) or "bone") for (start, _), side in zip(pairs, sides)])
    rank = lengths + np.where(same, np.inf, 0.0)  # a bone on the joint's side before any other
    main = np.zeros(figure.n_joints, np.int64)
    for k in np.argsort(rank):  # the last written is the best
        main[pairs[k, 0]] = k
    is_main = main[pairs[:, 0]] == np.arange(len(pairs))
    reached = np.where(pairs[:, 1] < figure.n_joints, radii[np.minimum(pairs[:, 1], figure.n_joints - 1)], np.inf)
    bone_radii = np.where(is_main, radii[pairs[:, 0]], np.minimum(radii[pairs[:, 0]], reached))
    bone_radii = np.maximum(bone_radii, MIN_RADIUS * body_height(figure))
    shapes = []
    for (start, _), offset, length, radius, side in zip(pairs, ends, lengths, bone_radii, sides):
        if only is not None and start not in only:
            continue
        capsule = trimesh.creation.capsule(height=length, radius=radius, count=[SEGMENTS, SEGMENTS // 2])
        shapes.append(_placed(capsule, int(start), _along(np.zeros(3), offset), COLOURS[side], "capsule"))
    return shapes


def _primitive(visual: Visual):
    """The trimesh of a primitive visual, centred at its origin, along Z."""
    trimesh = _trimesh()
    if visual.kind == "box":
        return trimesh.creation.box(extents=visual.size)
    if visual.kind == "sphere":
        return trimesh.creation.icosphere(subdivisions=2, radius=visual.size[0])
    radius, length = visual.size
    if visual.kind == "cylinder":
        return trimesh.creation.cylinder(radius=radius, height=length, sections=SEGMENTS)
    return trimesh.creation.capsule(height=length, radius=radius, count=[SEGMENTS, SEGMENTS // 2])


def _mesh(visual: Visual):
    """The trimesh of a mesh visual's file, scaled; None when it is missing or unreadable."""
    if visual.path is None:
        return None
    try:
        mesh = _trimesh().load(visual.path, force="mesh")
    except Exception:  # a corrupt or unsupported file: the link is drawn another way, and the note says so
        return None
    if len(getattr(mesh, "faces", ())) == 0:
        return None
    mesh.apply_scale(visual.size)
    return mesh


def _colour(visual: Visual, side: str) -> tuple[int, int, int]:
    """A sided link's side colour, else the URDF's, else the middle's."""
    if side != "bone" or visual.rgba is None:
        return COLOURS[side]
    return tuple(int(round(255 * c)) for c in visual.rgba[:3])


def robot_body(path: str | Path, figure: Figure) -> Body:
    """The solids of URDF robot `path` (drawn as `figure`): each selected link's visuals,
    capsules where a link's mesh is missing or the robot has no visual."""
    visuals = read_visuals(path)
    names = list(figure.names)
    shapes, missing, counts = [], [], {}
    for link, items in visuals.items():
        if link not in names:
            continue  # outside the selected chain
        frame = names.index(link)
        for visual in items:
            mesh = _mesh(visual) if visual.kind == "mesh" else _primitive(visual)
            if mesh is None:
                missing.append((frame, visual.mesh))
                continue
            transform = np.eye(4)
            transform[:3, :3], transform[:3, 3] = rpy_matrix(visual.rpy), visual.xyz
            shapes.append(_placed(mesh, frame, transform, _colour(visual, bone_side(link) or "bone"), visual.kind))
            counts[visual.kind] = counts.get(visual.kind, 0) + 1
    # a robot's links are not a body of flesh: one radius for every link, from its size
    radii = np.full(figure.n_joints, ROBOT_RADIUS * body_height(figure))
    if not shapes:
        capsules = bone_capsules(figure, radii)
        why = "its meshes were not found" if missing else "it has no visual geometry"
        return Body(tuple(capsules), f"body: capsules along the links ({why})")
    note = "body: the URDF's visuals (" + ", ".join(f"{kind} x{n}" for kind, n in counts.items()) + ")"
    if missing:
        shapes += bone_capsules(figure, radii, only=sorted({frame for frame, _ in missing}))
        files = ", ".join(sorted({name for _, name in missing}))
        note += f"; meshes not found or unreadable, drawn as capsules: {files}"
    return Body(tuple(shapes), note)


def character_body(skeleton: Skeleton | None, figure: Figure) -> Body:
    """Capsules along the bones of a character or built-in skeleton (`skeleton` None: a pose
    file's figure, radii from the bone lengths)."""
    if skeleton is None:
        return Body(tuple(bone_capsules(figure)), "body: capsules along the bones, a tenth of each bone thick")
    source = "sized from the segment masses" if skeleton.total_mass > 0 else "a tenth of each bone thick"
    return Body(tuple(bone_capsules(figure, default_radii(skeleton))), f"body: capsules along the bones, {source}")

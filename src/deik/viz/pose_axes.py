"""One skeleton pose drawn on one matplotlib axes, 2-D or 3-D perspective: its bones and joints,
the root, the tips (named) and the sites, and marks (targets, centre of mass, support, contacts),
each in its deik.viz.marks colour so that a picture test can find it.

The picture's axes are the columns of `basis` (3, 2) or (3, 3), unit vectors in world
coordinates: a point p is drawn at p @ basis.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from deik.model.skeleton import Skeleton
from deik.viz.marks import bone_sides, bones, colour, frame_parents, roots, spread_out, tips

if TYPE_CHECKING:  # matplotlib is imported when a picture is drawn
    from matplotlib.axes import Axes

# marker, size (points), filled: one style per kind of mark
MARKERS = {
    "joint": ("o", 4, True),
    "site": ("D", 4, True),
    "root": ("s", 10, True),
    "tip": ("^", 9, True),
    "target": ("x", 10, True),
    "support": ("v", 9, False),
    "centre of mass": ("o", 10, False),
    "contact": ("s", 8, False),
}


def _mark(ax, flat: np.ndarray, kind: str, label: str | None) -> None:
    """Points `flat` (N, k) in the style of `kind`."""
    if len(flat) == 0:
        return
    marker, size, filled = MARKERS[kind]
    face = colour(kind) if filled else "none"
    ax.plot(*flat.T, marker, ls="none", color=colour(kind), mfc=face, ms=size, mew=2, label=label)


def draw_skeleton(
    ax: Axes,
    basis: np.ndarray,
    skeleton: Skeleton,
    points: np.ndarray,
    marks: dict | None = None,
    bone_kind: str = "bone",
    legend: bool = True,
    bone_label: str | None = None,
) -> np.ndarray:
    """Draw one pose of `skeleton`: `points` (F, 3) world positions of its joints then sites
    (the tips are labelled with their names); `marks` {kind: points (N, 3)} for kinds of
    MARKERS ("target", "support", "centre of mass", "contact"); `bone_kind` "bone" colours the
    bones by side (viz.marks.bone_sides), another kind ("compare" for an overlay, which then gets
    no joint, site, root or tip marks) all in its colour;
    `legend` False leaves the entries out of the axes' legend (a second pose on one axes);
    `bone_label` the middle bones' legend entry (default "bones", or "compared" for an overlay).
    Returns the picture coordinates (N, k) of everything drawn, for fit_axes."""
    parents, n_joints, names = frame_parents(skeleton), skeleton.n_joints, skeleton.frame_names
    points = np.asarray(points, float)
    flat = points @ basis

    def label(text):
        return text if legend else None

    # by side (viz.marks.bone_sides), each side's first bone carrying its legend entry
    sides = bone_sides(parents, names) if bone_kind == "bone" else [bone_kind] * len(bones(parents))
    entries = {
        "left": "left",
        "right": "right",
        bone_kind: bone_label or ("bones" if bone_kind == "bone" else "compared"),
    }
    for k, ((parent, child), side) in enumerate(zip(bones(parents), sides)):
        ax.plot(
            *flat[[parent, child]].T,
            color=colour(side),
            lw=2.5,
            solid_capstyle="round",
            label=label(entries[side]) if side not in sides[:k] else None,
        )
    drawn = [flat]
    if bone_kind == "bone":
        ends = tips(parents, points)
        _mark(ax, flat[:n_joints], "joint", label("joints"))
        _mark(ax, flat[n_joints:], "site", label("sites"))
        _mark(ax, flat[roots(parents)], "root", label("root"))
        _mark(ax, flat[ends], "tip", label("tips"))
        _name_tips(ax, flat, ends, names)
    for kind, values in (marks or {}).items():
        values = np.asarray(values, float).reshape(-1, 3)
        values = values[np.isfinite(values).all(axis=1)]
        _mark(ax, values @ basis, kind, label(kind))
        drawn.append(values @ basis)
    return np.concatenate(drawn)


def fit_axes(ax: Axes, drawn: np.ndarray) -> None:
    """Equal lengths along every axis around everything `drawn` (N, k): a 2-D view keeps its
    aspect; a 3-D view gets one cube (matplotlib would stretch each axis to its own range)."""
    if drawn.shape[1] == 2:
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
        return
    low, high = drawn.min(axis=0), drawn.max(axis=0)
    centre, half = (low + high) / 2, max(float((high - low).max()) / 2, 1e-9) * 1.1
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))


def _name_tips(ax, flat: np.ndarray, ends: np.ndarray, names) -> None:
    """Label the tips with their names, those spread out enough to read (viz.marks.spread_out),
    each on the side of its tip that faces the middle of the body, so that no name runs off the
    picture."""
    middle = (flat[:, 0].min() + flat[:, 0].max()) / 2
    for end in spread_out(flat, ends):
        right = flat[end, 0] > middle
        text = f"{names[end]}  " if right else f"  {names[end]}"
        ax.text(*flat[end], text, fontsize="x-small", color="0.2", ha="right" if right else "left")

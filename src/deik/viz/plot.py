"""Pictures of poses as PNG files (matplotlib, imported only when a picture is drawn).

Two projections: "2d" draws a planar chain in its XY plane and a 3-D skeleton as a front view and
a side view with the skeleton's `up` axis vertical; "3d" draws one perspective view, up
vertical, that shows depth. Every picture marks the root, the tips and the sites
(deik.viz.marks), the targets and the centre of mass, and labels its axes with the length unit.
Files are written atomically: a reader sees the old file or the complete new one.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.io.atomic import save_atomically
from deik.io.files import FilePath
from deik.model.joints import ROTATE
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.solver.problem import Problem
from deik.solver.result import Result
from deik.viz.marks import colour, goal_targets, length_unit
from deik.viz.pose_axes import draw_skeleton, fit_axes

if TYPE_CHECKING:  # matplotlib is imported when a picture is drawn
    from matplotlib.figure import Figure, SubFigure

VIZ_HINT = 'drawing poses needs matplotlib: pip install "deik[viz]"'
PROJECTIONS = ("2d", "3d")


def require_matplotlib() -> ModuleType:
    """pyplot on the file-only Agg backend; ImportError with the install command if missing."""
    try:
        import matplotlib
    except ImportError:
        raise ImportError(VIZ_HINT) from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def is_planar(skeleton: Skeleton) -> bool:
    """True when every pose keeps all frames in the z = 0 plane (rotations about Z only)."""
    axes_z = np.abs(skeleton.dof_axis[:, 2])
    rotations_about_z = np.all(np.where(skeleton.dof_kind == ROTATE, np.isclose(axes_z, 1.0), axes_z == 0))
    offsets = np.concatenate([skeleton.offsets, skeleton.site_offset])
    return bool(rotations_about_z and np.all(offsets[:, 2] == 0))


def view_axes(up: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(across, depth, up) unit vectors (3,) of a right-handed frame whose vertical is `up`:
    across is world X unless up is nearly X (then world Z), with its component along up removed."""
    up = np.asarray(up, float) / np.linalg.norm(up)
    seed = np.eye(3)[0] if abs(up[0]) < 0.9 else np.eye(3)[2]
    across = seed - (seed @ up) * up
    across /= np.linalg.norm(across)
    return across, np.cross(up, across), up


def axis_name(v: np.ndarray) -> str:
    """'x', '-z', ... for a world axis direction, 'horizontal' for any other."""
    k = int(np.argmax(np.abs(v)))
    return ("-" if v[k] < 0 else "") + "xyz"[k] if np.isclose(abs(v[k]), 1.0) else "horizontal"


def views(skeleton: Skeleton, projection: str) -> list[tuple[str, np.ndarray]]:
    """[(title, basis (3, 2) or (3, 3) whose columns are the picture's axes in world coordinates)]."""
    if projection not in PROJECTIONS:
        raise InputError(f"projection must be one of {', '.join(PROJECTIONS)}, got {projection!r}")
    across, depth, up = view_axes(skeleton.up)
    if projection == "3d":
        return [("perspective", np.stack([across, depth, up], axis=1))]  # right-handed
    if is_planar(skeleton):
        return [("", np.eye(3)[:, :2])]
    return [("front", np.stack([across, up], axis=1)), ("side", np.stack([-depth, up], axis=1))]


def add_pose_axes(container: Figure | SubFigure, skeleton: Skeleton, projection: str, unit: str) -> list:
    """[(axes, basis)]: one row of views of `skeleton` (views) added to `container` (a matplotlib
    Figure or SubFigure), each axis labelled with its direction and `unit`."""
    out = []
    chosen = views(skeleton, projection)
    for k, (name, basis) in enumerate(chosen):
        three = basis.shape[1] == 3
        options = {"projection": "3d", "proj_type": "persp", "focal_length": 0.5} if three else {}
        ax = container.add_subplot(1, len(chosen), k + 1, **options)
        labels = [f"{axis_name(basis[:, j])} ({unit})" for j in range(basis.shape[1])]
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        if three:
            ax.set_zlabel(labels[2])
        ax.set_title(name)
        out.append((ax, basis))
    return out


@dataclass(frozen=True, kw_only=True)
class PoseMarks:
    """What a pose picture marks besides the skeleton (whose root, tips and sites it always
    marks): `targets` a sequence of points (3,), as crosses; `com` and `support` a point (3,)
    each (the centre of mass, the support point) or None; `obstacles` (centre (3,), radius)
    spheres."""

    targets: ArrayLike = ()
    com: ArrayLike | None = None
    support: ArrayLike | None = None
    obstacles: Iterable[tuple[ArrayLike, float]] = ()


def pose_figure(
    skeleton: Skeleton,
    angles: ArrayLike,
    marks: PoseMarks = PoseMarks(),
    title: str = "",
    projection: str = "2d",
    unit: str | None = None,
) -> Figure:
    """The matplotlib Figure plot_pose saves (see there); the caller closes it."""
    angles = skeleton.check_angles(angles)
    if angles.ndim != 1:
        raise InputError(f"plot_pose draws one pose (D,), got angles of shape {angles.shape}")
    views(skeleton, projection)  # a bad projection fails before matplotlib is loaded
    plt = require_matplotlib()
    points = forward_kinematics(skeleton, angles).p_world_frame
    shown = {"target": marks.targets, "support": [] if marks.support is None else [marks.support]}
    shown["centre of mass"] = [] if marks.com is None else [marks.com]
    two = projection == "2d" and not is_planar(skeleton)
    figure = plt.figure(figsize=(11.0, 5.5) if two else (7.0, 6.5) if projection == "3d" else (5.5, 5.5))
    figure.set_layout_engine("constrained")
    for k, (ax, basis) in enumerate(add_pose_axes(figure, skeleton, projection, unit or length_unit(skeleton)[0])):
        drawn = draw_skeleton(ax, basis, skeleton, points, shown)
        for centre, radius in marks.obstacles:
            _sphere(ax, basis, np.asarray(centre, float), float(radius), plt)
        fit_axes(ax, drawn)
        if k == 0:
            ax.legend(loc="upper left", fontsize="x-small", markerscale=0.8)
    figure.suptitle(title or skeleton.name)
    return figure


def _sphere(ax, basis, centre, radius, plt) -> None:
    """An obstacle: a filled circle in a 2-D view, a wireframe sphere in 3-D."""
    c = centre @ basis
    if basis.shape[1] == 2:
        ax.add_patch(plt.Circle(tuple(c), radius, color=colour("obstacle"), alpha=0.3))
        return
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 16), np.linspace(0, np.pi, 9))
    ball = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1) * radius + c
    ax.plot_wireframe(*np.moveaxis(ball, -1, 0), color=colour("obstacle"), lw=0.6, alpha=0.6)


def plot_pose(
    result_or_skeleton: Result | Skeleton,
    angles: ArrayLike | None,
    path: FilePath,
    marks: PoseMarks = PoseMarks(),
    title: str = "",
    projection: str = "2d",
    unit: str | None = None,
) -> None:
    """Draw one pose to PNG `path`.

    result_or_skeleton: a deik.Result (angles None takes its .angles) or a Skeleton; angles
    (D,) radians / length units; `marks` what else to mark (PoseMarks). projection: "2d" (front
    and side views) or "3d" (one perspective view). unit: the length unit in the axis labels
    (default: viz.marks.length_unit of the skeleton).
    """
    skeleton = getattr(result_or_skeleton, "skeleton", result_or_skeleton)
    if not isinstance(skeleton, Skeleton):
        raise TypeError(f"plot_pose takes a deik.Result or Skeleton, got {type(result_or_skeleton).__name__}")
    if angles is None:
        angles = getattr(result_or_skeleton, "angles", None)
        if angles is None:
            raise InputError("plot_pose needs angles (D,) when given a Skeleton")
    figure = pose_figure(skeleton, angles, marks, title, projection, unit)
    plt = require_matplotlib()
    try:
        save_atomically(path, lambda file: figure.savefig(file, format="png", dpi=100))
    finally:
        plt.close(figure)


def goal_marks(problem: Problem) -> PoseMarks:
    """plot_pose's marks from a Problem's goals (viz.marks.goal_targets): targets of Position /
    Aim / CentreOfMass goals, the support point of a ComOverSupport goal and obstacle spheres."""
    targets, support, obstacles = [], None, []
    for record in goal_targets(problem):
        if record["kind"] == "target":
            targets.extend(np.asarray(record["position"], float).reshape(-1, 3))
        elif record["kind"] == "support":
            support = np.asarray(record["position"], float).reshape(-1, 3)[0]
        else:
            obstacles.append((record["centre"], record["radius"]))
    return PoseMarks(targets=targets, support=support, obstacles=obstacles)


def plot_result(
    problem: Problem, result: Result, path: FilePath, title: str = "", projection: str = "2d", unit: str | None = None
) -> None:
    """plot_pose of an unbatched Result with `problem`'s targets, its support point and the
    pose's centre of mass (when the skeleton has mass)."""
    com = forward_kinematics(result.skeleton, result.angles).p_world_com if result.skeleton.total_mass > 0 else None
    marks = replace(goal_marks(problem), com=com)
    plot_pose(result, result.angles, path, marks, title=title, projection=projection, unit=unit)

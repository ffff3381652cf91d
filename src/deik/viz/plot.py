"""Pictures of poses as PNG files (matplotlib, imported only when a picture is drawn).

Planar chains are drawn in their XY plane; 3-D skeletons as a front view and a side view with
the skeleton's `up` axis vertical. Files are written atomically: a reader sees the old file or
the complete new one, never a half-written one.
"""

from __future__ import annotations

from collections.abc import Sequence
from types import ModuleType

import numpy as np
from numpy.typing import ArrayLike

from deik.io.atomic import save_atomically
from deik.io.files import FilePath
from deik.model.joints import ROTATE
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.objectives import goals as g
from deik.solver.problem import Problem
from deik.solver.result import Result

VIZ_HINT = 'drawing poses needs matplotlib: pip install "deik[viz]"'


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


def _views(skeleton: Skeleton):
    """[(title, horizontal axis (3,), vertical axis (3,), labels)] for the subplots."""
    if is_planar(skeleton):
        return [("", np.eye(3)[0], np.eye(3)[1], ("x", "y"))]
    up = skeleton.up
    seed = np.eye(3)[0] if abs(up[0]) < 0.9 else np.eye(3)[2]
    across = seed - (seed @ up) * up
    across /= np.linalg.norm(across)
    depth = np.cross(across, up)

    def name(v):
        k = int(np.argmax(np.abs(v)))
        return ("-" if v[k] < 0 else "") + "xyz"[k] if np.isclose(abs(v[k]), 1.0) else "horizontal"

    return [("front", across, up, (name(across), name(up))), ("side", depth, up, (name(depth), name(up)))]


def plot_pose(
    result_or_skeleton: Result | Skeleton,
    angles: ArrayLike | None,
    path: FilePath,
    targets: Sequence[ArrayLike] = (),
    com: ArrayLike | None = None,
    support: ArrayLike | None = None,
    title: str = "",
    obstacles: Sequence[tuple[ArrayLike, float]] = (),
) -> None:
    """Draw one pose to PNG `path`.

    result_or_skeleton: a deik.Result (angles None takes its .angles) or a Skeleton; angles
    (D,) radians / length units. Marks: targets, a sequence of points (3,), as crosses; com,
    support: points (3,) (e.g. the centre of mass and the support point), or None for no mark;
    obstacles: (centre (3,), radius) spheres drawn as circles.
    """
    skeleton = getattr(result_or_skeleton, "skeleton", result_or_skeleton)
    if not isinstance(skeleton, Skeleton):
        raise TypeError(f"plot_pose takes a deik.Result or Skeleton, got {type(result_or_skeleton).__name__}")
    if angles is None:
        angles = getattr(result_or_skeleton, "angles", None)
        if angles is None:
            raise ValueError("plot_pose needs angles (D,) when given a Skeleton")
    angles = skeleton.check_angles(angles)
    if angles.ndim != 1:
        raise ValueError(f"plot_pose draws one pose (D,), got angles of shape {angles.shape}")
    plt = require_matplotlib()
    points = forward_kinematics(skeleton, angles).p_world_frame
    parents = np.concatenate([skeleton.parents, skeleton.site_joint])
    views = _views(skeleton)
    figure, axes = plt.subplots(1, len(views), figsize=(5.5 * len(views), 5.5), squeeze=False)
    for ax, (name, across, up, labels) in zip(axes[0], views):
        flat = np.stack([points @ across, points @ up], axis=-1)
        for child, parent in enumerate(parents):
            if parent >= 0:
                ax.plot(*flat[[parent, child]].T, color="0.25", lw=2, solid_capstyle="round")
        ax.plot(*flat[: skeleton.n_joints].T, "o", color="tab:blue", ms=4, label="joints")
        for k, target in enumerate(targets):
            t = np.asarray(target, float)
            ax.plot(t @ across, t @ up, "x", color="tab:red", ms=10, mew=2, label="target" if k == 0 else None)
        for point, style, label in ((com, "o", "centre of mass"), (support, "^", "support")):
            if point is not None:
                p = np.asarray(point, float)
                colour = "tab:orange" if style == "o" else "tab:green"
                ax.plot(p @ across, p @ up, style, color=colour, ms=9, mfc="none", mew=2, label=label)
        for centre, radius in obstacles:
            c = np.asarray(centre, float)
            ax.add_patch(plt.Circle((c @ across, c @ up), radius, color="tab:purple", alpha=0.3))
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        ax.set_title(name)
        ax.grid(alpha=0.3)
    axes[0][0].legend(loc="best", fontsize="small")
    figure.suptitle(title or skeleton.name)
    figure.tight_layout()
    try:
        save_atomically(path, lambda temporary: figure.savefig(temporary, format="png", dpi=100))
    finally:
        plt.close(figure)


def goal_marks(problem: Problem) -> dict:
    """plot_pose's marks from a Problem's goals: targets of Position / Aim / CentreOfMass goals,
    the support point of a ComOverSupport goal and obstacle spheres."""
    marks = {"targets": [], "support": None, "obstacles": []}
    for goal in problem.goals:
        if isinstance(goal, (g.Position, g.Aim, g.CentreOfMass)):
            marks["targets"].extend(np.asarray(goal.target, float).reshape(-1, 3))
        elif isinstance(goal, g.ComOverSupport):
            marks["support"] = np.asarray(goal.point, float).reshape(-1, 3)[0]
        elif isinstance(goal, g.Obstacle):
            marks["obstacles"].append((goal.centre, goal.radius))
    return marks


def plot_result(problem: Problem, result: Result, path: FilePath, title: str = "") -> None:
    """plot_pose of an unbatched Result with `problem`'s targets, its support point and the
    pose's centre of mass (when the skeleton has mass)."""
    com = forward_kinematics(result.skeleton, result.angles).p_world_com if result.skeleton.total_mass > 0 else None
    plot_pose(result, result.angles, path, com=com, title=title, **goal_marks(problem))

"""What `deik view` shows, as plain arrays (no viewer library needed): one skeleton, and maybe a
second to compare, moving over T steps (a clip's frames, a batch's problems, or one pose), and
marks that may change from step to step (targets, contacts, the centre of mass).

Built from a Skeleton and its poses, from a pose JSON (deik.io.pose_json) and from a clip report
(`deik clip --json`); deik.viz.viewer draws it. Lengths are the skeleton's units.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.io.pose_json import PoseFile
from deik.model.kinematics import forward_kinematics
from deik.model.orientations import matrix_quaternion
from deik.model.skeleton import Skeleton
from deik.viz.marks import frame_parents

STEP_KINDS = ("frame", "problem", "pose")  # what one step of a scene is


@dataclass(frozen=True, eq=False)
class Figure:
    """One skeleton over T steps: `names` (F,) its joints then sites, `n_joints` of them joints;
    `parents` (F,) its tree (-1 for the root); world `positions` (T, F, 3) and
    `quaternions_wxyz` (T, F, 4); `com` (T, 3) the centre of mass, or None without masses."""

    name: str
    names: tuple[str, ...]
    n_joints: int
    parents: np.ndarray
    positions: np.ndarray
    quaternions_wxyz: np.ndarray
    com: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Marks:
    """Points of one `kind` (a key of viz.marks.COLOURS: "target", "contact", ...) over T steps:
    `labels` (K,) and `points` (T, K, 3), NaN where a point is absent in a step (a contact that
    is not touching, a reach target outside its frames)."""

    kind: str
    labels: tuple[str, ...]
    points: np.ndarray


@dataclass(frozen=True, eq=False)
class Scene:
    """A figure, an optional one to `compare` (drawn grey, same number of steps), marks, and
    how to present them: `step` ("frame", "problem" or "pose") and `step_time` (seconds per
    frame of a clip, else None); `up` (3,); the length `unit` and where it comes from; the
    `floor` height along up (None: under the lowest point); `obstacles` ((centre (T, 3),
    radius), ...); `notes`, lines of text shown beside the view; `shapes`, the figure's solid
    body (viz.body_shapes.Shape: meshes fixed to its frames)."""

    title: str
    figure: Figure
    up: np.ndarray
    unit: str
    unit_source: str
    step: str = "pose"
    step_time: float | None = None
    compare: Figure | None = None
    marks: tuple[Marks, ...] = ()
    floor: float | None = None
    obstacles: tuple = ()
    notes: tuple[str, ...] = ()
    shapes: tuple = ()

    @property
    def n_steps(self) -> int:
        return len(self.figure.positions)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lowest and highest corners (3,) of everything drawn, over every step."""
        points = [self.figure.positions.reshape(-1, 3)]
        if self.compare is not None:
            points.append(self.compare.positions.reshape(-1, 3))
        points += [m.points.reshape(-1, 3) for m in self.marks]
        points = np.concatenate(points)
        points = points[np.isfinite(points).all(axis=1)]
        return points.min(axis=0), points.max(axis=0)


def figure_from_poses(skeleton: Skeleton, angles: ArrayLike, name: str = "") -> Figure:
    """The Figure of `skeleton` in poses `angles` (T, D) (radians / length units), by forward
    kinematics."""
    angles = skeleton.check_angles(np.atleast_2d(angles))
    kin = forward_kinematics(skeleton, angles)
    return Figure(
        name or skeleton.name,
        skeleton.frame_names,
        skeleton.n_joints,
        frame_parents(skeleton),
        kin.p_world_frame,
        matrix_quaternion(kin.R_world_frame, "wxyz"),
        kin.p_world_com if skeleton.total_mass > 0 else None,
    )


def figure_from_pose_file(pose: PoseFile, name: str = "") -> Figure:
    """The Figure drawn by a pose JSON alone (deik.io.pose_json.PoseFile) from its world frames
    and tree; ValueError naming the file when it lacks them (a file from an older deik, or a
    hand-written pose with angles only), saying how to view it with its skeleton instead."""
    if pose.positions is None or pose.parents is None:
        missing = "world frames" if pose.positions is None else 'skeleton tree ("parents")'
        raise InputError(
            f"{pose.path}: has no {missing} to draw; write it again with `deik solve --out pose.json`, "
            f"or give its skeleton: `deik view SKELETON --pose {pose.path}`"
        )
    return Figure(
        name or pose.skeleton or "pose",
        pose.frame_names,
        pose.n_joints,
        pose.parents,
        pose.positions,
        pose.quaternions_wxyz,
        pose.centre_of_mass,
    )


def target_marks(targets: Iterable[dict], steps: int) -> tuple[tuple[Marks, ...], tuple]:
    """(marks, obstacles) from goal target records (viz.marks.goal_targets as read by
    deik.io.pose_json: points (B, 3)) for a scene of `steps` steps, one step per problem."""
    groups: dict[str, tuple[list, list]] = {}
    obstacles = []
    for record in targets:
        if record["kind"] == "obstacle":
            obstacles.append((np.broadcast_to(record["centre"], (steps, 3)), float(record["radius"])))
            continue
        labels, points = groups.setdefault(record["kind"], ([], []))
        labels.append(record["goal"])
        points.append(np.broadcast_to(np.asarray(record["position"], float), (steps, 3)))
    marks = tuple(Marks(kind, tuple(labels), np.stack(points, axis=1)) for kind, (labels, points) in groups.items())
    return marks, tuple(obstacles)


def with_compare(scene: Scene, other: Figure, source: str) -> Scene:
    """`scene` with `other` drawn beside it for comparison (a one-step figure is held still);
    ValueError naming `source` when the step counts differ."""
    if len(other.positions) not in (1, scene.n_steps):
        raise InputError(
            f"{source}: has {len(other.positions)} {scene.step}s, the viewed file {scene.n_steps}; "
            "compare a clip with one of the same length (e.g. the input of `deik clip` with its output)"
        )
    if len(other.positions) == 1:
        steps = scene.n_steps
        other = replace(
            other,
            positions=np.repeat(other.positions, steps, axis=0),
            quaternions_wxyz=np.repeat(other.quaternions_wxyz, steps, axis=0),
            com=None if other.com is None else np.repeat(other.com, steps, axis=0),
        )
    return replace(scene, compare=other)

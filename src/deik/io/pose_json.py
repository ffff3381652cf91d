"""Reading a pose JSON (`deik solve --out pose.json`, Result.to_dict plus the goals' targets):
the pose for a skeleton (`--start pose.json`, `deik view SKELETON --pose pose.json`), and the
world frames, tree, centre of mass and targets that let `deik view pose.json` draw it alone.

Shapes: one problem's pose is (D,); a batch's (B, D), and then every position is (B, 3).
Every mistake is a FileFormatError (a ValueError) that names the file and says what to do.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from deik.errors import FileFormatError, InputError
from deik.io.files import FilePath, read_json
from deik.model.skeleton import Skeleton

WHAT = "pose (JSON)"
REWRITE = "write it again with `deik solve --out pose.json`"


@dataclass(frozen=True)
class PoseFile:
    """A pose JSON read and checked. `angles` (B, D), `batched` False when the file holds one
    pose (D,) (then B = 1); `dof_names` None when the file does not say; `frame_names` (F,)
    joints then sites, `n_joints` of them joints; `parents` (F,) int, the tree (-1 for the
    root), None in a file without one; world frames `positions` (B, F, 3) and
    `quaternions_wxyz` (B, F, 4), None without them; `centre_of_mass` (B, 3) or None; `up`
    (3,) or None; `targets` the goals' target records (viz.marks.goal_targets), points (B, 3);
    `length_unit` the unit `deik solve` named for the skeleton's lengths, or None."""

    path: str
    skeleton: str
    dof_names: tuple[str, ...] | None
    angles: np.ndarray
    batched: bool
    frame_names: tuple[str, ...] = ()
    n_joints: int = 0
    parents: np.ndarray | None = None
    positions: np.ndarray | None = None
    quaternions_wxyz: np.ndarray | None = None
    centre_of_mass: np.ndarray | None = None
    up: np.ndarray | None = None
    targets: tuple[dict, ...] = ()
    length_unit: str | None = None


def _numbers(path: str, value, shape_end: tuple[int, ...], what: str, batch: int) -> np.ndarray:
    """`value` as a finite float array of shape (batch, *shape_end), a lone (*shape_end) broadcast."""
    try:
        array = np.asarray(value, np.float64)
    except (TypeError, ValueError):
        raise FileFormatError(path, f"{what} must hold numbers; {REWRITE}") from None
    if array.shape == shape_end:
        array = np.broadcast_to(array, (batch, *shape_end))
    if array.shape != (batch, *shape_end) or not np.isfinite(array).all():
        raise FileFormatError(
            path, f"{what} must be {batch} x {list(shape_end)} finite numbers, got shape {array.shape}; {REWRITE}"
        )
    return np.array(array)


def read_pose_json(path: FilePath) -> PoseFile:
    """The pose JSON at `path`, checked: its "angles" and "dof_names" always; its world frames,
    tree, centre of mass, up and targets where present (older files and hand-written poses
    carry only the angles)."""
    path = str(path)
    data = read_json(path, WHAT)
    if not isinstance(data, dict) or "angles" not in data:
        raise FileFormatError(path, 'has no "angles": give a pose JSON as `deik solve --out pose.json` writes it')
    try:
        angles = np.asarray(data["angles"], np.float64)
    except (TypeError, ValueError):
        angles = np.empty(0)
    if angles.ndim not in (1, 2) or angles.size == 0 or not np.isfinite(angles).all():
        raise FileFormatError(path, f'"angles" must be finite numbers, one list per pose; {REWRITE}')
    batched, angles = angles.ndim == 2, np.atleast_2d(angles)
    names = data.get("dof_names")
    if names is not None and not (
        isinstance(names, list) and len(names) == angles.shape[1] and all(isinstance(n, str) for n in names)
    ):
        raise FileFormatError(path, f'"dof_names" must list one name per angle ({angles.shape[1]}); {REWRITE}')
    pose = PoseFile(path, str(data.get("skeleton", "")), None if names is None else tuple(names), angles, batched)
    if not isinstance(data.get("joints"), dict) or not isinstance(data.get("sites"), dict):
        return pose
    return _with_frames(pose, data)


def _with_frames(pose: PoseFile, data: dict) -> PoseFile:
    """`pose` with the world frames, tree, centre of mass, up and targets of `data`."""
    path, batch = pose.path, len(pose.angles)
    joints, sites = data["joints"], data["sites"]
    names = (*joints, *sites)
    frames = [*joints.values(), *sites.values()]
    if not frames or not all(isinstance(f, dict) and "position" in f and "quaternion_wxyz" in f for f in frames):
        raise FileFormatError(path, f'every joint and site needs a "position" and a "quaternion_wxyz"; {REWRITE}')
    positions = [_numbers(path, f["position"], (3,), f"{n!r} position", batch) for n, f in zip(names, frames)]
    turns = [_numbers(path, f["quaternion_wxyz"], (4,), f"{n!r} quaternion_wxyz", batch) for n, f in zip(names, frames)]
    com, up, unit = data.get("centre_of_mass"), data.get("up"), data.get("length_unit")
    return replace(
        pose,
        frame_names=names,
        n_joints=len(joints),
        parents=_parents(path, data["parents"], names) if "parents" in data else None,
        positions=np.stack(positions, axis=1),
        quaternions_wxyz=np.stack(turns, axis=1),
        centre_of_mass=None if com is None else _numbers(path, com, (3,), '"centre_of_mass"', batch),
        up=None if up is None else _numbers(path, up, (3,), '"up"', 1)[0],
        targets=_targets(path, data.get("targets", []), batch),
        length_unit=unit if isinstance(unit, str) else None,
    )


def _parents(path: str, parents, names: tuple[str, ...]) -> np.ndarray:
    """The "parents" table {frame: parent joint name or null} as indices (F,), -1 for the root;
    it must name every frame, one root, and parents among the frames."""
    index = {name: k for k, name in enumerate(names)}
    if not isinstance(parents, dict) or set(parents) != set(names):
        raise FileFormatError(path, f'"parents" must name the parent of every joint and site; {REWRITE}')
    out = np.empty(len(names), np.int64)
    for name, parent in parents.items():
        if parent is not None and parent not in index:
            raise FileFormatError(path, f'"parents": {name!r} has parent {parent!r}, which is no frame; {REWRITE}')
        out[index[name]] = -1 if parent is None else index[parent]
    if (out < 0).sum() != 1:
        raise FileFormatError(path, f'"parents" must have exactly one root (parent null); {REWRITE}')
    return out


def _targets(path: str, records, batch: int) -> tuple[dict, ...]:
    """The "targets" list: {"goal", "kind", "position" (batch, 3)} or, for an obstacle,
    {"goal", "kind", "centre" (batch, 3), "radius"}."""
    if not isinstance(records, list):
        raise FileFormatError(path, f'"targets" must be a list of goal targets; {REWRITE}')
    out = []
    for record in records:
        if not isinstance(record, dict) or not {"goal", "kind"} <= set(record):
            raise FileFormatError(path, f'each of "targets" needs a "goal" and a "kind"; {REWRITE}')
        point = "centre" if record["kind"] == "obstacle" else "position"
        entry = {**record, point: _numbers(path, record.get(point), (3,), f"target of {record['goal']!r}", batch)}
        if point == "centre":
            radius = record.get("radius")
            if not isinstance(radius, (int, float)) or isinstance(radius, bool) or not radius > 0:
                raise FileFormatError(path, f"obstacle {record['goal']!r} needs a positive radius; {REWRITE}")
        out.append(entry)
    return tuple(out)


def pose_angles(pose: PoseFile, skeleton: Skeleton, flag: str) -> np.ndarray:
    """`pose`'s angles (B, D) for `skeleton`; ValueError naming `flag` and the file when its DOF
    names are not the skeleton's (a pose of another robot, or of other --base/--tip links)."""
    if pose.angles.shape[1] != skeleton.n_dofs:
        raise InputError(
            f"{flag} {pose.path}: its angles hold {pose.angles.shape[1]} values, the skeleton has "
            f"{skeleton.n_dofs} DOFs"
        )
    if pose.dof_names is not None and list(pose.dof_names) != list(skeleton.dof_names):
        raise InputError(
            f"{flag} {pose.path}: its dof_names {list(pose.dof_names)} are not this skeleton's "
            f"{list(skeleton.dof_names)}; give a pose written for the same skeleton, base and tips"
        )
    return pose.angles

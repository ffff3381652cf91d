"""Problems written as TOML files, and the skeleton specs shared with the command line.

A problem file names a skeleton, optional solver settings and one `[[goal]]` table per goal
(lengths in metres or the skeleton's length unit, angles as noted; docs/conventions.md)::

    skeleton = "humanoid"        # "chain:N" (planar, N links), "chain3d:N", "humanoid", or a
                                 # .bvh / .urdf file (relative to this file's folder)
    limits = "reflect"           # optional: "reflect", "clip", "penalty" or "paper"

    [settings]                   # optional: population, generations, strategy, F, CR, seed,
    population = 256             # patience, device ("cpu" | "gpu"), dtype ("float32" | "float64")
    seed = 1

    [[goal]]
    type = "position"            # place joint or site `frame` at `target`
    frame = "left_hand"
    target = [0.23, 1.0, 0.25]
    level = 1                    # every goal may set weight, mu, level and tolerance
    tolerance = 0.01             # length units (default 0.001) or radians (default 0.1 degree)

    [[goal]]
    type = "orientation"         # exactly one of: target = 3x3 rotation matrix, pose = 4x4
    frame = "head"               # homogeneous pose, quaternion_wxyz = [w, x, y, z],
    rpy_degrees = [0, 20, 0]     # quaternion_xyzw = [x, y, z, w], rpy_degrees = URDF roll,
    tolerance_degrees = 0.1      # pitch, yaw (R = Rz Ry Rx), or euler = "XYZ" (intrinsic)
                                 # with degrees = [a, b, c]; tolerance in radians, or
                                 # tolerance_degrees (orientation and aim goals)

Other types and their fields (optional ones in brackets): "aim" frame, target [axis];
"com" target; "com_over_support" point; "com_in_polygon" frames (a list of names);
"comfort" [mode ("sum" | "max"), joint_weights ("start" | "end", a table {joint = weight} or
one number per DOF)]; "obstacle" centre, radius [bone_radius]; "self_collision" [margin,
radii (a number or a table {joint = radius}), skip (links)]; "floor" height. Every mistake raises a
ValueError naming the file, the goal and the field; nothing is guessed or defaulted silently.

A URDF robot takes the top-level keys of `deik solve`'s flags: base = "link", tip = "link" or
a list of links, up = [x, y, z]. A BVH clip takes segments = "table.json" (masses) and
frame = N: the search then starts around that frame's pose, and comfort goals keep the pose
near it (their reference), as `deik solve --frame N` does. Any skeleton takes
joint_limits = "limits.json", a table of narrower limits (deik.io.limits).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from deik.errors import InputError
from deik.io.files import FilePath, read_toml
from deik.io.limits import read_limits, with_limits
from deik.io.load import SKELETON_FORMS, Loaded, load_skeleton
from deik.objectives import goals as g
from deik.solver.problem import LIMIT_MODES, Problem
from deik.solver.problem_goals import goal_from_table, vector_field
from deik.solver.settings import Settings
from deik.suggest import did_you_mean

URDF_KEYS, BVH_KEYS, FILE_KEYS = ("base", "tip"), ("segments", "frame"), ("up",)
TOP_LEVEL = ("skeleton", "limits", "joint_limits", "settings", "goal") + URDF_KEYS + BVH_KEYS + FILE_KEYS


@dataclass(frozen=True)
class ProblemFile:
    """A problem as a file or the flags of `deik solve` pose it: the Problem, its settings (a
    dict for deik.solve), the skeleton as loaded (deik.io.load.Loaded: its clip for a BVH), the
    clip frame the search starts from (None unless the file sets `frame`) and the pose (D,)
    the search starts around (that frame's, or None: anywhere within the limits)."""

    problem: Problem
    settings: dict
    loaded: Loaded
    frame: int | None = None
    start: np.ndarray | None = None


def load_problem(path: FilePath) -> ProblemFile:
    """Read TOML file `path`: its Problem, settings dict (deik.solve(problem, **settings)),
    loaded skeleton and start frame (see ProblemFile)."""
    path = str(path)
    data = read_toml(path, "problem (TOML)")
    for key in data:
        if key not in TOP_LEVEL:
            raise InputError(
                f"{path}: unknown top-level key {key!r}{did_you_mean(key, TOP_LEVEL, 1)} (keys: {', '.join(TOP_LEVEL)})"
            )
    loaded, frame = _skeleton(data, path)
    skeleton = loaded.skeleton
    limits = data.get("limits", "reflect")
    if limits not in LIMIT_MODES:
        raise InputError(f"{path}: field 'limits' must be one of {', '.join(LIMIT_MODES)}, got {limits!r}")
    settings = data.get("settings", {})
    names = list(Settings.__dataclass_fields__)
    if not isinstance(settings, dict):
        raise InputError(f"{path}: 'settings' must be a [settings] table")
    for key in settings:
        if key not in names:
            raise InputError(
                f"{path}: [settings]: unknown setting {key!r}{did_you_mean(key, names, 1)} "
                f"(settings: {', '.join(names)})"
            )
    try:
        Settings(**settings)
    except (ValueError, TypeError) as error:
        raise InputError(f"{path}: [settings]: {error}") from None
    tables = data.get("goal")
    if isinstance(tables, dict):
        raise InputError(f"{path}: write each goal as a [[goal]] table (double brackets), not [goal]")
    if not isinstance(tables, list) or not tables:
        raise InputError(
            f"{path}: no goals; add at least one [[goal]] table, e.g. "
            'type = "position", frame = "tip", target = [x, y, z]'
        )
    goals = [goal_from_table(skeleton, table, n, path) for n, table in enumerate(tables, start=1)]
    pose = None if frame is None else loaded.clip.pose(frame)
    if frame is not None:
        goals = [
            replace(goal, reference=pose) if isinstance(goal, g.Comfort) and goal.reference is None else goal
            for goal in goals
        ]
    try:
        return ProblemFile(Problem(skeleton, goals, limits), dict(settings), loaded, frame, pose)
    except ValueError as error:
        raise InputError(f"{path}: {error}") from None


def _skeleton(data: dict, path: str) -> tuple[Loaded, int | None]:
    """The file's skeleton (a built-in spec, or a .bvh / .urdf path relative to the file's
    folder, with the keys that apply to it) and the BVH frame to start from, or None."""
    if "skeleton" not in data:
        raise InputError(f"{path}: missing field 'skeleton'; set skeleton = {SKELETON_FORMS}")
    spec = data["skeleton"]
    if not isinstance(spec, str):
        raise InputError(f"{path}: field 'skeleton' must be a string: {SKELETON_FORMS}")
    suffix = Path(spec).suffix.lower()
    allowed = URDF_KEYS if suffix == ".urdf" else (BVH_KEYS if suffix == ".bvh" else ())
    allowed += FILE_KEYS if suffix in (".urdf", ".bvh") else ()
    for key in URDF_KEYS + BVH_KEYS + FILE_KEYS:
        if key in data and key not in allowed:
            kind = {**dict.fromkeys(URDF_KEYS, "a URDF robot"), **dict.fromkeys(BVH_KEYS, "a BVH clip")}.get(
                key, "a URDF robot or a BVH clip"
            )
            raise InputError(f"{path}: field {key!r} only applies to {kind}, not skeleton = {spec!r}")
    folder = Path(path).parent
    tip = data.get("tip")
    if tip is not None and not (
        isinstance(tip, str) or (isinstance(tip, list) and tip and all(isinstance(t, str) for t in tip))
    ):
        raise InputError(f"{path}: field 'tip' must be a link name or a list of link names, got {tip!r}")
    if "base" in data and not isinstance(data["base"], str):
        raise InputError(f"{path}: field 'base' must be a link name, got {data['base']!r}")
    segments = data.get("segments")
    if segments is not None and not isinstance(segments, str):
        raise InputError(f"{path}: field 'segments' must be the path of a segment table, got {segments!r}")
    try:
        loaded = load_skeleton(
            str(folder / spec) if allowed else spec,
            base=data.get("base"),
            tip=tip,
            segments=str(folder / segments) if segments else None,
            up=vector_field(data["up"], (3,), path, "up") if "up" in data else None,
        )
    except (ValueError, KeyError, OSError) as error:
        raise InputError(f"{path}: field 'skeleton': {error.args[0] if error.args else error}") from None
    table = data.get("joint_limits")
    if table is not None:
        if not isinstance(table, str):
            raise InputError(f"{path}: field 'joint_limits' must be the path of a limits table (JSON), got {table!r}")
        try:
            limits = read_limits(folder / table, loaded.skeleton)
        except (ValueError, KeyError) as error:
            raise InputError(f"{path}: field 'joint_limits': {error.args[0]}") from None
        loaded = replace(loaded, skeleton=with_limits(loaded.skeleton, limits))
    frame = data.get("frame")
    if frame is not None:
        if not (isinstance(frame, int) and not isinstance(frame, bool) and 0 <= frame < loaded.clip.n_frames):
            raise InputError(
                f"{path}: field 'frame' must be a frame number from 0 to "
                f"{loaded.clip.n_frames - 1} of {spec}, got {frame!r}"
            )
    return loaded, frame

"""Joint limits for any skeleton: a JSON table, a clip's range of motion, a new Skeleton.

A BVH file has no limits (every rotation gets [-pi, pi]) and a URDF's may be wider than a task
allows. A limits table narrows them; DE then samples and keeps every pose inside. The table
maps DOF names to [lower, upper], degrees for rotations and length units for translations::

    {"LeftKnee.Zrotation": [-150, 0], "Hips.Xposition": [-2.0, 2.0]}

A DOF the table leaves out keeps its limits. `range_of_motion` measures a table from a clip:
each DOF's extremes over every frame plus a margin, so a clip fix or a new pose stays within
what the performer did (`deik limits CLIP.bvh --margin 10 --out limits.json`).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from deik.errors import FileFormatError, InputError, UnknownNameError
from deik.io.atomic import write_json_atomically
from deik.io.files import FilePath, numbers_value, read_json
from deik.io.motion import Clip, held_translations, message_prefix
from deik.model.joints import ROTATE
from deik.model.skeleton import Skeleton
from deik.suggest import did_you_mean


def with_limits(skeleton: Skeleton, limits: dict[str, tuple[float, float]]) -> Skeleton:
    """`skeleton` with the DOFs named in `limits` ({dof name: (lower, upper)}, radians or
    length units) given those limits. A hinge's (a rotation short of whole turns: a robot's
    joint) only narrow its own: it cannot turn further than its URDF says; a BVH joint's
    rotations turn whole turns and its translations' limits are the capture's range, which a
    table may widen. Unknown names raise a KeyError with close matches; non-finite or inverted
    limits, or a hinge's past its own, an InputError naming the DOF (rotations in degrees, as
    the table gives them)."""
    lower, upper = skeleton.lower.copy(), skeleton.upper.copy()
    for name, bounds in limits.items():
        if name not in skeleton.dof_names:
            raise UnknownNameError(_not_a_dof(skeleton, name))
        low, high = (float(b) for b in bounds)
        d = skeleton.dof_names.index(name)
        shown = _shown(skeleton, d)
        if not (math.isfinite(low) and math.isfinite(high) and low <= high):
            raise InputError(f"DOF {name!r}: limits must be finite with lower <= upper, got {shown(low, high)}")
        hinge = skeleton.dof_kind[d] == ROTATE and not skeleton.full_turns[d]
        if hinge and (low < lower[d] or high > upper[d]):
            raise InputError(
                f"DOF {name!r}: limits {shown(low, high)} go past the skeleton's own {shown(lower[d], upper[d])}; "
                "a limits table only narrows them"
            )
        lower[d], upper[d] = low, high
    return replace(skeleton, lower=lower, upper=upper)


def _shown(skeleton: Skeleton, d: int):
    """A function writing DOF d's (lower, upper) as the limits table gives them: degrees for a
    rotation, length units for a translation."""
    rotation = skeleton.dof_kind[d] == ROTATE
    return lambda low, high: (
        f"[{math.degrees(low):.6g}, {math.degrees(high):.6g}] degrees" if rotation else f"[{low:.6g}, {high:.6g}]"
    )


def _not_a_dof(skeleton: Skeleton, name: str) -> str:
    """Why `name` keys no DOF, and which key to give: a joint's own DOF names, the joint that
    moves a link (URDF), or close matches."""
    try:
        dofs = skeleton.joint_dofs(name)
    except KeyError as error:
        if name in skeleton.frame_names:  # a link or a site: the skeleton says which name to give
            return f"{error.args[0]}; a limits table is keyed by DOF names"
        return f"DOF {name!r} not found in skeleton {skeleton.name!r}{did_you_mean(name, skeleton.dof_names)}"
    names = ", ".join(skeleton.dof_names[dofs]) or "none"
    return f"{name!r} is a joint; a limits table is keyed by its DOF names ({names})"


def read_limits(path: FilePath, skeleton: Skeleton) -> dict[str, tuple[float, float]]:
    """The table in JSON file `path` for `skeleton`, rotations converted to radians; every
    mistake (an unknown DOF too) raises a FileFormatError naming the file."""
    path = str(path)
    table = read_json(path, "limits (JSON)")
    if not isinstance(table, dict):
        raise FileFormatError(path, 'must be a JSON object {"DOF name": [lower, upper], ...}')
    if not table:
        raise FileFormatError(path, 'lists no DOF: give {"DOF name": [lower, upper], ...}')
    limits = {}
    for name, bounds in table.items():
        if not (isinstance(bounds, list) and len(bounds) == 2):
            raise FileFormatError(path, f"must be [lower, upper] (two numbers), got {bounds!r:.60}", element=name)
        bounds = numbers_value(bounds, path, name, 2)
        if name in skeleton.dof_names and skeleton.dof_kind[skeleton.dof_names.index(name)] == ROTATE:
            bounds = np.radians(bounds)
        limits[name] = (float(bounds[0]), float(bounds[1]))
    try:
        with_limits(skeleton, limits)
    except (KeyError, ValueError) as error:
        raise FileFormatError(path, error.args[0]) from None
    return limits


def range_of_motion(
    clip: Clip, margin_degrees: float, margin_length: float | None = None
) -> dict[str, tuple[float, float]]:
    """{dof name: (lower, upper)} of `clip` (a deik.Clip): each DOF's smallest and largest
    value over the frames (rotations wrapped into [-pi, pi)), widened by the margins and kept
    within the skeleton's own limits. Translations that carry the body through the world (free
    in the skeleton, unlike those the clip holds, deik.io.motion.held_translations) are a path,
    not a range of motion: they are left out unless `margin_length` (length units) is given,
    as pinning them to the capture's exact range would leave a fix no room to lift or shift
    the body."""
    if not isinstance(clip, Clip):
        raise TypeError(f"range_of_motion measures a deik.Clip (deik.read_bvh(path)), got {type(clip).__name__}")
    given = 0.0 if margin_length is None else margin_length
    if not (math.isfinite(margin_degrees) and margin_degrees >= 0 and math.isfinite(given) and given >= 0):
        raise InputError(f"margins must be finite and >= 0, got {margin_degrees} degrees, {margin_length}")
    sk = clip.skeleton
    if clip.n_frames == 0:
        raise InputError(
            f"{message_prefix(clip)}the clip has no frames, so it has no range of motion to measure; "
            "give a clip with motion"
        )
    poses = clip.poses()
    margin = np.where(sk.dof_kind == ROTATE, math.radians(margin_degrees), given)
    lower = np.maximum(poses.min(axis=0) - margin, sk.lower)
    upper = np.minimum(poses.max(axis=0) + margin, sk.upper)
    path = (sk.dof_kind != ROTATE) & ~held_translations(sk, clip.frames)
    measured = ~path if margin_length is None else np.ones(sk.n_dofs, bool)
    return {name: (float(lower[d]), float(upper[d])) for d, name in enumerate(sk.dof_names) if measured[d]}


def clip_within(clip: Clip, skeleton: Skeleton, source: str) -> Clip:
    """`clip` (a deik.Clip) on `skeleton`, the same skeleton with other limits; a ValueError
    naming the first frame and DOF outside them (`source`: where the limits came from)."""
    poses = clip.poses()
    outside = np.argwhere((poses < skeleton.lower - 1e-9) | (poses > skeleton.upper + 1e-9))
    if len(outside):
        n, d = outside[0]
        scale = math.degrees(1.0) if skeleton.dof_kind[d] == ROTATE else 1.0
        raise InputError(
            f"{source}: frame {n} has {skeleton.dof_names[d]} = {poses[n, d] * scale:.6g}, outside its limits "
            f"[{skeleton.lower[d] * scale:.6g}, {skeleton.upper[d] * scale:.6g}] ({len(outside)} values outside in "
            "all); widen the table, or measure it from the clip with `deik limits`"
        )
    return replace(clip, skeleton=skeleton)


def write_limits(path: FilePath, skeleton: Skeleton, limits: dict[str, tuple[float, float]]) -> None:
    """Write `limits` (radians / length units) as a table (degrees for rotations, to 6 decimals
    rounded outward, so that the values they were measured from stay inside), atomically."""
    table = {}
    for name, (low, high) in limits.items():
        rotation = skeleton.dof_kind[skeleton.dof_names.index(name)] == ROTATE
        degrees = (math.floor(math.degrees(low) * 1e6) / 1e6, math.ceil(math.degrees(high) * 1e6) / 1e6)
        table[name] = list(degrees) if rotation else [low, high]
    write_json_atomically(Path(path), table)

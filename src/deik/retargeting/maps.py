"""Joint map files: which source joint or site each target joint or site follows.

TOML or JSON (told apart by the ending: `.json` is JSON), every key optional but `points`:

    scale = "limbs"           # target lengths per source length: "limbs" (each point's rest
                              # distance from the pelvis point, and the pelvis's rest height, target
                              # over source), "height" (the ratio of the mapped points' heights at
                              # rest) or a number
    up = [0, 1, 0]            # the target's up, for a URDF (whose convention is +Z)
    rotation = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]   # target = rotation @ source: its columns are the source's axes
    pelvis = { source = "Hips", target = "middle_pelvis" }   # the target's root: orientation
    torso = { source = "Chest", target = "middle_thorax" }   # orientation goal
    [points]                  # source joint or site = target joint or site
    LeftKnee = "left_lowerleg"
    LeftAnkle_end = { target = "left_foot", offset = [0.15, -0.06, 0.0] }  # in the target
                              # frame's axes, target length units: a point the target has no frame for

Names are checked against both skeletons by `check_map`; every error names the file and key.
docs/retarget.md describes the format and how each entry is used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from deik.errors import FileFormatError
from deik.io.files import FilePath, number_value, numbers_value, read_json_or_toml
from deik.model.skeleton import MAX_LENGTH, Skeleton
from deik.retargeting.keypoints import stature
from deik.suggest import did_you_mean

KEYS = ("scale", "up", "rotation", "pelvis", "torso", "points")


@dataclass(frozen=True)
class PointPair:
    """Source frame `source` followed by target frame `target` moved by `offset` (3,) in the
    target frame's axes (target length units)."""

    source: str
    target: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def site(self) -> str:
        """The target frame that follows: `target`, or a site "retarget_SOURCE" at the offset."""
        return self.target if not any(self.offset) else f"retarget_{self.source}"


@dataclass(frozen=True)
class JointMap:
    """A parsed joint map: `points`, `scale` (None: by height), `limbs` (scale each point by its
    own rest distance from the pelvis point), `up` (3,) or None, `rotation` (3, 3) source axes
    to target axes, `pelvis` and `torso` (source, target) or None, `source` the file."""

    points: tuple[PointPair, ...]
    scale: float | None = None
    limbs: bool = False
    up: tuple[float, float, float] | None = None
    rotation: np.ndarray | None = None
    pelvis: tuple[str, str] | None = None
    torso: tuple[str, str] | None = None
    source: str = "<joint map>"


def _vector(source: str, key: str, value, length: int = 3, bound: float = MAX_LENGTH) -> tuple[float, ...]:
    return numbers_value(value, source, key, length, -bound, bound)


def _pair(source: str, key: str, value) -> tuple[str, str]:
    if not (isinstance(value, dict) and set(value) == {"source", "target"} and all(map(_is_name, value.values()))):
        raise FileFormatError(source, 'must be { source = "JOINT", target = "JOINT" }', element=key)
    return value["source"], value["target"]


def _is_name(value) -> bool:
    return isinstance(value, str) and bool(value)


def _point(source: str, name: str, value) -> PointPair:
    key = f"points.{name}"
    if _is_name(value):
        return PointPair(name, value)
    if isinstance(value, dict) and _is_name(value.get("target")) and set(value) <= {"target", "offset"}:
        offset = _vector(source, f"{key}.offset", value["offset"]) if "offset" in value else (0.0, 0.0, 0.0)
        return PointPair(name, value["target"], offset)
    raise FileFormatError(source, 'must be "TARGET" or { target = "TARGET", offset = [x, y, z] }', element=key)


def _check_one_source_each(source: str, pairs: tuple[PointPair, ...]) -> None:
    """FileFormatError naming both keys when two source points follow one target point (the
    same target frame and offset): one of them is a slip, and the target would be pulled two
    ways (a left knee mapped onto the right one put the wrists 34 cm off)."""
    seen = {}
    for pair in pairs:
        first = seen.setdefault((pair.target, pair.offset), pair.source)
        if first != pair.source:
            raise FileFormatError(
                source,
                f"points.{first} and points.{pair.source} both map onto {pair.target!r}"
                + (f" at offset {list(pair.offset)}" if any(pair.offset) else "")
                + "; give each source point its own target",
                element=f"points.{pair.source}",
            )


def parse_map(data: object, source: str) -> JointMap:
    """A JointMap from the parsed file `data` (a dict); FileFormatError naming the key."""
    if not isinstance(data, dict):
        raise FileFormatError(source, "must be a table of keys (scale, up, rotation, pelvis, torso, points)")
    unknown = [key for key in data if key not in KEYS]
    if unknown:
        raise FileFormatError(
            source, f"unknown key{did_you_mean(unknown[0], KEYS)}; keys: {', '.join(KEYS)}", element=unknown[0]
        )
    points = data.get("points")
    if not isinstance(points, dict) or not points:
        raise FileFormatError(source, 'needs a [points] table: SOURCE = "TARGET" per key point', element="points")
    scale = data.get("scale", "height")
    if scale not in ("height", "limbs"):
        if isinstance(scale, str) or isinstance(scale, bool) or not isinstance(scale, (int, float)):
            raise FileFormatError(
                source, f'must be "limbs", "height" or a number > 0, got {scale!r:.40}', element="scale"
            )
        scale = number_value(scale, source, "scale", 0.0, MAX_LENGTH)
        if scale <= 0:
            raise FileFormatError(source, f'must be "limbs", "height" or a number > 0, got {scale:g}', element="scale")
    if scale == "limbs" and not ("pelvis" in data and isinstance(data["pelvis"], dict)):
        raise FileFormatError(source, 'scale = "limbs" measures from the pelvis: give pelvis too', element="scale")
    rotation = None
    if "rotation" in data:
        rows = data["rotation"]
        if not (isinstance(rows, list) and len(rows) == 3):
            raise FileFormatError(source, "must be 3 rows of 3 numbers", element="rotation")
        rotation = np.array([_vector(source, f"rotation[{k}]", row, bound=2.0) for k, row in enumerate(rows)])
        if not (np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6) and np.linalg.det(rotation) > 0):
            raise FileFormatError(
                source, "must be a rotation matrix (orthonormal rows, determinant +1)", element="rotation"
            )
    pairs = tuple(_point(source, str(name), value) for name, value in points.items())
    _check_one_source_each(source, pairs)
    return JointMap(
        points=pairs,
        scale=None if scale in ("height", "limbs") else float(scale),
        limbs=scale == "limbs",
        up=_up(source, data["up"]) if "up" in data else None,
        rotation=rotation,
        pelvis=_pair(source, "pelvis", data["pelvis"]) if "pelvis" in data else None,
        torso=_pair(source, "torso", data["torso"]) if "torso" in data else None,
        source=source,
    )


def _up(source: str, value) -> tuple[float, float, float]:
    up = _vector(source, "up", value)
    if not 1e-6 <= math.hypot(*up) <= MAX_LENGTH:
        raise FileFormatError(source, f"must be a direction: a non-zero vector, got {list(up)}", element="up")
    return up


def read_map(path: FilePath) -> JointMap:
    """Read the joint map at `path` (TOML, or JSON for `.json`); FileFormatError when malformed."""
    return parse_map(read_json_or_toml(path, "joint map"), str(path))


SIZE_RANGE = 10.0  # the scaled source may be this many times taller or shorter than the target, no more


def _check_up(joint_map: JointMap, target_up: np.ndarray) -> None:
    """FileFormatError when the map's rotation (identity when none) does not take the source's
    up, +Y (a source is turned upright first), to the target's `target_up` (3,): the motion
    would be laid on its side or upside down, its floor no longer under its feet."""
    rotation = np.eye(3) if joint_map.rotation is None else joint_map.rotation
    lands = rotation @ np.array([0.0, 1.0, 0.0])
    if lands @ target_up >= 1.0 - 1e-6:
        return
    words = " ".join(f"{v:g}" for v in np.round(lands, 6) + 0.0)
    up = " ".join(f"{v:g}" for v in np.round(target_up, 6) + 0.0)
    if joint_map.rotation is None:
        fix = f"give `rotation` (target = rotation @ source) taking +Y to {up}, or `up` for a target that stands on +Y"
        raise FileFormatError(joint_map.source, f"the target's up is {up}, the source's +Y: {fix}", element="up")
    flipped = rotation.T @ np.array([0.0, 1.0, 0.0]) @ target_up >= 1.0 - 1e-6
    hint = (
        "; its transpose does (a rotation acts on columns: target = rotation @ source, so its columns, "
        "not its rows, are where the source's X, Y and Z go)"
        if flipped
        else ""
    )
    raise FileFormatError(
        joint_map.source,
        f"takes the source's up (+Y) to {words}, not the target's up {up}{hint}",
        element="rotation",
    )


def check_map(joint_map: JointMap, source_skeleton: Skeleton, target_skeleton: Skeleton) -> None:
    """FileFormatError naming the map's key when a name is not a frame of its skeleton (with
    close names), the pelvis target is not the target's root joint, the `scale` makes the
    source more than SIZE_RANGE times taller or shorter than the target (statures at rest), or
    an offset is longer than the target is tall, or the rotation does not stand the source's up
    (+Y) on the target's (_check_up)."""
    names = [(f"points.{p.source}", p.source, p.target) for p in joint_map.points]
    for key in ("pelvis", "torso"):
        pair = getattr(joint_map, key)
        if pair is not None:
            names.append((key, *pair))
    for key, source_name, target_name in names:
        for name, skeleton, side in (
            (source_name, source_skeleton, "source"),
            (target_name, target_skeleton, "target"),
        ):
            if name not in skeleton.frame_names:
                raise FileFormatError(
                    joint_map.source,
                    f"no joint or site {name!r} in the {side} {skeleton.name!r}"
                    f"{did_you_mean(name, skeleton.frame_names)}",
                    element=key,
                )
    _check_sizes(joint_map, stature(source_skeleton), stature(target_skeleton), target_skeleton.name)
    _check_up(joint_map, np.asarray(target_skeleton.up, float))
    if joint_map.pelvis and joint_map.pelvis[1] != target_skeleton.joint_names[0]:
        raise FileFormatError(
            joint_map.source,
            f"the pelvis target must be the target's root joint {target_skeleton.joint_names[0]!r}",
            element="pelvis",
        )


def _check_sizes(joint_map: JointMap, source_size: float, target_size: float, target_name: str) -> None:
    """FileFormatError when the map's numbers are out of range for the skeletons' sizes
    (statures, length units): see check_map."""
    if joint_map.scale is not None and target_size > 0:
        scaled = joint_map.scale * source_size
        if not (target_size / SIZE_RANGE <= scaled <= target_size * SIZE_RANGE):
            raise FileFormatError(
                joint_map.source,
                f"scale = {joint_map.scale:g} makes the source {scaled:.3g} tall, and the target "
                f"{target_name} is {target_size:.3g} (length units, at rest); give a number near "
                f'{target_size / source_size:.3g} (their heights\' ratio), or "height" or "limbs"',
                element="scale",
            )
    for point in joint_map.points:
        if np.linalg.norm(point.offset) > target_size:
            raise FileFormatError(
                joint_map.source,
                f"offset {list(point.offset)} is longer than the target {target_name!r} is tall "
                f"({target_size:.3g} length units); give it in the target's length unit",
                element=f"points.{point.source}.offset",
            )

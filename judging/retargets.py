"""The independent judge of retargets (benchmarks/retarget_quality.py runs it, tests/retargeting
calls it): nothing here uses deik's report code, its forward kinematics or its contact detection.

Robots are read by yourdfpy (the tests' extra) and posed by its own transforms, turned so that the
map's up (default +Y) is +Y, along which every height here is read, the floating
root (ROOT.X/Y/Zposition, ROOT.Z/X/Yrotation, intrinsic, in the root link's axes) applied on top;
a ball joint (pybullet's `spherical`, which yourdfpy does not read) as the three continuous
joints JOINT.Zrotation, JOINT.Xrotation, JOINT.Yrotation that docs/formats.md says it is, its
shapes dropped (pybullet's <capsule> is no URDF shape);
BVH files are read, written and posed by judging/rigs.py, the clip judge's own (a
joint's local transform is its OFFSET plus its position channels, then its rotation channels
in file order, intrinsic).

Per retarget (judge; lengths in mm of the target, the target's floor at height 0 of its world
for a robot, the floor deik states for the same rig, whose world is the source's; the judge's
own estimate of the source's floor decides what rests):
- contacts: every point of the source (joint or end site) at rest near the floor (rest_mask:
  slower than REST_SPEED statures/s or REST_RATIO x the mean point, within REST_BAND statures
  of its own lowest resting height, which lies within REST_NEAR statures of the floor, for
  REST_TIME s; the stature is the source's standing height, the floor the lower quartile of
  its body's slow lowest point, a root that only carries the body not counted: source_floor)
  is a contact; its target point (through the joint map) must not slide:
  `sliding_max_mm_per_frame` over all of them, `sliding_worst_point`;
- `penetration_max_mm`: the deepest point of the body (every link origin and mapped point of a
  robot, every joint and site of a BVH but its carrier chain) below the floor;
- `step_excess_max`: the largest DOF step between two frames over its allowance, max(velocity
  limit x frame time, STEP_ALLOWANCE x the source's largest joint turn per frame) (<= 1 meets
  it), with `step_excess_count` the (frame, DOF) pairs over it, and `wrap_count` the steps of a
  rotation longer than pi (a +-180 degree wrap or an Euler twin);
- `wrist_distance_max_mm`: the largest distance of a hand (the source's wrists) from its
  scaled source point (the source's directions with the target's limb lengths, the pelvis's
  path scaled by the pelvis heights' ratio), against WRIST_BOUND statures of the target;
- `keypoint_error_mean_mm`: the mean distance of every mapped point from its scaled source;
- `speed_peak_ratio_max`: the largest, over the mapped points, of a point's top speed over its
  scaled source point's (1: as fast; a flicking forearm shows as several), with the point.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from judging.rigs import Rig, format_rig, joint_values, parse_rig, pose_points

# the judge's contact: slower than REST_SPEED statures/s or REST_RATIO x the body's mean point,
# within REST_BAND statures of its own lowest resting height, which lies within REST_NEAR
# statures of the floor, for REST_TIME seconds
REST_SPEED, REST_RATIO, REST_BAND, REST_NEAR, REST_TIME = 0.08, 0.5, 0.02, 0.08, 0.1
STEP_ALLOWANCE = 1.5  # x the source's largest joint turn per frame (or the velocity limit)
WRIST_BOUND = 0.1  # statures of the target: the bound on a hand's distance from its scaled source point
SLIDING_BOUND, PENETRATION_BOUND = 1.0, 2.0  # mm per frame, mm


# --- BVH: read and pose -----------------------------------------------------------------


@dataclass
class Bvh:
    """A BVH file: per node (joints, then End Sites in file order) its name, parent index (-1
    for the root), OFFSET (3,) and channels; `frames` (N, C) in channel order; `frame_time` s."""

    names: list
    parents: list
    offsets: np.ndarray
    channels: list
    frames: np.ndarray
    frame_time: float

    def columns(self, node: int) -> list[int]:
        """The frame columns of node `node`'s channels."""
        start = sum(len(c) for c in self.channels[:node])
        return list(range(start, start + len(self.channels[node])))


def read_bvh_file(path: Path) -> Bvh:
    """Parse a BVH file (judging/rigs.py): its joints, then its End Sites ("JOINT_end")."""
    rig = parse_rig(Path(path).read_text())
    names = [*rig.names, *(name for name, _, _ in rig.sites)]
    parents = [*rig.parents, *(joint for _, joint, _ in rig.sites)]
    offsets = np.concatenate([rig.offsets, np.reshape([offset for _, _, offset in rig.sites], (-1, 3))])
    channels = [list(c) for c in rig.channels] + [[] for _ in rig.sites]
    return Bvh(names, parents, offsets, channels, rig.frames, rig.frame_time)


def as_rig(bvh: Bvh) -> Rig:
    """`bvh` as a judging.rigs.Rig: its nodes with channels or children are joints (first), the
    others End Sites."""
    joints = [p for p in range(len(bvh.names)) if bvh.channels[p] or p in bvh.parents]
    if joints != list(range(len(joints))):
        raise ValueError("a Bvh lists its joints before its End Sites")
    sites = [p for p in range(len(bvh.names)) if p >= len(joints)]
    return Rig(
        tuple(bvh.names[: len(joints)]),
        tuple(bvh.parents[: len(joints)]),
        bvh.offsets[: len(joints)],
        tuple(tuple(c) for c in bvh.channels[: len(joints)]),
        tuple((bvh.names[p], bvh.parents[p], bvh.offsets[p]) for p in sites),
        bvh.frames,
        bvh.frame_time,
    )


def write_bvh_file(path: Path, bvh: Bvh) -> None:
    """Write `bvh` as a BVH file."""
    Path(path).write_text(format_rig(as_rig(bvh)))


def bvh_transforms(bvh: Bvh) -> tuple[np.ndarray, np.ndarray]:
    """(positions (N, P, 3), local rotations (N, P, 3, 3)) of every node in every frame: a
    node's local transform is its OFFSET plus its position channels, then its rotation
    channels in file order, intrinsic (judging.rigs, position channels as displacements)."""
    rig = as_rig(bvh)
    local = joint_values(rig)[0]
    sites = np.broadcast_to(np.eye(3), (len(local), len(rig.sites), 3, 3))
    return pose_points(rig), np.concatenate([local, sites], axis=1)


def stature(bvh: Bvh) -> float:
    """The vertical span (Y) of the rest pose (every channel 0): the standing height."""
    rest = replace(bvh, frames=np.zeros((1, bvh.frames.shape[1])))
    heights = bvh_transforms(rest)[0][0, :, 1]
    return float(np.ptp(heights))


# --- robots: yourdfpy's transforms under a floating root ------------------------------------


@dataclass
class Robot:
    """A URDF read by yourdfpy: its `urdf`, each joint's velocity limit `velocity` {name: rad/s
    or m/s} and whether it is `continuous` {name: bool}."""

    urdf: object
    velocity: dict
    continuous: dict


def read_robot(path: Path) -> Robot:
    """The robot at `path` (yourdfpy, no meshes; ball joints as the module notes say)."""
    import io

    import yourdfpy

    text = balls_as_revolutes(Path(path).read_bytes().rstrip(b"\0"))
    urdf = yourdfpy.URDF.load(io.BytesIO(text), load_meshes=False, build_collision_scene_graph=False)
    velocity = {j.name: (j.limit.velocity if j.limit is not None else None) for j in urdf.robot.joints}
    continuous = {j.name: j.type == "continuous" for j in urdf.robot.joints}
    return Robot(urdf, velocity, continuous)


def balls_as_revolutes(text: bytes) -> bytes:
    """URDF `text` with every spherical joint J written as continuous joints J.Zrotation,
    J.Xrotation, J.Yrotation (in that order, through two massless links), the first at J's
    origin, each with J's <limit velocity>; without a ball, `text` unchanged."""
    from lxml import etree

    root = etree.fromstring(text)
    balls = root.findall("joint[@type='spherical']")
    if not balls:
        return text
    for shape in list(root.iter("visual", "collision")):
        shape.getparent().remove(shape)
    for ball in balls:
        name, limit, origin = ball.get("name"), ball.find("limit"), ball.find("origin")
        ends = [ball.find("parent").get("link"), f"{name}.z", f"{name}.x", ball.find("child").get("link")]
        for k, axis in enumerate("ZXY"):
            joint = etree.SubElement(root, "joint", name=f"{name}.{axis}rotation", type="continuous")
            etree.SubElement(joint, "parent", link=ends[k])
            etree.SubElement(joint, "child", link=ends[k + 1])
            if k == 0 and origin is not None:
                joint.append(origin)
            etree.SubElement(joint, "axis", xyz={"X": "1 0 0", "Y": "0 1 0", "Z": "0 0 1"}[axis])
            if limit is not None and limit.get("velocity"):
                etree.SubElement(joint, "limit", effort="0", velocity=limit.get("velocity"))
            if k < 2:
                etree.SubElement(root, "link", name=ends[k + 1])
        root.remove(ball)
    return etree.tostring(root)


def read_trajectory_csv(path: Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(DOF names, times (N,), values (N, D)) of a trajectory CSV (frame,time_s,<DOFs>)."""
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    values = np.array([[float(v) for v in row] for row in rows[1:]])
    return rows[0][2:], values[:, 1], values[:, 2:]


def robot_links(robot: Robot, names: list[str], values: np.ndarray) -> dict[str, np.ndarray]:
    """{link: (N, 4, 4) world transform} of every link at each row of `values` (N, D) over DOF
    `names`: the six ROOT.* DOFs place the base link (X, Y, Z translation, then intrinsic
    rotations about Z, X, Y), the others are the URDF's joints."""
    urdf = robot.urdf
    root = [k for k, n in enumerate(names) if _is_root(robot, n)]
    by_channel = {names[k].split(".")[-1]: k for k in root}
    joints = [(k, n) for k, n in enumerate(names) if k not in root]
    out = {link: np.zeros((len(values), 4, 4)) for link in urdf.link_map}
    for n, row in enumerate(values):
        base = np.eye(4)
        if root:
            base[:3, 3] = [row[by_channel[c]] for c in ROOT_CHANNELS[:3]]
            angles = [row[by_channel[c]] for c in ROOT_CHANNELS[3:]]
            base[:3, :3] = Rotation.from_euler("ZXY", angles).as_matrix()
        urdf.update_cfg({name: row[k] for k, name in joints})
        for link in urdf.link_map:
            out[link][n] = base @ urdf.get_transform(link, urdf.base_link)
    return out


ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")


def _is_root(robot: Robot, name: str) -> bool:
    """Whether DOF `name` is one of the floating root's, ROOT.CHANNEL with ROOT the base link (a
    ball joint's JOINT.Zrotation is not)."""
    return name in {f"{robot.urdf.base_link}.{channel}" for channel in ROOT_CHANNELS}


# --- the judge --------------------------------------------------------------------------------


def rest_mask(points: np.ndarray, frame_time: float, floor: float, size: float) -> np.ndarray:
    """(N, P) bool: the frames each point of `points` (N, P, 3), Y up, rests near the floor
    at height `floor` (module notes; `size` the stature in the points' units)."""
    height = points[..., 1] - floor
    slow = _slow(points, frame_time, size)
    lowest = np.where(slow, height, np.inf).min(axis=0)
    mask = slow & (height <= lowest + REST_BAND * size) & (lowest <= REST_NEAR * size)
    for p in range(mask.shape[1]):  # rests shorter than REST_TIME do not count
        edges = np.flatnonzero(np.diff(np.concatenate([[0], mask[:, p].astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):
            if (b - a) * frame_time < REST_TIME - 1e-9:
                mask[a:b, p] = False
    return mask


def _slow(points: np.ndarray, frame_time: float, size: float) -> np.ndarray:
    """(N, P) bool: each point of `points` (N, P, 3) slower than REST_SPEED statures/s or than
    REST_RATIO x the mean point of all of them."""
    if len(points) < 2:
        return np.ones(points.shape[:2], bool)
    speed = np.linalg.norm(np.gradient(points, frame_time, axis=0), axis=-1)
    centre = np.linalg.norm(np.gradient(points.mean(axis=1), frame_time, axis=0), axis=-1)
    return speed <= np.maximum(REST_SPEED * size, REST_RATIO * centre)[:, None]


def carrier_chain(bvh: Bvh) -> list[int]:
    """The nodes above the body that only carry it: the root and the nodes below it down to
    the first with more than one child (a "Reference" joint on the ground above the hips);
    none when the root itself branches."""
    chain, node = [], 0
    while True:
        children = [k for k, parent in enumerate(bvh.parents) if parent == node]
        if len(children) != 1:
            return chain
        chain.append(node)
        node = children[0]


def source_floor(source: Bvh, positions: np.ndarray, size: float) -> float:
    """The height `source` rests on, its node positions (N, P, 3) given: the lower quartile,
    over the frames its body's lowest point is slow, of that point's height (the carrier chain
    is no body)."""
    body = np.delete(positions, carrier_chain(source), axis=1)
    lowest = body[..., 1].argmin(axis=1)
    slow = _slow(body, source.frame_time, size)[np.arange(len(body)), lowest]
    heights = body[np.arange(len(body)), lowest, 1]
    return float(np.percentile(heights[slow] if slow.any() else heights, 25))


def largest_turn(bvh: Bvh) -> float:
    """The largest angle (radians) any joint of `bvh` turns between two frames."""
    local = bvh_transforms(bvh)[1]
    if len(local) < 2:
        return 0.0
    relative = np.einsum("npji,npjk->npik", local[:-1], local[1:])
    cosine = (np.trace(relative, axis1=-2, axis2=-1) - 1) / 2
    return float(np.arccos(np.clip(cosine, -1, 1)).max())


def limb_scaled(source: np.ndarray, parents: list[int], lengths: np.ndarray, root: int, root_path: np.ndarray):
    """(N, K, 3) the source points (N, K, 3) with each point's distance from its parent point
    (`parents`, -1 for the root) set to `lengths` (K,), the root point on `root_path` (N, 3)."""
    out = np.zeros_like(source)
    order = sorted(range(len(parents)), key=lambda k: _depth(parents, k))
    for k in order:
        if parents[k] < 0:
            out[:, k] = root_path
            continue
        along = source[:, k] - source[:, parents[k]]
        norm = np.maximum(np.linalg.norm(along, axis=-1, keepdims=True), 1e-12)
        out[:, k] = out[:, parents[k]] + along / norm * lengths[k]
    return out


def _depth(parents: list[int], k: int) -> int:
    return 0 if parents[k] < 0 else 1 + _depth(parents, parents[k])


@dataclass
class Pairing:
    """How the source's points become the target's: `source` (K,) source node names, their
    target positions `target` (N, K, 3) in the target's world, the target's `body` (N, B, 3)
    (every link origin and mapped point of a robot, every joint and site of a BVH but its
    carrier chain), the
    target's rest positions `rest` (K, 3) and rest `rest_body` (B, 3), `pelvis` the source name
    of the target's root point, `floor` the target's floor height, `rotation` (3, 3) source
    axes to target axes; `same_world` for a target in the source's world (the same rig), else
    the target's world has its origin on the floor below the source's root in frame 0."""

    source: list
    target: np.ndarray
    body: np.ndarray
    rest: np.ndarray
    rest_body: np.ndarray
    pelvis: str
    floor: float
    rotation: np.ndarray
    same_world: bool = False


def robot_pairing(robot: Robot, csv_path: Path, joint_map: dict) -> tuple[Pairing, list, np.ndarray, float]:
    """(Pairing, DOF names, values (N, D), frame time) of a robot's trajectory CSV retargeted
    through `joint_map` (the parsed TOML)."""
    names, times, values = read_trajectory_csv(csv_path)
    links = robot_links(robot, names, values)
    moving = [n for n in names if not _is_root(robot, n)]
    rest_links = robot_links(robot, moving, np.zeros((1, len(moving))))

    def place(transforms, target, offset):
        return np.einsum("nij,j->ni", transforms[target], np.append(offset, 1.0))[:, :3]

    points = [(source, *_map_point(value)) for source, value in joint_map["points"].items()]
    upright = _upright(joint_map.get("up", [0.0, 1.0, 0.0]))
    target = np.stack([place(links, t, o) for _, t, o in points], axis=1) @ upright.T
    rest = np.stack([place(rest_links, t, o)[0] for _, t, o in points]) @ upright.T
    origins = np.stack([links[link][:, :3, 3] for link in robot.urdf.link_map], axis=1) @ upright.T
    rest_origins = np.stack([rest_links[link][0, :3, 3] for link in robot.urdf.link_map]) @ upright.T
    rotation = upright @ np.array(joint_map.get("rotation", np.eye(3)), float)
    pairing = Pairing(
        source=[p[0] for p in points],
        target=target,
        body=np.concatenate([origins, target], axis=1),
        rest=rest,
        rest_body=np.concatenate([rest_origins, rest]),
        pelvis=joint_map["pelvis"]["source"],
        floor=0.0,
        rotation=rotation,
    )
    return pairing, names, values, float(np.median(np.diff(times))) if len(times) > 1 else 1.0


def _upright(up) -> np.ndarray:
    """(3, 3) the shortest turn taking the target's `up` (the map's, default +Y) onto +Y, the up
    every measure here reads heights along (a robot standing on +Z is turned about X)."""
    up = np.asarray(up, float) / np.linalg.norm(up)
    if up @ [0.0, 1.0, 0.0] < -1.0 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    return Rotation.align_vectors([[0.0, 1.0, 0.0]], [up])[0].as_matrix()


def _map_point(value) -> tuple[str, np.ndarray]:
    if isinstance(value, str):
        return value, np.zeros(3)
    return value["target"], np.array(value.get("offset", [0.0, 0.0, 0.0]), float)


def rig_pairing(source: Bvh, out: Bvh, floor: float) -> Pairing:
    """Pairing of a same-rig retarget: every node to itself, the floor the source's."""
    positions = bvh_transforms(out)[0]
    rest = bvh_transforms(replace(out, frames=np.zeros((1, out.frames.shape[1]))))[0][0]
    carriers = carrier_chain(out)
    body, rest_body = np.delete(positions, carriers, axis=1), np.delete(rest, carriers, axis=0)
    return Pairing(list(out.names), positions, body, rest, rest_body, out.names[0], floor, np.eye(3), True)


def judge(source: Bvh, pairing: Pairing, wrists: list[str], mm: float, steps: dict | None = None) -> dict:
    """The module notes' figures of one retarget: `source` the source clip, `pairing` its
    target, `wrists` the source names of the hands, `mm` millimetres per target length unit;
    `steps` {"names", "values" (N, D), "frame_time", "robot"} for a robot's DOF steps (None for
    a BVH)."""
    positions = bvh_transforms(source)[0]
    size = stature(source)
    floor = source_floor(source, positions, size)
    index = [source.names.index(name) for name in pairing.source]
    resting = rest_mask(positions, source.frame_time, floor, size)[:, index]
    # the scaled source: the target's limb lengths on the source's directions
    parents = _mapped_parents(source, pairing.source)
    root = pairing.source.index(pairing.pelvis)
    lengths = np.linalg.norm(pairing.rest - pairing.rest[np.maximum(parents, 0)], axis=-1)
    rest_source = bvh_transforms(replace(source, frames=np.zeros((1, source.frames.shape[1]))))[0][0]
    legs = [
        rest[k] @ [0, 1, 0] - body[:, 1].min()
        for rest, k, body in ((rest_source[index], root, rest_source), (pairing.rest, root, pairing.rest_body))
    ]
    origin = positions[0, 0] * [1, 0, 1] + [0, floor, 0]
    mapped = (positions[:, index] - origin) @ pairing.rotation.T
    root_path = mapped[:, root] * legs[1] / legs[0] + (origin if pairing.same_world else 0.0)
    scaled = limb_scaled(mapped, parents, lengths, root, root_path)
    target_size = float(np.ptp(pairing.rest_body[:, 1]))
    error = np.linalg.norm(pairing.target - scaled, axis=-1)
    hands = [pairing.source.index(w) for w in wrists]
    moved = np.linalg.norm(np.diff(pairing.target, axis=0), axis=-1)
    both = resting[1:] & resting[:-1]
    sliding = np.where(both, moved, 0.0)
    worst = np.unravel_index(np.argmax(sliding), sliding.shape) if sliding.size else (0, 0)
    figures = {
        "frames": int(len(positions)),
        "floor_source": floor,
        "resting_points": sorted({pairing.source[k] for k in np.flatnonzero(resting.any(axis=0))}),
        "sliding_max_mm_per_frame": float(sliding.max(initial=0.0) * mm),
        "sliding_worst_point": pairing.source[worst[1]] if sliding.size and sliding.max() > 0 else None,
        "penetration_max_mm": float(max(0.0, (pairing.floor - pairing.body[..., 1]).max()) * mm),
        "wrist_distance_max_mm": float(error[:, hands].max() * mm),
        "wrist_bound_mm": WRIST_BOUND * target_size * mm,
        "keypoint_error_mean_mm": float(error.mean() * mm),
        **_speed_peaks(pairing.source, scaled, pairing.target),
    }
    figures.update(step_figures(source, steps) if steps else {})
    return figures


def _speed_peaks(names: list[str], scaled: np.ndarray, target: np.ndarray) -> dict:
    """The largest, over the mapped points, of a point's top speed between two frames over its
    scaled source point's (a flail or a flick shows here), and which point."""
    if len(target) < 2:
        return {"speed_peak_ratio_max": None, "speed_peak_point": None}
    top = [np.linalg.norm(np.diff(p, axis=0), axis=-1).max(axis=0) for p in (scaled, target)]
    ratio = top[1] / np.maximum(top[0], 1e-9)
    k = int(np.argmax(ratio))
    return {"speed_peak_ratio_max": float(ratio[k]), "speed_peak_point": names[k]}


def _mapped_parents(source: Bvh, names: list[str]) -> list[int]:
    """Each mapped point's nearest mapped ancestor in the source (-1 for none)."""
    out = []
    for name in names:
        node = source.parents[source.names.index(name)]
        while node >= 0 and source.names[node] not in names:
            node = source.parents[node]
        out.append(names.index(source.names[node]) if node >= 0 else -1)
    return out


def step_figures(source: Bvh, steps: dict) -> dict:
    """The DOF steps of a robot's trajectory against their allowance (module notes)."""
    robot, names, values, dt = steps["robot"], steps["names"], steps["values"], steps["frame_time"]
    turn = STEP_ALLOWANCE * largest_turn(source) * dt / source.frame_time if len(values) > 1 else 0.0
    allowance, rotation = np.zeros(len(names)), np.zeros(len(names), bool)
    for d, name in enumerate(names):
        rotation[d] = name.endswith("rotation") if _is_root(robot, name) else True
        limit = robot.velocity.get(name)
        allowance[d] = max(turn, (limit or 0.0) * dt) if rotation[d] else np.inf
    delta = np.abs(np.diff(values, axis=0))
    excess = np.where(rotation, delta / np.maximum(allowance, 1e-12), 0.0)
    over = excess > 1 + 1e-9
    worst = np.unravel_index(np.argmax(excess), excess.shape) if excess.size else (0, 0)
    return {
        "step_excess_max": float(excess.max(initial=0.0)),
        "step_excess_count": int(over.sum()),
        "step_worst": f"{names[worst[1]]} frames {worst[0]}-{worst[0] + 1}" if excess.size else None,
        "wrap_count": int((rotation & (delta > math.pi)).sum()),
        "source_largest_turn_deg": math.degrees(largest_turn(source)),
    }

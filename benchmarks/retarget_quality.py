"""Retargets judged by an independent measurement: every shared clip and hard cases made from
them, onto human.urdf (and robots made from it) and onto the same rig with other proportions.

    PYTHONPATH=src python -m benchmarks.retarget_quality [--quick] [--clips DIR] [--out DIR]

Nothing here uses deik's report code, its forward kinematics or its contact detection. Robots
are read by yourdfpy (the tests' extra) and posed by its own transforms, the floating root
(ROOT.X/Y/Zposition, ROOT.Z/X/Yrotation, intrinsic, in the root link's axes) applied on top;
BVH files are read and posed by the small parser below (a joint's local transform is its OFFSET
plus its position channels, then its rotation channels in file order, intrinsic). Outputs are
read back from the files deik writes (the trajectory CSV, the BVH).

Per clip (lengths in mm of the target, the target's floor at height 0 of its world for a robot,
at the source's floor for the same rig):
- contacts: every point of the source (joint or end site) at rest near the floor (rest_mask:
  within REST_BAND of its own lowest resting height, which lies within REST_NEAR of the floor,
  and slower than REST_SPEED; sizes in statures, the source's standing height) is a contact;
  its target point (through the joint map) must not slide: `sliding_max_mm_per_frame` over all
  of them, `sliding_worst_point`;
- `penetration_max_mm`: the deepest point of the body (every link origin and mapped point of a
  robot, every joint and site of a BVH) below the floor;
- `step_excess_max`: the largest DOF step between two frames over its allowance, max(velocity
  limit x frame time, 1.5 x the source's largest joint turn per frame) (<= 1 meets it), with
  `step_excess_count` the (frame, DOF) pairs over it, and `wrap_count` the steps of a rotation
  longer than pi (a +-180 degree wrap or an Euler twin);
- `wrist_distance_max_mm`: the largest distance of a hand (the source's wrists) from its
  scaled source point (limb-scaled, as the map asks), against WRIST_BOUND statures;
- `keypoint_error_mean_mm`: the mean distance of every mapped point from its scaled source.
Hard cases (make_cases): a clip played backwards, sped up 2x, with its legs 15 % longer, with
noise added to every channel, and as another rig family (centimetres, a Reference root on the
floor above the hips, position channels on every joint, other joint names, 30 fps); robots
made from human.urdf (another joint order, the root turns as continuous joints, velocity
limits halved). Writes retarget_quality.json and retarget_quality.md under --out.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import re
import tempfile
import time
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
HUMAN_URDF = DATA / "robots" / "human.urdf"
URDF_MAP = ROOT / "examples" / "maps" / "shared_bvh_to_human_urdf.toml"
RESULTS = Path(__file__).resolve().parent / "results"
# the judge's contact: slower than REST_SPEED statures/s or REST_RATIO x the body's mean point,
# within REST_BAND statures of its own lowest resting height, which lies within REST_NEAR
# statures of the floor, for REST_TIME seconds
REST_SPEED, REST_RATIO, REST_BAND, REST_NEAR, REST_TIME = 0.08, 0.5, 0.02, 0.08, 0.1
STEP_ALLOWANCE = 1.5  # x the source's largest joint turn per frame (or the velocity limit)
WRIST_BOUND = 0.1  # statures of the target: the bound on a hand's distance from its scaled source point
SLIDING_BOUND, PENETRATION_BOUND = 1.0, 2.0  # mm per frame, mm


# --- BVH: read, pose, write -----------------------------------------------------------------


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
    """Parse a BVH file (a site is named after its joint, "JOINT_end")."""
    text = Path(path).read_text()
    head, motion = re.split(r"^\s*MOTION\s*$", text, maxsplit=1, flags=re.M)
    tokens = head.split()
    names, parents, offsets, channels, stack = [], [], [], [], []
    k = 0
    while k < len(tokens):
        word = tokens[k]
        if word in ("ROOT", "JOINT"):
            names.append(tokens[k + 1])
            k += 2
        elif word == "End":
            names.append(names[stack[-1]] + "_end")
            k += 2
        elif word == "{":
            parents.append(stack[-1] if stack else -1)
            stack.append(len(names) - 1)
            offsets.append(None)
            channels.append([])
            k += 1
        elif word == "}":
            stack.pop()
            k += 1
        elif word == "OFFSET":
            offsets[stack[-1]] = [float(v) for v in tokens[k + 1 : k + 4]]
            k += 4
        elif word == "CHANNELS":
            count = int(tokens[k + 1])
            channels[stack[-1]] = tokens[k + 2 : k + 2 + count]
            k += 2 + count
        else:
            k += 1
    lines = [line for line in motion.strip().splitlines() if line.strip()]
    frame_time = float(lines[1].split(":")[1])
    frames = np.array([[float(v) for v in line.split()] for line in lines[2:]])
    return Bvh(names, parents, np.array(offsets), channels, frames.reshape(len(lines) - 2, -1), frame_time)


def bvh_transforms(bvh: Bvh) -> tuple[np.ndarray, np.ndarray]:
    """(positions (N, P, 3), local rotations (N, P, 3, 3)) of every node in every frame: a
    node's local transform is its OFFSET plus its position channels, then its rotation
    channels in file order, intrinsic."""
    N, P = len(bvh.frames), len(bvh.names)
    position, local = np.zeros((N, P, 3)), np.tile(np.eye(3), (N, P, 1, 1))
    world = np.zeros((N, P, 3, 3))
    for p in range(P):
        columns, names = bvh.columns(p), bvh.channels[p]
        shift = np.tile(bvh.offsets[p], (N, 1))
        axes = "".join(c[0] for c in names if c.endswith("rotation"))
        for column, name in zip(columns, names):
            if name.endswith("position"):
                shift[:, "XYZ".index(name[0])] += bvh.frames[:, column]
        if axes:
            angles = bvh.frames[:, [c for c, n in zip(columns, names) if n.endswith("rotation")]]
            local[:, p] = Rotation.from_euler(axes.upper(), angles, degrees=True).as_matrix()
        parent = bvh.parents[p]
        if parent < 0:
            position[:, p], world[:, p] = shift, local[:, p]
        else:
            position[:, p] = position[:, parent] + np.einsum("nij,nj->ni", world[:, parent], shift)
            world[:, p] = world[:, parent] @ local[:, p]
    return position, local


def write_bvh_file(path: Path, bvh: Bvh) -> None:
    """Write `bvh` as a BVH file."""
    lines = ["HIERARCHY"]
    children = {p: [c for c, parent in enumerate(bvh.parents) if parent == p] for p in range(len(bvh.names))}

    def node(p: int, depth: int) -> None:
        pad = "\t" * depth
        site = not bvh.channels[p] and not children[p]
        kind = "End Site" if site else ("ROOT " if depth == 0 else "JOINT ") + bvh.names[p]
        lines.extend([pad + kind, pad + "{", pad + "\tOFFSET " + " ".join(f"{v:.6f}" for v in bvh.offsets[p])])
        if not site:
            lines.append(pad + f"\tCHANNELS {len(bvh.channels[p])} " + " ".join(bvh.channels[p]))
        for c in children[p]:
            node(c, depth + 1)
        lines.append(pad + "}")

    node(0, 0)
    lines += ["MOTION", f"Frames: {len(bvh.frames)}", f"Frame Time: {bvh.frame_time:.6f}"]
    lines += [" ".join(f"{v:.6f}" for v in row) for row in bvh.frames]
    Path(path).write_text("\n".join(lines) + "\n")


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
    """The robot at `path` (yourdfpy, no meshes)."""
    import yourdfpy

    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    velocity = {j.name: (j.limit.velocity if j.limit is not None else None) for j in urdf.robot.joints}
    continuous = {j.name: j.type == "continuous" for j in urdf.robot.joints}
    return Robot(urdf, velocity, continuous)


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
    root = [k for k, n in enumerate(names) if n.split(".")[-1] in ROOT_CHANNELS]
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


def source_floor(points: np.ndarray, frame_time: float, size: float) -> float:
    """The height the source rests on: the lower quartile, over the frames its lowest point is
    slow, of that point's height."""
    lowest = points[..., 1].argmin(axis=1)
    slow = _slow(points, frame_time, size)[np.arange(len(points)), lowest]
    heights = points[np.arange(len(points)), lowest, 1]
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
    (every link origin and mapped point of a robot, every joint and site of a BVH), the
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
    moving = [n for n in names if n.split(".")[-1] not in ROOT_CHANNELS]
    rest_links = robot_links(robot, moving, np.zeros((1, len(moving))))

    def place(transforms, target, offset):
        return np.einsum("nij,j->ni", transforms[target], np.append(offset, 1.0))[:, :3]

    points = [(source, *_map_point(value)) for source, value in joint_map["points"].items()]
    target = np.stack([place(links, t, o) for _, t, o in points], axis=1)
    rest = np.stack([place(rest_links, t, o)[0] for _, t, o in points])
    origins = np.stack([links[link][:, :3, 3] for link in robot.urdf.link_map], axis=1)
    rest_origins = np.stack([rest_links[link][0, :3, 3] for link in robot.urdf.link_map])
    rotation = np.array(joint_map.get("rotation", np.eye(3)), float)
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


def _map_point(value) -> tuple[str, np.ndarray]:
    if isinstance(value, str):
        return value, np.zeros(3)
    return value["target"], np.array(value.get("offset", [0.0, 0.0, 0.0]), float)


def rig_pairing(source: Bvh, out: Bvh, floor: float) -> Pairing:
    """Pairing of a same-rig retarget: every node to itself, the floor the source's."""
    positions = bvh_transforms(out)[0]
    rest = bvh_transforms(replace(out, frames=np.zeros((1, out.frames.shape[1]))))[0][0]
    return Pairing(list(out.names), positions, positions, rest, rest, out.names[0], floor, np.eye(3), True)


def judge(source: Bvh, pairing: Pairing, wrists: list[str], mm: float, steps: dict | None = None) -> dict:
    """The module notes' figures of one retarget: `source` the source clip, `pairing` its
    target, `wrists` the source names of the hands, `mm` millimetres per target length unit;
    `steps` {"names", "values" (N, D), "frame_time", "robot"} for a robot's DOF steps (None for
    a BVH)."""
    positions = bvh_transforms(source)[0]
    size = stature(source)
    floor = source_floor(positions, source.frame_time, size)
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
    }
    figures.update(step_figures(source, steps) if steps else {})
    return figures


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
        channel = name.split(".")[-1]
        rotation[d] = channel.endswith("rotation") if channel in ROOT_CHANNELS else True
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


# --- hard cases -------------------------------------------------------------------------------

STUDIO_NAMES = {  # the shared rig's joints as another studio names them
    "Hips": "pelvis",
    "RightHip": "thigh_r",
    "RightKnee": "calf_r",
    "RightAnkle": "foot_r",
    "LeftHip": "thigh_l",
    "LeftKnee": "calf_l",
    "LeftAnkle": "foot_l",
    "Chest": "spine_03",
    "Neck": "neck_01",
    "RightShoulder": "upperarm_r",
    "RightElbow": "lowerarm_r",
    "LeftShoulder": "upperarm_l",
    "LeftElbow": "lowerarm_l",
}
LEG_NODES = ("RightKnee", "RightAnkle", "RightAnkle_end", "LeftKnee", "LeftAnkle", "LeftAnkle_end")
SOURCE_CASES = ("backwards", "sped_up", "long_legs", "noisy", "studio")
ROBOT_CASES = ("reordered", "continuous", "slow")


def source_case(bvh: Bvh, case: str, seed: int = 0) -> Bvh:
    """`bvh` made harder (module notes): "backwards", "sped_up" (every other frame), "long_legs"
    (thighs, shins and feet 15 % longer, the root's path kept: the feet sink), "noisy" (1 degree
    on every rotation channel, 3 mm on the root's position) or "studio" (studio_rig)."""
    if case == "backwards":
        return replace(bvh, frames=bvh.frames[::-1].copy())
    if case == "sped_up":
        return replace(bvh, frames=bvh.frames[::2].copy())
    if case == "long_legs":
        offsets = bvh.offsets.copy()
        for name in LEG_NODES:
            offsets[bvh.names.index(name)] *= 1.15
        return replace(bvh, offsets=offsets)
    if case == "noisy":
        rng = np.random.default_rng(seed)
        frames = bvh.frames.copy()
        for p, names in enumerate(bvh.channels):
            for column, name in zip(bvh.columns(p), names):
                frames[:, column] += rng.normal(0.0, 1.0 if name.endswith("rotation") else 0.003, len(frames))
        return replace(bvh, frames=frames)
    if case == "studio":
        return studio_rig(bvh, seed)
    raise ValueError(f"unknown case {case!r}")


def studio_rig(bvh: Bvh, seed: int = 0) -> Bvh:
    """The clip on another rig family: centimetres, a "Reference" root on the floor below the
    hips (its own six channels carry the hips' ground track), position channels on every joint
    (the capture's small values, 0.01 cm of drift), the joints renamed (STUDIO_NAMES), 30 fps."""
    rng = np.random.default_rng(seed)
    step = max(1, round(1 / 30 / bvh.frame_time))
    frames = bvh.frames[::step] * 1.0
    N = len(frames)
    positions = bvh_transforms(replace(bvh, frames=frames))[0]
    ground = positions[:, 0] * [1, 0, 1] * 100.0  # cm: the hips' track on the floor
    hips_rest = bvh.offsets[0] * 100.0 + [0, 100.0 * positions[0, 0, 1], 0]
    names = ["Reference"] + [STUDIO_NAMES.get(n, n) for n in bvh.names]
    names = [STUDIO_NAMES[n[:-4]] + "_end" if n.endswith("_end") else n for n in names]
    parents = [-1] + [p + 1 for p in bvh.parents]
    offsets = np.concatenate([[np.zeros(3)], bvh.offsets * 100.0])
    offsets[1] = hips_rest
    six = ["Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"]
    channels = [six] + [six if c else [] for c in bvh.channels]
    columns = [np.concatenate([ground, np.zeros((N, 3))], axis=1)]
    for p, names_p in enumerate(bvh.channels):
        if not names_p:
            continue
        values = frames[:, bvh.columns(p)]
        rotation = values[:, [k for k, n in enumerate(names_p) if n.endswith("rotation")]]
        if p == 0:
            moved = values[:, :3] * 100.0 - ground - hips_rest
        else:
            moved = rng.normal(0.0, 0.01, (N, 3))
        columns.append(np.concatenate([moved, rotation], axis=1))
    return Bvh(names, parents, offsets, channels, np.concatenate(columns, axis=1), bvh.frame_time * step)


def studio_map(joint_map: dict) -> dict:
    """`joint_map` (parsed) with its source names as studio_rig names them, and the target's
    offsets kept (the target is the same robot)."""

    def rename(name: str) -> str:
        return STUDIO_NAMES[name[:-4]] + "_end" if name.endswith("_end") else STUDIO_NAMES[name]

    out = dict(joint_map)
    out["points"] = {rename(s): t for s, t in joint_map["points"].items()}
    for key in ("pelvis", "torso"):
        if key in joint_map:
            out[key] = {"source": rename(joint_map[key]["source"]), "target": joint_map[key]["target"]}
    return out


def robot_case(urdf_text: str, case: str) -> str:
    """human.urdf's text made harder: "reordered" (its joints in reverse file order: another
    DOF order), "continuous" (shoulders' first and elbows' second joints continuous) or
    "slow" (every velocity limit halved)."""
    joints = re.findall(r"<joint\b.*?</joint>", urdf_text, flags=re.S)
    if case == "reordered":
        body = urdf_text
        for joint in joints:
            body = body.replace(joint, "", 1)
        return body.replace("</robot>", "\n".join(reversed(joints)) + "\n</robot>")
    if case == "continuous":
        out = urdf_text
        for joint in joints:
            name = re.search(r'name="([^"]+)"', joint)[1]
            if re.fullmatch(r"(left|right)_(shoulder_Z|elbow_Y)", name):
                changed = joint.replace('type="revolute"', 'type="continuous"')
                changed = re.sub(r'\s(lower|upper)="[^"]*"', "", changed)
                out = out.replace(joint, changed)
        return out
    if case == "slow":
        return re.sub(r'velocity="([^"]+)"', lambda m: f'velocity="{float(m[1]) / 2:g}"', urdf_text)
    raise ValueError(f"unknown case {case!r}")


def toml_text(joint_map: dict) -> str:
    """A joint map as TOML (the few shapes maps use)."""

    def value(v) -> str:
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    lines = [f"{k} = {value(v)}" for k, v in joint_map.items() if k != "points"]
    lines.append("[points]")
    lines += [f"{k} = {value(v)}" for k, v in joint_map["points"].items()]
    return "\n".join(lines) + "\n"


# --- the runs ---------------------------------------------------------------------------------

WRISTS = ["LeftElbow_end", "RightElbow_end"]
STUDIO_WRISTS = ["lowerarm_l_end", "lowerarm_r_end"]
SCALE = "LeftHip=1.15,RightHip=1.15,LeftShoulder=0.9,RightShoulder=0.9"  # the same rig, other proportions


def deik_retarget(arguments: list[str]) -> float:
    """Run `deik retarget ARGUMENTS` in this process; its wall time (s). RuntimeError on failure."""
    from deik.cli.app import main

    began = time.perf_counter()
    status = main(["retarget", *arguments, "--quiet"])
    if status != 0:
        raise RuntimeError(f"deik retarget {' '.join(arguments)} exited {status}")
    return time.perf_counter() - began


def onto_robot(source_path: Path, robot_path: Path, map_path: Path, folder: Path, wrists: list[str]) -> dict:
    """Retarget `source_path` onto the URDF at `robot_path` through `map_path` and judge it."""
    out = folder / (source_path.stem + ".csv")
    report = folder / (source_path.stem + ".json")
    wall = deik_retarget(
        [str(source_path), "--map", str(map_path), "--to", str(robot_path), "--out", str(out), "--json", str(report)]
    )
    robot = read_robot(robot_path)
    joint_map = tomllib.loads(Path(map_path).read_text())
    pairing, names, values, dt = robot_pairing(robot, out, joint_map)
    source = read_bvh_file(source_path)
    steps = {"robot": robot, "names": names, "values": values, "frame_time": dt}
    figures = judge(source, pairing, wrists, 1000.0, steps)  # a URDF is in metres
    return {**figures, "wall_s": wall, "deik": json.loads(report.read_text())["summary"]}


def onto_rig(source_path: Path, folder: Path, scale: str = SCALE) -> dict:
    """Retarget `source_path` onto its own rig with other proportions (--scale) and judge it."""
    out, report = folder / (source_path.stem + "_scaled.bvh"), folder / (source_path.stem + "_scaled.json")
    wall = deik_retarget([str(source_path), "--scale", scale, "--out", str(out), "--json", str(report)])
    source = read_bvh_file(source_path)
    positions = bvh_transforms(source)[0]
    floor = source_floor(positions, source.frame_time, stature(source))
    mm = 1000.0 if stature(source) < 10 else 10.0  # the rig's unit: metres or centimetres
    figures = judge(source, rig_pairing(source, read_bvh_file(out), floor), WRISTS, mm)
    return {**figures, "wall_s": wall, "deik": json.loads(report.read_text())["summary"]}


def plan(clips: list[Path], quick: bool) -> list[dict]:
    """The runs: every clip onto human.urdf and onto its own rig scaled; each source case on a
    few clips onto human.urdf; each robot case on a few clips."""
    by_name = {c.stem.removeprefix("humanoid3d_"): c for c in clips}
    runs = [{"clip": name, "case": "as captured", "target": "human.urdf"} for name in by_name]
    runs += [{"clip": name, "case": "as captured", "target": "same rig, scaled"} for name in by_name]
    hard = {"backwards": "crawl", "sped_up": "kick", "long_legs": "walk", "noisy": "punch", "studio": "walk"}
    hard_robots = {"reordered": "kick", "continuous": "dance_a", "slow": "jump"}
    runs += [{"clip": clip, "case": case, "target": "human.urdf"} for case, clip in hard.items()]
    runs += [
        {"clip": clip, "case": "as captured", "target": f"human.urdf, {case}"} for case, clip in hard_robots.items()
    ]
    runs = [r for r in runs if r["clip"] in by_name]
    return [r for r in runs if r["clip"] == "walk"] if quick else runs


def run(spec: dict, clips: dict, folder: Path) -> dict:
    """Make the case of `spec` in `folder`, retarget it and judge it."""
    original = clips[spec["clip"]]
    source_path, map_path, robot_path, wrists = original, URDF_MAP, HUMAN_URDF, WRISTS
    if spec["case"] != "as captured":
        bvh = source_case(read_bvh_file(original), spec["case"])
        source_path = folder / f"{spec['clip']}_{spec['case']}.bvh"
        write_bvh_file(source_path, bvh)
        if spec["case"] == "studio":
            map_path, wrists = folder / "studio_map.toml", STUDIO_WRISTS
            map_path.write_text(toml_text(studio_map(tomllib.loads(URDF_MAP.read_text()))))
    if spec["target"] == "same rig, scaled":
        return onto_rig(source_path, folder)
    if ", " in spec["target"]:
        robot_path = folder / f"human_{spec['target'].split(', ')[1]}.urdf"
        robot_path.write_text(robot_case(HUMAN_URDF.read_text(), spec["target"].split(", ")[1]))
    return onto_robot(source_path, robot_path, map_path, folder, wrists)


SHOWN = (
    ("sliding_max_mm_per_frame", "sliding mm/frame"),
    ("penetration_max_mm", "under floor mm"),
    ("step_excess_max", "step / allowance"),
    ("wrap_count", "wraps"),
    ("wrist_distance_max_mm", "wrist mm"),
    ("keypoint_error_mean_mm", "key points mm"),
)


def markdown(rows: list[dict], facts: dict) -> str:
    """The short Markdown table of the runs."""
    header = ["clip", "case", "target", "frames"] + [label for _, label in SHOWN] + ["resting points"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        cells = [row["clip"], row["case"], row["target"], str(row.get("frames", ""))]
        for key, _ in SHOWN:
            value = row.get(key)
            cells.append("-" if value is None else f"{value:.3g}" if isinstance(value, float) else str(value))
        cells.append(", ".join(row.get("resting_points", [])) or "-")
        lines.append("| " + " | ".join(cells) + " |")
    notes = [
        "",
        f"Bounds: sliding <= {SLIDING_BOUND} mm/frame over every point resting in the source, nothing more than "
        f"{PENETRATION_BOUND} mm under the floor, every DOF step within max(velocity limit x frame time, "
        f"{STEP_ALLOWANCE} x the source's largest joint turn per frame) (step / allowance <= 1), no wraps, "
        f"a hand within {WRIST_BOUND} statures of the target of its scaled source point.",
        f"Measured by benchmarks/retarget_quality.py (yourdfpy and its own BVH reader), commit {facts['commit']}, "
        f"{facts['cpu']}, load average {facts['load']}.",
    ]
    return "\n".join(lines + notes) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Run the plan, write retarget_quality.json and .md under --out, print the table."""
    import subprocess

    from deik.experiments.timing import cpu_model
    from deik.io.atomic import write_json_atomically, write_text_atomically

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="the walk alone")
    p.add_argument("--clips", type=Path, default=DATA / "humanoid", help="folder of clips (default the shared ones)")
    p.add_argument("--out", type=Path, default=RESULTS)
    p.add_argument("--only", help="run only the plan entries whose clip, case or target contains this text")
    args = p.parse_args(argv)
    clips = {c.stem.removeprefix("humanoid3d_"): c for c in sorted(args.clips.glob("*.bvh"))}
    specs = plan(list(clips.values()), args.quick)
    if args.only:
        specs = [s for s in specs if any(args.only in s[k] for k in ("clip", "case", "target"))]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for spec in specs:
            folder = Path(tmp) / f"{spec['clip']}_{len(rows)}"
            folder.mkdir()
            try:
                row = {**spec, **run(spec, clips, folder)}
            except Exception as error:  # a failed run is a row of the table, not the end of the benchmark
                row = {**spec, "failed": f"{type(error).__name__}: {error}"}
            rows.append(row)
            print(json.dumps({k: v for k, v in row.items() if k not in ("deik", "resting_points")}), flush=True)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT).stdout
    facts = {"commit": commit.strip(), "cpu": cpu_model(), "load": [round(v, 1) for v in os.getloadavg()]}
    args.out.mkdir(parents=True, exist_ok=True)
    write_json_atomically(args.out / "retarget_quality.json", {"machine": facts, "runs": rows}, missing_as_null=True)
    write_text_atomically(args.out / "retarget_quality.md", markdown(rows, facts))
    print(markdown(rows, facts))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""BVH rigs for the clip benchmark, read, written and posed without deik: the independent side of
benchmarks/clip_targets.py (the case generator and the judge use this, never deik's reader or
kinematics).

A `Rig` is a BVH file's hierarchy and motion: joint names, parents, OFFSETs, channels in file
order, End Sites, frames (N, C) as in the file (degrees, length units) and the frame time.
`position_mode` says how position channels below the root are read: "local" (the channels hold
the joint's whole local position and repeat its OFFSET, as Blender and MotionBuilder read them)
or "displacement" (added to the OFFSET). The root's position channels are its position. World
positions come from `pose_points` (NumPy and SciPy rotations, intrinsic Euler orders as the
channels list them).
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
from scipy.spatial.transform import Rotation


@dataclasses.dataclass(frozen=True)
class Rig:
    """A BVH file (module notes). `channels[j]`: channel names of joint j in file order;
    `sites`: (name, joint index, offset (3,)) per End Site, named JOINT_end as the case tables use."""

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...]
    sites: tuple[tuple[str, int, np.ndarray], ...]
    frames: np.ndarray
    frame_time: float
    position_mode: str = "displacement"

    @property
    def columns(self) -> list[tuple[int, str]]:
        """(joint, channel) of every frame column, file order."""
        return [(j, c) for j, chans in enumerate(self.channels) for c in chans]

    def point_names(self) -> list[str]:
        """Joints then End Sites: pose_points' columns."""
        return list(self.names) + [name for name, _, _ in self.sites]


def parse_rig(text: str, position_mode: str = "displacement") -> Rig:
    """A Rig from BVH `text` (well-formed files only: this reads what the generator writes and
    what deik writes back)."""
    tokens = re.findall(r"[{}]|[^\s{}]+", text.split("MOTION")[0])
    names, parents, offsets, channels, sites = [], [], [], [], []
    stack, k, pending_site = [], 0, False
    while k < len(tokens):
        word = tokens[k]
        if word in ("ROOT", "JOINT"):
            names.append(tokens[k + 1])
            parents.append(stack[-1] if stack else -1)
            offsets.append(np.zeros(3))
            channels.append(())
            k += 2
        elif word == "End":
            pending_site = True
            k += 2
        elif word == "{":
            stack.append(-2 if pending_site else len(names) - 1)
            if pending_site:
                sites.append((f"{names[stack[-2]]}_end", stack[-2], np.zeros(3)))
            pending_site = False
            k += 1
        elif word == "}":
            stack.pop()
            k += 1
        elif word == "OFFSET":
            value = np.array([float(v) for v in tokens[k + 1 : k + 4]])
            if stack[-1] == -2:
                sites[-1] = (sites[-1][0], sites[-1][1], value)
            else:
                offsets[stack[-1]] = value
            k += 4
        elif word == "CHANNELS":
            count = int(tokens[k + 1])
            channels[stack[-1]] = tuple(tokens[k + 2 : k + 2 + count])
            k += 2 + count
        else:
            k += 1
    motion = text.split("MOTION")[1].strip().splitlines()
    frame_time = float(motion[1].split(":")[1])
    frames = np.array([[float(v) for v in line.split()] for line in motion[2:] if line.strip()], float)
    return Rig(
        tuple(names),
        tuple(parents),
        np.array(offsets),
        tuple(channels),
        tuple(sites),
        frames,
        frame_time,
        position_mode,
    )


def format_rig(rig: Rig) -> str:
    """The BVH text of `rig`."""
    lines = ["HIERARCHY"]

    def joint(j: int, depth: int) -> None:
        pad = "\t" * depth
        lines.append(f"{pad}{'ROOT' if depth == 0 else 'JOINT'} {rig.names[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}\tOFFSET {' '.join(f'{v:.10g}' for v in rig.offsets[j])}")
        if rig.channels[j]:
            lines.append(f"{pad}\tCHANNELS {len(rig.channels[j])} {' '.join(rig.channels[j])}")
        for child in (c for c, p in enumerate(rig.parents) if p == j):
            joint(child, depth + 1)
        for _, owner, offset in rig.sites:
            if owner == j:
                lines.extend(
                    [
                        f"{pad}\tEnd Site",
                        f"{pad}\t{{",
                        f"{pad}\t\tOFFSET {' '.join(f'{v:.10g}' for v in offset)}",
                        f"{pad}\t}}",
                    ]
                )
        lines.append(f"{pad}}}")

    joint(0, 0)
    lines += ["MOTION", f"Frames: {len(rig.frames)}", f"Frame Time: {rig.frame_time:.8f}"]
    lines += [" ".join(f"{v:.10g}" for v in row) for row in rig.frames]
    return "\n".join(lines) + "\n"


def joint_values(rig: Rig) -> tuple[np.ndarray, np.ndarray]:
    """(local rotations (N, J, 3, 3), local translations (N, J, 3)) of every joint: the rotation
    channels composed in file order (intrinsic), the translation by position_mode."""
    N, J = len(rig.frames), len(rig.names)
    rotations = np.broadcast_to(np.eye(3), (N, J, 3, 3)).copy()
    translations = np.broadcast_to(rig.offsets, (N, J, 3)).copy()
    column = 0
    for j, chans in enumerate(rig.channels):
        values = rig.frames[:, column : column + len(chans)]
        column += len(chans)
        order = "".join(c[0] for c in chans if c.endswith("rotation"))
        if order:
            angles = np.stack([values[:, i] for i, c in enumerate(chans) if c.endswith("rotation")], axis=1)
            rotations[:, j] = Rotation.from_euler(order.upper(), angles, degrees=True).as_matrix()
        moves = {"XYZ".index(c[0]): i for i, c in enumerate(chans) if c.endswith("position")}
        if moves:
            local = rig.position_mode == "local"
            base = np.zeros((N, 3)) if local else translations[:, j].copy()
            for axis, i in moves.items():
                base[:, axis] += values[:, i]
            translations[:, j] = base
    return rotations, translations


def world_frames(rig: Rig) -> tuple[np.ndarray, np.ndarray]:
    """(world rotations (N, J, 3, 3), world positions (N, J, 3)) of every joint."""
    local_r, local_t = joint_values(rig)
    N, J = local_t.shape[:2]
    R, p = np.zeros((N, J, 3, 3)), np.zeros((N, J, 3))
    for j, parent in enumerate(rig.parents):
        if parent < 0:
            R[:, j], p[:, j] = local_r[:, j], local_t[:, j]
        else:
            R[:, j] = R[:, parent] @ local_r[:, j]
            p[:, j] = p[:, parent] + np.einsum("nij,nj->ni", R[:, parent], local_t[:, j])
    return R, p


def pose_points(rig: Rig) -> np.ndarray:
    """(N, J + S, 3) world positions of every joint, then every End Site."""
    R, p = world_frames(rig)
    sites = [p[:, j] + np.einsum("nij,j->ni", R[:, j], offset) for _, j, offset in rig.sites]
    return np.concatenate([p, np.stack(sites, axis=1)], axis=1) if sites else p

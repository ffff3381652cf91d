"""Motion clips: a Skeleton, its frames (N, D) and the BVH channel layout that writes them back.

Frames hold skeleton DOF values in skeleton order: radians for rotations, the file's length unit
for translations. The layout keeps, per joint, its channels in file order and the skeleton DOF
each one carries, so a clip read from BVH is written back with the same columns. Euler angles
are kept as given (they may leave [-pi, pi]); `pose` wraps them, `with_pose`/`with_frames` keep
new angles continuous with the frames they replace, `with_continuous_channels` with the frame
before (deik.io.euler).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.io.euler import AXIS_TOLERANCE, continuous_angles, continuous_frames
from deik.model.joints import ROTATE, TRANSLATE
from deik.model.kinematics import Kinematics, forward_kinematics
from deik.model.rotations import wrap_rotations
from deik.model.skeleton import Skeleton

DEGREES_PER_RADIAN = 180.0 / math.pi
# Channel name -> (DOF kind, axis index). BVH spells them e.g. "Xposition", "Zrotation".
CHANNELS = {
    f"{axis}{word}": (kind, k)
    for k, axis in enumerate("XYZ")
    for word, kind in (("position", TRANSLATE), ("rotation", ROTATE))
}


@dataclass(frozen=True)
class JointChannels:
    """One BVH joint: `channels` in file order, `dofs` the skeleton DOF index of each channel,
    `children` the names of its child joints and End Sites (skeleton sites) in file order;
    `local_position`: its position channels hold its whole local position (the file repeats
    its OFFSET in them) rather than a displacement from the OFFSET, so each such channel is its
    DOF's value plus the OFFSET's component."""

    name: str
    channels: tuple[str, ...]
    dofs: tuple[int, ...]
    children: tuple[str, ...]
    local_position: bool = False


class KinematicsOnce:
    """A motion's forward kinematics, computed on first use and kept: a clip's frames never
    change (a new clip is made instead), so every measure of the same clip reads one Kinematics."""

    @cached_property
    def kinematics(self) -> Kinematics:
        """Kinematics of every frame (batch (N,)): world frames (N, F, 3, 3), positions (N, F, 3)
        in length units and the centre of mass (N, 3); read-only."""
        kin = forward_kinematics(self.skeleton, self.frames)
        for array in (kin.R_world_frame, kin.p_world_frame, kin.p_world_com):
            array.setflags(write=False)
        return kin


@dataclass(frozen=True, eq=False, repr=False)
class Clip(KinematicsOnce):
    """A skeleton and N frames of its DOF values: `frames` (N, D) float64, read-only, radians /
    length units in skeleton DOF order; `frame_time` seconds; `layout` the BVH joints in file
    order; `source` where it came from; `mass_source` where its masses came from.

    Derived: `channel_dofs` (C,) the skeleton DOF in each file column (C = D), `channel_scale`
    and `channel_bias` (C,) with file value = DOF value * scale + bias (degrees per radian for
    rotations, -1 where a DOF turns about a negative axis; the bias is the OFFSET's component
    for a joint whose position channels hold its local position, JointChannels, else 0).
    """

    skeleton: Skeleton
    frames: np.ndarray
    frame_time: float
    layout: tuple[JointChannels, ...]
    source: str = ""
    mass_source: str = ""
    channel_dofs: np.ndarray = field(init=False)
    channel_scale: np.ndarray = field(init=False)
    channel_bias: np.ndarray = field(init=False)

    def __post_init__(self):
        sk = self.skeleton
        frames = self.frames
        if not (isinstance(frames, np.ndarray) and frames.dtype == np.float64 and _sealed(frames)):
            frames = np.array(frames, dtype=np.float64)  # the caller's array: a copy nobody else can change
        if frames.ndim != 2 or frames.shape[1] != sk.n_dofs:
            raise InputError(f"frames must have shape (N, {sk.n_dofs}), got {frames.shape}")
        if not np.isfinite(frames).all():
            raise InputError("frames contain NaN or infinite values")
        frames.setflags(write=False)
        frame_time = float(self.frame_time)
        if not (math.isfinite(frame_time) and frame_time > 0):
            raise InputError(f"frame_time must be a positive number of seconds, got {frame_time}")
        layout = tuple(self.layout)
        dofs, scale, bias = _channel_map(sk, layout)
        for array in (dofs, scale, bias):
            array.setflags(write=False)
        for key, value in (
            ("frames", frames),
            ("frame_time", frame_time),
            ("layout", layout),
            ("channel_dofs", dofs),
            ("channel_scale", scale),
            ("channel_bias", bias),
        ):
            object.__setattr__(self, key, value)

    def __repr__(self) -> str:
        return (
            f"Clip({self.source!r}, {self.n_frames} frames x {self.skeleton.n_dofs} DOFs, "
            f"frame_time={self.frame_time:g} s)"
        )

    @property
    def n_frames(self) -> int:
        return self.frames.shape[0]

    def _frame_index(self, n) -> int:
        n = operator.index(n)
        if not 0 <= n < self.n_frames:
            valid = f"0..{self.n_frames - 1}" if self.n_frames else "none: the clip has no frames"
            raise IndexError(f"frame {n} is out of range; valid frames: {valid}")
        return n

    def pose(self, n: int) -> np.ndarray:
        """Frame n as a (D,) pose with rotation DOFs wrapped into [-pi, pi) radians (inside the
        limits of a skeleton read from BVH); translations unchanged."""
        return wrap_rotations(self.frames[self._frame_index(n)], self.skeleton.dof_kind == ROTATE)

    def poses(self) -> np.ndarray:
        """Every frame (N, D) wrapped as in `pose`."""
        return wrap_rotations(self.frames, self.skeleton.dof_kind == ROTATE)

    def with_pose(self, n: int, pose: ArrayLike) -> Clip:
        """A new clip with frame n replaced by `pose` (D,), radians / length units, its Euler
        angles made continuous with the original frame n (same rotations, nearest values)."""
        n = self._frame_index(n)
        pose = self.skeleton.check_angles(pose, "pose")
        if pose.ndim != 1:
            raise InputError(f"pose must have shape ({self.skeleton.n_dofs},), got {pose.shape}")
        frames = self.frames.copy()
        frames[n] = continuous_angles(self.skeleton, pose[None], self.frames[n : n + 1])[0]
        return replace(self, frames=frames)

    def with_frames(self, frames: ArrayLike) -> Clip:
        """A new clip with every frame replaced by `frames` (N, D), each made continuous with
        the original frame it replaces (same rotations, nearest Euler values)."""
        frames = self.skeleton.check_angles(frames, "frames")
        if frames.shape != self.frames.shape:
            raise InputError(f"frames must have shape {self.frames.shape} like the clip's, got {frames.shape}")
        return replace(self, frames=continuous_angles(self.skeleton, frames, self.frames))

    def with_continuous_channels(self) -> Clip:
        """A new clip with the same rotations whose Euler channels move the least from frame
        to frame (deik.io.euler.continuous_frames: whole turns, the flipped triple, gimbal lock)."""
        return replace(self, frames=continuous_frames(self.skeleton, self.frames))

    def channel_values(self) -> np.ndarray:
        """Frames in file layout (N, C): degrees for rotation channels, length units for
        position channels, columns in file order."""
        values = self.frames[:, self.channel_dofs] * self.channel_scale
        return values + self.channel_bias if self.channel_bias.any() else values  # keeps -0.0 as the file had it

    @classmethod
    def from_channel_values(
        cls,
        skeleton: Skeleton,
        layout: Sequence[JointChannels],
        values: ArrayLike,
        frame_time: float,
        source: str = "",
        mass_source: str = "",
    ) -> Clip:
        """A clip from file-layout values (N, C) (degrees, length units; see channel_values)."""
        dofs, scale, bias = _channel_map(skeleton, tuple(layout))
        values = np.asarray(values, dtype=np.float64)
        if values.ndim != 2 or values.shape[1] != len(dofs):
            raise InputError(f"values must have shape (N, {len(dofs)}), got {values.shape}")
        frames = np.empty((values.shape[0], skeleton.n_dofs))
        for column, (dof, factor, offset) in enumerate(zip(dofs, scale, bias)):  # by column: no (N, C) temporary
            np.subtract(values[:, column], offset, out=frames[:, dof])
            frames[:, dof] /= factor
        frames.setflags(write=False)  # sealed: the clip takes it as it is, without a copy
        return cls(skeleton, frames, frame_time, tuple(layout), source, mass_source)

    @classmethod
    def from_poses(cls, skeleton: Skeleton, poses: ArrayLike, frame_time: float, source: str = "") -> Clip:
        """A clip of `poses` (N, D) for any skeleton whose DOFs BVH can carry: rotations about and
        translations along +-X, Y or Z, translations before rotations within each joint. The
        layout follows skeleton order; sites become End Sites (their rotations are dropped)."""
        layout = _layout_from_skeleton(skeleton)
        poses = np.atleast_2d(skeleton.check_angles(poses, "poses"))
        if poses.ndim != 2:
            raise InputError(f"poses must have shape (N, {skeleton.n_dofs}), got {poses.shape}")
        mass_source = f"skeleton {skeleton.name!r} ({skeleton.total_mass:g} kg)"
        return cls(skeleton, poses, frame_time, layout, source or f"<poses of {skeleton.name}>", mass_source)


def held_translations(skeleton: Skeleton, frames: np.ndarray) -> np.ndarray:
    """(D,) bool: translations whose limits leave them no room beyond their range over `frames`
    (N, D): the clip holds them at its values (a BVH's position channels below its first joint
    that translates, deik.io.bvh), so solves and fixes keep bones at their lengths."""
    if not len(frames):
        return np.zeros(skeleton.n_dofs, bool)
    slack = 1e-9 * max(skeleton.reach, 1e-300)
    inside = (skeleton.lower >= frames.min(axis=0) - slack) & (skeleton.upper <= frames.max(axis=0) + slack)
    return (skeleton.dof_kind == TRANSLATE) & inside


def _sealed(array: np.ndarray) -> bool:
    """Whether `array` is read-only and owns its memory (no writable view of it exists), so a
    Clip may keep it without a copy."""
    return not array.flags.writeable and array.flags.owndata and array.flags.c_contiguous


def _channel_map(sk: Skeleton, layout: tuple[JointChannels, ...]):
    """Check `layout` against the skeleton; return channel_dofs (C,) int, channel_scale (C,) and
    channel_bias (C,)."""
    joint = {name: k for k, name in enumerate(sk.joint_names)}
    site = {name: s for s, name in enumerate(sk.site_names)}
    entries = {e.name: e for e in layout}
    if len(entries) != len(layout) or set(entries) != set(joint) or layout[0].name != sk.joint_names[0]:
        raise InputError("the layout must list every joint of the skeleton once, the root first")
    order, stack, sites = [], [layout[0].name], []
    while stack:
        name = stack.pop()
        order.append(name)
        for child in entries[name].children:
            parent = sk.parents[joint[child]] if child in joint else sk.site_joint[site[child]] if child in site else -1
            if parent < 0 or sk.joint_names[parent] != name:
                raise InputError(f"layout lists {child!r} under {name!r}, which is not its parent")
            if child in site:
                sites.append(child)
        stack.extend(reversed([c for c in entries[name].children if c in joint]))
    if order != [e.name for e in layout] or sorted(sites) != sorted(sk.site_names):
        raise InputError("the layout must be the depth-first walk of the skeleton with every site once")
    dofs, scale, bias = [], [], []
    for entry in layout:
        k = joint[entry.name]
        own = range(sk.joint_dof_start[k], sk.joint_dof_start[k + 1])
        if len(entry.channels) != len(entry.dofs) or sorted(entry.dofs) != list(own):
            raise InputError(f"joint {entry.name!r}: the layout must give one channel per DOF")
        for channel, d in zip(entry.channels, entry.dofs):
            kind, axis = CHANNELS.get(channel, (None, 0))
            sign = sk.dof_axis[d][axis]
            if kind != sk.dof_kind[d] or abs(abs(sign) - 1.0) > AXIS_TOLERANCE:
                raise InputError(f"channel {channel} of joint {entry.name!r} does not match DOF {sk.dof_names[d]!r}")
            dofs.append(d)
            scale.append(math.copysign(DEGREES_PER_RADIAN if kind == ROTATE else 1.0, sign))
            bias.append(float(sk.offsets[k][axis]) if entry.local_position and kind != ROTATE else 0.0)
        kinds = sk.dof_kind[own]
        rotations = [d for c, d in zip(entry.channels, entry.dofs) if CHANNELS[c][0] == ROTATE]
        if (np.diff(kinds) > 0).any() or rotations != sorted(rotations):
            raise InputError(
                f"joint {entry.name!r}: DOFs must be its translations, then its rotations in channel order"
            )
    return np.array(dofs, dtype=np.intp), np.array(scale, dtype=np.float64), np.array(bias, dtype=np.float64)


def _layout_from_skeleton(sk: Skeleton) -> tuple[JointChannels, ...]:
    """Depth-first BVH layout of `sk`; ValueError naming the first DOF or name BVH cannot carry."""
    for name in sk.frame_names:
        if not name or any(c.isspace() or c in "{}" for c in name):
            raise InputError(
                f"name {name!r} cannot be written to BVH: names need at least one character and no spaces or braces"
            )
    turned = np.flatnonzero(np.abs(sk.joint_rotation - np.eye(3)).max(axis=(1, 2)) > AXIS_TOLERANCE)
    if turned.size:
        raise InputError(
            f"joint {sk.joint_names[turned[0]]!r} has a fixed rest rotation, which BVH "
            "cannot carry (OFFSETs only); write the pose as JSON instead"
        )
    if sk.mimic_names:
        raise InputError(
            f"DOF {sk.mimic_names[0]!r} mimics another; BVH has no mimic channels, write the pose as JSON instead"
        )
    children = [[] for _ in sk.joint_names]
    for k in range(1, sk.n_joints):
        children[sk.parents[k]].append(sk.joint_names[k])
    for s, k in enumerate(sk.site_joint):
        children[k].append(sk.site_names[s])
    entries, stack = [], [0]
    while stack:
        k = stack.pop()
        channels, rotated = [], False
        for d in range(sk.joint_dof_start[k], sk.joint_dof_start[k + 1]):
            axis = int(np.argmax(np.abs(sk.dof_axis[d])))
            word = "rotation" if sk.dof_kind[d] == ROTATE else "position"
            if abs(abs(sk.dof_axis[d][axis]) - 1.0) > AXIS_TOLERANCE:
                raise InputError(
                    f"DOF {sk.dof_names[d]!r} moves along {tuple(sk.dof_axis[d])}, "
                    "not a coordinate axis: BVH channels are X/Y/Z only"
                )
            if word == "position" and rotated:
                raise InputError(
                    f"DOF {sk.dof_names[d]!r} translates after a rotation of its "
                    "joint; BVH position channels move along the parent's axes, so "
                    "a joint's translations must come before its rotations"
                )
            channel = f"{'XYZ'[axis]}{word}"
            if channel in channels:
                raise InputError(
                    f"DOF {sk.dof_names[d]!r} repeats channel {channel} of its joint; "
                    "BVH allows each channel once per joint"
                )
            channels.append(channel)
            rotated = rotated or word == "rotation"
        start = int(sk.joint_dof_start[k])
        entries.append(
            JointChannels(
                sk.joint_names[k], tuple(channels), tuple(range(start, start + len(channels))), tuple(children[k])
            )
        )
        stack.extend(reversed([j for j in range(k + 1, sk.n_joints) if sk.parents[j] == k]))
    return tuple(entries)


def message_prefix(clip: Clip | KinematicsOnce) -> str:
    """The words to begin an error about `clip` (a Clip or Trajectory) with: its `source` file
    and a colon ("" without one)."""
    return f"{clip.source}: " if clip.source else ""

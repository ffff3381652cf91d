"""`deik info`: a skeleton described in text: joint tree, DOFs and limits, masses and sites."""

from __future__ import annotations

import math

import numpy as np

from deik.io.load import Loaded
from deik.model.joints import ROTATE
from deik.model.skeleton import Skeleton
from deik.viz.marks import length_unit
from deik.viz.text import format_table


def _dof_cells(skeleton, d: int) -> list[str]:
    """Name, kind, lower and upper of DOF d (degrees for rotations, length units otherwise)."""
    rotation = skeleton.dof_kind[d] == ROTATE
    scale, unit = (180.0 / math.pi, "deg") if rotation else (1.0, "")
    bound = lambda v: f"{v * scale:.6g}" if math.isfinite(v) else ("-inf" if v < 0 else "inf")  # noqa: E731
    axis = " ".join(f"{a:.6g}" for a in skeleton.dof_axis[d])
    return [
        skeleton.dof_names[d],
        ("rotate" if rotation else "slide") + f" ({axis})",
        f"{bound(skeleton.lower[d])} .. {bound(skeleton.upper[d])} {unit}".rstrip(),
    ]


def joint_tree(skeleton: Skeleton) -> list[str]:
    """One line per joint (frame), indented by depth, with the URDF joint that moves it where its
    name differs (the key of its values in a pose), its DOF count and sites."""
    depth = np.zeros(skeleton.n_joints, int)
    lines = []
    for k, name in enumerate(skeleton.joint_names):
        if k:
            depth[k] = depth[skeleton.parents[k]] + 1
        dofs = skeleton.joint_dof_start[k + 1] - skeleton.joint_dof_start[k]
        mimics = int((skeleton.mimic_joint == k).sum())
        sites = [s for s, j in zip(skeleton.site_names, skeleton.site_joint) if j == k]
        label = skeleton.joint_labels[k]
        notes = (
            ([f"moved by joint {label}"] if label != name else [])
            + [f"{dofs} DOF"]
            + ([f"{mimics} mimic"] if mimics else [])
            + ([f"sites: {', '.join(sites)}"] if sites else [])
        )
        lines.append(f"{'  ' * depth[k]}{name}  ({'; '.join(notes)})")
    return lines


def describe(loaded: Loaded, source: str) -> str:
    """The text `deik info` prints for a loaded skeleton."""
    sk = loaded.skeleton
    unit, where = length_unit(sk, loaded.kind)
    lines = [
        f"{source}: {loaded.kind} skeleton {sk.name!r}",
        f"{sk.n_joints} joints, {sk.n_dofs} DOFs"
        + (f" (+{len(sk.mimic_names)} mimic)" if sk.mimic_names else "")
        + f", {len(sk.site_names)} sites, reach {sk.reach:.6g} {unit}, up {tuple(float(u) for u in sk.up)}",
        f"lengths in {unit}: {where}",
        f"mass: {sk.total_mass:.6g} kg, {loaded.mass_source}",
    ]
    if loaded.clip is not None:
        clip = loaded.clip
        lines.append(f"clip: {clip.n_frames} frames, {clip.frame_time:g} s per frame")
    lines += ["", "joint tree:"] + ["  " + line for line in joint_tree(sk)]
    lines += ["", format_table(["DOF", "motion (axis)", "limits"], [_dof_cells(sk, d) for d in range(sk.n_dofs)])]
    if sk.mimic_names:
        rows = [
            [n, sk.dof_names[s], f"{m:.6g}", f"{b:.6g}"]
            for n, s, m, b in zip(sk.mimic_names, sk.mimic_source, sk.mimic_scale, sk.mimic_bias)
        ]
        lines += ["", format_table(["mimic DOF", "follows", "multiplier", "offset"], rows)]
    if len(sk.mass_value):
        rows = [
            [sk.joint_names[j], f"{m:.6g}", " ".join(f"{x:.6g}" for x in o)]
            for j, m, o in zip(sk.mass_joint, sk.mass_value, sk.mass_offset)
        ]
        lines += ["", format_table(["mass on joint", "kg", "centre (joint frame)"], rows)]
    if sk.site_names:
        rows = [
            [n, sk.joint_names[j], " ".join(f"{x:.6g}" for x in o)]
            for n, j, o in zip(sk.site_names, sk.site_joint, sk.site_offset)
        ]
        lines += ["", format_table(["site", "on joint", "offset"], rows)]
    return "\n".join(lines)

"""deik.describe_skeleton(): what `deik info` shows of a skeleton, as data (JSON-able).

info = deik.describe_skeleton("panda.urdf", base="panda_link0")
info["dofs"][0]    # {"name": "panda_joint1", "kind": "rotate", "axis": [0, 0, 1], "lower": -2.9, ...}
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from deik.io.files import FilePath
from deik.io.load import Loaded, load_skeleton
from deik.model.joints import ROTATE
from deik.model.skeleton import Skeleton


def _joints(sk: Skeleton) -> list[dict]:
    """One entry per joint in tree order: its depth, the URDF joint that moves it (its label),
    its DOF and mimic counts and its sites."""
    depth = np.zeros(sk.n_joints, int)
    mimic_counts = np.bincount(sk.mimic_joint, minlength=sk.n_joints)
    sites_on: dict[int, list[str]] = {}  # gathered once: a scan of every site per joint is quadratic
    for site, joint in zip(sk.site_names, sk.site_joint.tolist()):
        sites_on.setdefault(joint, []).append(site)
    out = []
    for k, name in enumerate(sk.joint_names):
        if k:
            depth[k] = depth[sk.parents[k]] + 1
        out.append(
            {
                "name": name,
                "depth": int(depth[k]),
                "label": sk.joint_labels[k],
                "dofs": int(sk.joint_dof_start[k + 1] - sk.joint_dof_start[k]),
                "mimics": int(mimic_counts[k]),
                "sites": sites_on.get(k, []),
            }
        )
    return out


def skeleton_record(loaded: Loaded) -> dict:
    """The description of a loaded skeleton (see describe_skeleton)."""
    sk = loaded.skeleton
    clip = loaded.clip
    return {
        "kind": loaded.kind,
        "name": sk.name,
        "joint_count": sk.n_joints,
        "dof_count": sk.n_dofs,
        "site_count": len(sk.site_names),
        "reach": float(sk.reach),
        "up": [float(u) for u in sk.up],
        "mass_kg": float(sk.total_mass),
        "mass_source": loaded.mass_source,
        "clip": None if clip is None else {"frames": clip.n_frames, "frame_time_s": clip.frame_time},
        "joints": _joints(sk),
        "dofs": [
            {
                "name": sk.dof_names[d],
                "kind": "rotate" if sk.dof_kind[d] == ROTATE else "slide",
                "axis": [float(a) for a in sk.dof_axis[d]],
                "lower": float(sk.lower[d]),
                "upper": float(sk.upper[d]),
            }
            for d in range(sk.n_dofs)
        ],
        "mimics": [
            {"name": n, "follows": sk.dof_names[s], "multiplier": float(m), "offset": float(b)}
            for n, s, m, b in zip(sk.mimic_names, sk.mimic_source, sk.mimic_scale, sk.mimic_bias)
        ],
        "masses": [
            {"joint": sk.joint_names[j], "kg": float(m), "centre": [float(x) for x in o]}
            for j, m, o in zip(sk.mass_joint, sk.mass_value, sk.mass_offset)
        ],
        "sites": [
            {"name": n, "joint": sk.joint_names[j], "offset": [float(x) for x in o]}
            for n, j, o in zip(sk.site_names, sk.site_joint, sk.site_offset)
        ],
    }


def describe_skeleton(
    source: str | FilePath | Loaded,
    *,
    base: str | None = None,
    tip: str | Sequence[str] | None = None,
    segments: FilePath | None = None,
    up: ArrayLike | None = None,
) -> dict:
    """What `deik info` shows of `source` (a .bvh or .urdf path, "chain:N", "chain3d:N",
    "humanoid", or a deik.io.load.Loaded; `base`, `tip`, `segments`, `up` as deik.load_skeleton):
    {"kind", "name", "joint_count", "dof_count", "site_count", "reach" (length units), "up" (3,),
    "mass_kg", "mass_source", "clip" ({"frames", "frame_time_s"} for a BVH, else None),
    "joints" [{"name", "depth", "label", "dofs", "mimics", "sites"}] in tree order, "dofs"
    [{"name", "kind" ("rotate" | "slide"), "axis" (3,), "lower", "upper"}] (radians or length
    units, infinite when unlimited), "mimics" [{"name", "follows", "multiplier", "offset"}],
    "masses" [{"joint", "kg", "centre" (3,) in the joint's frame}], "sites" [{"name", "joint",
    "offset" (3,)}]}."""
    if not isinstance(source, Loaded):
        source = load_skeleton(str(source), base=base, tip=tip, segments=segments, up=up)
    return skeleton_record(source)

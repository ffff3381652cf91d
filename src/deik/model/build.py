"""`build_skeleton`: Joint, Site and Segment specs in any order -> a validated, frozen Skeleton;
`with_sites`: a skeleton with more sites.

Joints are sorted topologically (parents first), cycles and unknown parents are refused, and
mimic DOFs are resolved to the free DOFs they follow.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.model.joints import Dof, Joint, Segment, Site
from deik.model.skeleton import Skeleton


def _topological_order(joints: list[Joint]) -> list[int]:
    """Depth-first order from the root (parents first, siblings in given order)."""
    by_name: dict[str, int] = {}
    for k, j in enumerate(joints):
        if j.name in by_name:
            raise InputError(f"duplicate joint name {j.name!r}; every joint needs its own name")
        by_name[j.name] = k
    roots = [k for k, j in enumerate(joints) if j.parent is None]
    if len(roots) != 1:
        names = [joints[k].name for k in roots]
        raise InputError(f"a skeleton needs exactly one root (parent=None), found {names}")
    children: list[list[int]] = [[] for _ in joints]
    for k, j in enumerate(joints):
        if j.parent is not None:
            if j.parent not in by_name:
                raise InputError(f"joint {j.name!r} names unknown parent {j.parent!r}")
            children[by_name[j.parent]].append(k)
    order, stack = [], [roots[0]]
    while stack:
        k = stack.pop()
        order.append(k)
        stack.extend(reversed(children[k]))
    if len(order) < len(joints):
        k = next(i for i in range(len(joints)) if i not in set(order))
        path = []
        while k not in path:
            path.append(k)
            k = by_name[joints[k].parent]
        cycle = [joints[i].name for i in path[path.index(k) :]] + [joints[k].name]
        raise InputError(f"joint parents form a cycle: {' -> '.join(cycle)}")
    return order


def build_skeleton(
    joints: Iterable[Joint],
    sites: Iterable[Site] = (),
    segments: Iterable[Segment] = (),
    up: ArrayLike = (0.0, 1.0, 0.0),
    name: str = "skeleton",
) -> Skeleton:
    """Build a validated Skeleton from Joint/Site/Segment specs given in any order."""
    joints = list(joints)
    order = _topological_order(joints)
    joints = [joints[k] for k in order]
    index = {j.name: k for k, j in enumerate(joints)}
    for j in joints:
        free = [d.mimic is None for d in j.dofs]
        if free != sorted(free, reverse=True):
            raise InputError(f"joint {j.name!r}: mimic DOFs must come after its free DOFs")
    dofs = [(k, d) for k, j in enumerate(joints) for d in j.dofs if d.mimic is None]
    mimics = [(k, d) for k, j in enumerate(joints) for d in j.dofs if d.mimic is not None]
    dof_names = tuple(_dof_name(joints[k], d) for k, d in dofs)
    dof_start = np.cumsum([0] + [sum(d.mimic is None for d in j.dofs) for j in joints])
    masses = [(index[j.name], (0.0, 0.0, 0.0), j.mass) for j in joints if j.mass != 0.0]
    for s in segments:
        if s.joint not in index:
            raise InputError(f"segment {s.name!r} names unknown joint {s.joint!r}")
        masses.append((index[s.joint], s.com_offset, s.mass))
    for s in sites:
        if s.joint not in index:
            raise InputError(f"site {s.name!r} names unknown joint {s.joint!r}")
    return Skeleton(
        name=name,
        joint_names=tuple(j.name for j in joints),
        parents=np.array([index[j.parent] if j.parent else -1 for j in joints], np.int32),
        offsets=np.array([j.offset for j in joints], np.float64).reshape(-1, 3),
        joint_dof_start=dof_start.astype(np.int32),
        dof_names=dof_names,
        dof_joint=np.array([k for k, _ in dofs], np.int32),
        dof_kind=np.array([d.kind for _, d in dofs], np.int32),
        dof_axis=np.array([d.axis for _, d in dofs], np.float64).reshape(-1, 3),
        lower=np.array([d.lower for _, d in dofs], np.float64),
        upper=np.array([d.upper for _, d in dofs], np.float64),
        reference=np.array([d.reference for _, d in dofs], np.float64),
        site_names=tuple(s.name for s in sites),
        site_joint=np.array([index[s.joint] for s in sites], np.int32),
        site_offset=np.array([s.offset for s in sites], np.float64).reshape(-1, 3),
        site_rotation=np.array([s.rotation for s in sites], np.float64).reshape(-1, 3, 3),
        mass_joint=np.array([m[0] for m in masses], np.int32),
        mass_offset=np.array([m[1] for m in masses], np.float64).reshape(-1, 3),
        mass_value=np.array([m[2] for m in masses], np.float64),
        up=np.asarray(up, np.float64),
        joint_rotation=np.array([j.rotation for j in joints], np.float64).reshape(-1, 3, 3),
        joint_labels=tuple(j.label or j.name for j in joints),
        **_mimic_arrays(joints, mimics, dof_names),
    )


def _dof_name(joint: Joint, dof: Dof) -> str:
    return dof.name or f"{joint.name}.{dof.label or 'dof'}"


def _mimic_arrays(joints, mimics, dof_names) -> dict:
    """Skeleton mimic fields from [(joint index, Dof)]; sources are resolved to DOF indices."""
    sources = []
    for k, d in mimics:
        source = d.mimic[0]
        if source not in dof_names:
            raise InputError(
                f"DOF {_dof_name(joints[k], d)!r} mimics unknown DOF {source!r}; "
                "a mimic source must be a free DOF of the same skeleton"
            )
        sources.append(dof_names.index(source))
    return dict(
        mimic_names=tuple(_dof_name(joints[k], d) for k, d in mimics),
        mimic_joint=np.array([k for k, _ in mimics], np.int32),
        mimic_kind=np.array([d.kind for _, d in mimics], np.int32),
        mimic_axis=np.array([d.axis for _, d in mimics], np.float64).reshape(-1, 3),
        mimic_source=np.array(sources, np.int32),
        mimic_scale=np.array([d.mimic[1] for _, d in mimics], np.float64),
        mimic_bias=np.array([d.mimic[2] for _, d in mimics], np.float64),
    )


def with_sites(skeleton: Skeleton, sites: Sequence[tuple[str, str, ArrayLike]]) -> Skeleton:
    """`skeleton` with new sites: `sites` [(name, frame, offset (3,) in the frame's axes)]; a
    site on a site lands on that site's joint. InputError when a name is taken."""
    if not sites:
        return skeleton
    names, joints, offsets, rotations = [], [], [], []
    for name, frame, offset in sites:
        if name in skeleton.frame_names or name in names:
            raise InputError(f"site name {name!r} is already used in {skeleton.name!r}")
        f = skeleton.frame_index(frame)
        offset = np.asarray(offset, float)
        if f < skeleton.n_joints:
            joint, R, base = f, np.eye(3), np.zeros(3)
        else:
            s = f - skeleton.n_joints
            joint, R, base = int(skeleton.site_joint[s]), skeleton.site_rotation[s], skeleton.site_offset[s]
        names.append(name)
        joints.append(joint)
        offsets.append(base + R @ offset)
        rotations.append(R)
    return replace(
        skeleton,
        site_names=skeleton.site_names + tuple(names),
        site_joint=np.concatenate([skeleton.site_joint, joints]).astype(np.int32),
        site_offset=np.concatenate([skeleton.site_offset, offsets]),
        site_rotation=np.concatenate([skeleton.site_rotation, rotations]),
    )

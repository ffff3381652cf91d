"""Contacts on bones and contacts merged: a bone (PARENT-CHILD: a joint and its child joint or end
site, a segment) touches the floor at its lowest point, which for a segment is one of its ends,
both when it lies flat: in a frame where the bone is in contact, each end within BONE_TIE x reach
of the lower end is. Contacts found or given in parts (feet, the body, bones) merge into one.
(Where points rest and the floor lies: cleanup/ground.py.)
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from deik.cleanup.contacts import Contacts, site_positions
from deik.io.trajectory import Motion
from deik.model.capsules import body_reach
from deik.model.skeleton import Skeleton

BONE_TIE = 0.01  # of reach: both ends of a bone this level with each other touch together


def bone_ends(skeleton: Skeleton, name: str) -> tuple[str, str] | None:
    """(parent, child) of a bone named PARENT-CHILD (a joint and its child joint or site), or
    None when `name` is no such pair of names."""
    names = skeleton.frame_names
    J = skeleton.n_joints
    for cut in (k for k, c in enumerate(name) if c == "-"):
        parent, child = name[:cut], name[cut + 1 :]
        if parent in names and child in names:
            c = names.index(child)
            above = int(skeleton.parents[c]) if c < J else int(skeleton.site_joint[c - J])
            if above >= 0 and names[above] == parent:
                return parent, child
    return None


def bone_contacts(clip: Motion, parent: str, child: str, frames: np.ndarray) -> dict[str, np.ndarray]:
    """{end: mask (N,)}: the frames of `frames` (N,) bool in which each end of the bone from
    `parent` to `child` is its lowest point (within BONE_TIE x reach of the lower end)."""
    heights = site_positions(clip, (parent, child)) @ clip.skeleton.up
    lowest = heights.min(axis=1, keepdims=True)
    low = heights <= lowest + BONE_TIE * body_reach(clip.skeleton)
    return {parent: frames & low[:, 0], child: frames & low[:, 1]}


def merge_contacts(parts: Iterable[Contacts], floor: float) -> Contacts:
    """One Contacts of `parts` (Contacts): each site in contact in a frame where any part says so
    (its clearance the first part's that has it), on the floor at `floor`; detected (with the
    first detected part's thresholds) when any part was."""
    masks, clear = {}, {}
    for part in parts:
        for s, site in enumerate(part.sites):
            masks[site] = masks.get(site, False) | part.mask[:, s]
            clear.setdefault(site, float(part.clearance[s]))
    detected = [part for part in parts if part.detected]
    first = detected[0] if detected else None
    sites = tuple(masks)
    mask = np.stack([masks[site] for site in sites], axis=1) if sites else np.zeros((len(parts[0].mask), 0), bool)
    height, speed = (first.height, first.speed) if first else (None, None)
    clearance = np.array([clear[site] for site in sites])
    seams = {n for part in parts for n in part.seams}
    return Contacts(sites, mask, bool(detected), height, speed, floor, clearance, tuple(seams))

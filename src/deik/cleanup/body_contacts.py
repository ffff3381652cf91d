"""Contacts anywhere on the body and the floor they rest on: joints, end sites and bones.

The floor (a height along skeleton.up, length units) is detected as the FLOOR_PERCENTILE-th
percentile over the frames of the lowest joint or site of each frame, so the few frames that dip
through it (a glitch, the crawl's last frames) do not lower it; or it is given.

A point (a joint or end site) rests where it stays when it touches the floor: a knee joint some
centimetres above it, a toe tip on it. Its resting height is its lowest height over the frames it
is slow in, each height the median of three frames (a one-frame dip does not count); a point
whose resting height lies more than NEAR_FRACTION x reach above the floor never touches it. A
point touching the floor is in contact in the frames where it is slow (SPEED_FRACTION x reach
per second, as for feet) and at most BAND_FRACTION x reach above its resting height; gaps and
runs shorter than MIN_FRAMES are filled and dropped (contacts.fill_gaps, drop_short).

A bone (PARENT-CHILD: a joint and its child joint or end site, a segment) touches the floor at
its lowest point, which for a segment is one of its ends, both when it lies flat: in a frame
where the bone is in contact, each end within BONE_TIE x reach of the lower end is.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from deik.cleanup.contacts import SPEED_FRACTION, Contacts, drop_short, fill_gaps, site_positions, speeds, threshold
from deik.io.trajectory import Motion
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton

FLOOR_PERCENTILE = 5.0
NEAR_FRACTION = 0.08  # of reach (8.6 cm on the shared humanoid): a wrist above a flat hand rests 4-7 cm up
BAND_FRACTION = 0.05  # of reach (5.4 cm): a wrist over a flat hand rises and falls with the wrist angle
BONE_TIE = 0.01  # of reach: both ends of a bone this level with each other touch together


def detect_floor(clip: Motion) -> float:
    """The floor height along up (length units): the FLOOR_PERCENTILE-th percentile over the
    frames of each frame's lowest joint or site."""
    if clip.n_frames == 0:
        raise ValueError("the clip has no frames: there is no floor to detect")
    heights = forward_kinematics(clip.skeleton, clip.frames).p_world_frame @ clip.skeleton.up
    return float(np.percentile(heights.min(axis=1), FLOOR_PERCENTILE))


def _median3(heights: np.ndarray) -> np.ndarray:
    """(N, S) median of each frame's height and its two neighbours' (the frame's own at the ends)."""
    if len(heights) < 3:
        return heights
    padded = np.concatenate([heights[:1], heights, heights[-1:]])
    return np.median(np.stack([padded[:-2], padded[1:-1], padded[2:]]), axis=0)


def detect_body_contacts(
    clip: Motion,
    points: Sequence[str] | None = None,
    floor: float | None = None,
    band: float | None = None,
    speed: float | None = None,
) -> Contacts:
    """Contacts of the joints and sites `points` (default: every joint and site) with the floor
    at height `floor` (default detect_floor), found as the module notes say; `band` (length
    units above a point's resting height, default BAND_FRACTION x reach) and `speed` (length
    units per second, default SPEED_FRACTION x reach). Points never in contact are left out
    when `points` is None. KeyError with suggestions for unknown names."""
    sk = clip.skeleton
    every = points is None
    points = tuple(sk.frame_names if every else points)
    if not points:
        raise ValueError("detect_body_contacts needs at least one joint or site")
    floor = detect_floor(clip) if floor is None else float(floor)
    band = threshold(band, BAND_FRACTION * sk.reach, "height")
    speed = threshold(speed, SPEED_FRACTION * sk.reach, "speed")
    p = site_positions(clip, points)
    heights = p @ sk.up
    slow = speeds(p, clip.frame_time) <= speed
    resting = np.where(slow, _median3(heights), np.inf).min(axis=0)
    touches = resting <= floor + NEAR_FRACTION * sk.reach
    mask = drop_short(fill_gaps(slow & touches & (heights <= resting + band)))
    keep = mask.any(axis=0) if every else np.ones(len(points), bool)
    return Contacts(tuple(np.array(points)[keep]), mask[:, keep], True, band, speed, floor)


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
    low = heights <= lowest + BONE_TIE * clip.skeleton.reach
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
    return Contacts(sites, mask, bool(detected), height, speed, floor, np.array([clear[site] for site in sites]))

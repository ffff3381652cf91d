"""How a clip meets the floor: foot skating, penetration below the floor, floating contacts.

The floor is `contacts.ground` (a height along skeleton.up, length units). A contact site sits
at its own height above it when planted (an ankle joint about 5 cm above the sole): its
`clearance`, the lowest height above the floor it reaches in its contact frames in the capture.
Heights of contact sites are measured above floor + clearance, so that floating and skating
mean the same for an ankle joint and a toe tip.

- skating (the foot-skating ratio motion-synthesis papers report): the share of contact
  steps (a site in contact in frames n and n+1) in which a site in contact in both slides
  horizontally more than SKATE_SLIDE (2.5 cm) while lower than SKATE_HEIGHT (5 cm) in both;
- penetration: per frame, the depth of the deepest body point (every joint and end site, or
  the body's surface around each: its clearance below it) below the floor, 0 when none is below;
- floating: per contact site and frame in contact, its height above floor + clearance (0 when
  lower; penetration covers that).
"""

from __future__ import annotations

import numpy as np

from deik.cleanup.contacts import Contacts
from deik.model.geometry import ground_frame
from deik.model.kinematics import Kinematics
from deik.model.skeleton import Skeleton

SKATE_SLIDE = 0.025  # metres a contact site may slide in one frame before it counts as skating
SKATE_HEIGHT = 0.05  # metres above its planted height below which a contact site counts as down


def _site_index(skeleton, sites) -> list[int]:
    return [skeleton.frame_index(name) for name in sites]


def clearance(kin: Kinematics, skeleton: Skeleton, contacts: Contacts) -> np.ndarray:
    """(S,) each contact site's lowest height above contacts.ground over its contact frames in
    the clip whose kinematics are `kin` (the capture), length units; 0 for a site never in
    contact."""
    heights = kin.p_world_frame[:, _site_index(skeleton, contacts.sites)] @ skeleton.up - contacts.ground
    lowest = np.where(contacts.mask, heights, np.inf).min(axis=0, initial=np.inf)
    return np.where(np.isfinite(lowest), lowest, 0.0)


def floating(kin: Kinematics, skeleton: Skeleton, contacts: Contacts, clear: np.ndarray) -> np.ndarray:
    """(N, S) height of each contact site above floor + `clear` (S,) where it is in contact
    (at least 0), NaN elsewhere; length units."""
    heights = kin.p_world_frame[:, _site_index(skeleton, contacts.sites)] @ skeleton.up - contacts.ground - clear
    return np.where(contacts.mask, np.maximum(heights, 0.0), np.nan)


def penetration(kin: Kinematics, skeleton: Skeleton, ground: float, clearance: np.ndarray | None = None) -> np.ndarray:
    """(N,) depth below the floor at height `ground` of the deepest joint or end site in each
    frame (0 when none is below), length units; with `clearance` (F,) (NaN: not counted), of the
    body's surface that far below each."""
    heights = kin.p_world_frame @ skeleton.up
    if clearance is not None:
        heights = heights - np.nan_to_num(clearance, nan=-np.inf)
    return np.maximum(ground - heights.min(axis=1), 0.0)


def skating(
    kin: Kinematics, skeleton: Skeleton, contacts: Contacts, clear: np.ndarray, metres: float
) -> tuple[np.ndarray, np.ndarray]:
    """(skating (N-1,), contact (N-1,)) bool per step from frame n to n+1: `contact` when a site
    is in contact in both frames, `skating` when such a site, lower than SKATE_HEIGHT above floor
    + `clear` (S,) in both, slides horizontally more than SKATE_SLIDE. `metres` per length unit
    converts the thresholds."""
    p = kin.p_world_frame[:, _site_index(skeleton, contacts.sites)]
    plane = ground_frame(np.asarray(skeleton.up, float))[:2].T
    slide = np.linalg.norm(np.diff(p @ plane, axis=0), axis=-1)
    low = p @ skeleton.up - contacts.ground - clear <= SKATE_HEIGHT / metres
    both = contacts.mask[1:] & contacts.mask[:-1]
    skate = both & low[1:] & low[:-1] & (slide > SKATE_SLIDE / metres)
    return skate.any(axis=1), both.any(axis=1)


def skating_ratio(skate: np.ndarray, contact: np.ndarray) -> float:
    """Share (0-1) of the contact steps `contact` (M,) that skate (`skate` (M,)); NaN without
    contact steps."""
    count = int(contact.sum())
    return float(skate.sum()) / count if count else float("nan")

"""Foot contacts of a clip: which sites touch the ground in which frames, and where they plant.

Contacts are detected from the sites' heights along `skeleton.up` and their speeds, or given by
the user as frame ranges. Frames are 0-based; a contact interval (start, stop) excludes stop.

Detection defaults, chosen on the shared humanoid clips (Y up, metres, reach 1.08 m):
- height: HEIGHT_FRACTION = 6 % of `skeleton.reach` above the ground (6.5 cm): the ankle joint of
  a flat foot, about 5 cm above the sole, counts; a heel raised for push-off does not.
- speed: SPEED_FRACTION = 0.5 reach per second (0.54 m/s): planted feet move under 0.1 m/s
  in the walk and jump and swinging ones 1-9 m/s; the threshold keeps the slow roll of the toe
  at heel-off and touch-down.
- ground: the lowest height any site reaches while no faster than the speed threshold (the
  lowest overall when none is ever that slow), so a glitch that drops a moving foot through
  the floor (the run's last frame, 5 cm down) does not lower the floor.
Gaps shorter than MIN_FRAMES frames between two contact runs are filled and runs shorter than
MIN_FRAMES frames then dropped.
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass

import numpy as np

from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton

FOOT_WORDS = ("foot", "toe", "heel", "ankle")
HEIGHT_FRACTION = 0.06
SPEED_FRACTION = 0.5
MIN_FRAMES = 2
RIGID_TOLERANCE = 1e-6  # of reach: sites whose distance varies less are rigidly linked
SNAP_FRACTION = 0.01  # of reach: a plant this close to the floor is put on it
HANDOVER = 3  # frames: a plant starting this soon after a rigidly linked site's ends takes over from it


def foot_sites(skeleton: Skeleton) -> tuple[str, ...]:
    """Joints and sites whose names contain foot, toe, heel or ankle (any case), each joint
    followed by its sites; ValueError when there are none."""
    found = [f for f, name in enumerate(skeleton.frame_names) if any(word in name.lower() for word in FOOT_WORDS)]
    if not found:
        raise ValueError(
            f"skeleton {skeleton.name!r} has no joint or site named like a foot "
            f"({', '.join(FOOT_WORDS)}); name the contact sites with --contact SITE"
        )
    J = skeleton.n_joints
    owner = lambda f: (f, 0) if f < J else (int(skeleton.site_joint[f - J]), 1)  # noqa: E731
    return tuple(skeleton.frame_names[f] for f in sorted(found, key=owner))


def _runs(column: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of each run of True in a (N,) bool array, stop exclusive."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], column.astype(np.int8), [0]])))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


@dataclass(frozen=True, eq=False)
class Contacts:
    """Which of `sites` touch the ground in each frame: `mask` (N, S) bool, read-only.

    `detected`: True when found by detect_contacts, whose thresholds `height` (length units
    above `ground`) and `speed` (length units per second) it keeps; both None for contacts the
    user gave. `ground`: height of the floor along skeleton.up, length units.
    """

    sites: tuple[str, ...]
    mask: np.ndarray
    detected: bool
    height: float | None
    speed: float | None
    ground: float

    def __post_init__(self):
        sites, mask = tuple(self.sites), np.array(self.mask, dtype=bool)
        if mask.ndim != 2 or mask.shape[1] != len(sites):
            raise ValueError(f"mask must have shape (N, {len(sites)}), got {mask.shape}")
        if len(set(sites)) != len(sites):
            raise ValueError(f"contact sites repeat: {sites}")
        mask.setflags(write=False)
        object.__setattr__(self, "sites", sites)
        object.__setattr__(self, "mask", mask)

    def intervals(self, site: int | str) -> list[tuple[int, int]]:
        """Contact intervals (start, stop) of a site, by index or name; stop exclusive."""
        if isinstance(site, str):
            if site not in self.sites:
                raise KeyError(f"{site!r} is not a contact site; the sites are {self.sites}")
            site = self.sites.index(site)
        return _runs(self.mask[:, site])

    def describe(self) -> str:
        """One line per site: its contact frames and intervals, shown inclusive (first-last)."""
        lines = []
        for s, name in enumerate(self.sites):
            spans = self.intervals(s)
            if not spans:
                lines.append(f"{name}: no contact")
                continue
            shown = ", ".join(f"{a}-{b - 1}" for a, b in spans)
            count = len(spans)
            lines.append(
                f"{name}: {int(self.mask[:, s].sum())} frames in {count} contact{'s' if count > 1 else ''} ({shown})"
            )
        return "\n".join(lines)


def site_positions(clip, sites) -> np.ndarray:
    """World positions (N, S, 3) of `sites` in every frame; KeyError for unknown names."""
    index = [clip.skeleton.frame_index(name) for name in sites]
    return forward_kinematics(clip.skeleton, clip.frames).p_world_frame[:, index]


def threshold(value, default: float, what: str) -> float:
    """`value` (default `default` when None) checked to be a number >= 0, else ValueError."""
    value = default if value is None else float(value)
    if not value >= 0:
        raise ValueError(f"the contact {what} threshold must be a number >= 0, got {value}")
    return value


def detect_contacts(clip, sites=None, height=None, speed=None) -> Contacts:
    """Contacts of `sites` (default foot_sites) found in `clip` (see the module notes).

    A site touches the ground in frame n when its height along up is at most ground + `height`
    (length units; default 6 % of reach) and its speed, by central differences over frame_time
    (one-sided at the ends), is at most `speed` (length units per second; default 0.5 reach/s).
    Runs shorter than 2 frames are dropped. KeyError with suggestions for unknown site names.
    """
    sk = clip.skeleton
    sites = foot_sites(sk) if sites is None else tuple(sites)
    if not sites:
        raise ValueError("detect_contacts needs at least one site")
    if clip.n_frames == 0:
        raise ValueError("the clip has no frames: there are no contacts to detect")
    height = threshold(height, HEIGHT_FRACTION * sk.reach, "height")
    speed = threshold(speed, SPEED_FRACTION * sk.reach, "speed")
    p = site_positions(clip, sites)
    heights = p @ sk.up
    slow = speeds(p, clip.frame_time) <= speed
    ground = float(heights[slow].min() if slow.any() else heights.min())
    return Contacts(sites, drop_short(fill_gaps(slow & (heights <= ground + height))), True, height, speed, ground)


def speeds(p: np.ndarray, frame_time: float) -> np.ndarray:
    """(N, S) speed of points p (N, S, 3) by central differences over `frame_time` (one-sided
    at the ends; 0 for a single frame), length units per second."""
    if len(p) < 2:
        return np.zeros(p.shape[:2])
    return np.linalg.norm(np.gradient(p, frame_time, axis=0), axis=-1)


def fill_gaps(mask: np.ndarray) -> np.ndarray:
    """(N, S) contact `mask` with its gaps shorter than MIN_FRAMES frames between two contact
    runs filled: a point that is slow and low on both sides of one frame never left the floor,
    and two plants either side would make it jump."""
    mask = np.array(mask, bool)
    for s in range(mask.shape[1]):
        runs = _runs(mask[:, s])
        for (_, stop), (start, _) in zip(runs, runs[1:]):
            if start - stop < MIN_FRAMES:
                mask[stop:start, s] = True
    return mask


def drop_short(mask: np.ndarray) -> np.ndarray:
    """(N, S) contact `mask` without its runs shorter than MIN_FRAMES frames."""
    mask = np.array(mask, bool)
    for s in range(mask.shape[1]):
        for a, b in _runs(mask[:, s]):
            if b - a < MIN_FRAMES:
                mask[a:b, s] = False
    return mask


def contacts_from_ranges(clip, ranges: dict) -> Contacts:
    """Contacts given by the user: {site: [(start, stop), ...]} with 0 <= start < stop <= N
    (stop exclusive). ValueError naming the site and range when a range leaves the clip; KeyError
    with suggestions for unknown sites. `ground` is the lowest height of a site in contact."""
    sites = tuple(ranges)
    for name in sites:
        clip.skeleton.frame_index(name)
    N = clip.n_frames
    mask = np.zeros((N, len(sites)), dtype=bool)
    for s, name in enumerate(sites):
        for span in ranges[name]:
            start, stop = (operator.index(v) for v in span)
            if not 0 <= start < stop <= N:
                valid = f"0..{N - 1}" if N else "none: the clip has no frames"
                raise ValueError(
                    f"contact range ({start}, {stop}) of site {name!r} is outside the "
                    f"clip or empty; ranges are (start, stop) with stop exclusive, "
                    f"valid frames: {valid}"
                )
            mask[start:stop, s] = True
    heights = site_positions(clip, sites) @ clip.skeleton.up
    chosen = heights[mask] if mask.any() else heights.ravel()
    ground = float(chosen.min()) if chosen.size else math.nan
    return Contacts(sites, mask, False, None, None, ground)


def _rigid_pairs(p: np.ndarray, reach: float) -> list[tuple[int, int, float]]:
    """(s, t, distance) of the sites whose distance stays the same in every frame of
    positions `p` (N, S, 3): an ankle and its toe, moved by no DOF between them."""
    pairs = []
    for s in range(p.shape[1]):
        for t in range(s + 1, p.shape[1]):
            distance = np.linalg.norm(p[:, s] - p[:, t], axis=-1)
            if np.ptp(distance) <= RIGID_TOLERANCE * reach:
                pairs.append((s, t, float(distance.mean())))
    return pairs


def _at_distance(point: np.ndarray, anchor: np.ndarray, distance: float, up: np.ndarray) -> np.ndarray:
    """`point` (3,) moved to lie `distance` from `anchor` (3,): along the ground, keeping its
    height, when their heights differ by less than `distance`, else along the line between
    them; unchanged when they coincide (no direction to move in)."""
    delta = point - anchor
    rise = delta @ up
    flat = delta - rise * up
    if abs(rise) < distance and np.linalg.norm(flat) > 0:
        return anchor + rise * up + flat * (np.sqrt(distance**2 - rise**2) / np.linalg.norm(flat))
    if np.linalg.norm(delta) > 0:
        return anchor + delta * (distance / np.linalg.norm(delta))
    return point


def _links(plants: dict, pairs, p: np.ndarray, up: np.ndarray) -> dict:
    """{plant: [(other plant, place)]}: how each plant of a rigidly linked site (`pairs`) is put
    relative to the other's, place(anchor) -> target (3,). Overlapping intervals: their
    distance apart (_at_distance). Intervals that hand over (one starts at most HANDOVER frames
    after the other stops, a heel lifting as the toe lands): the capture's offset between the
    two at the handover, along the ground (each keeps its height), so the foot does not jump
    where one plant ends and the other begins. `p` (N, S, 3): the sites' capture positions."""
    links = {key: [] for key in plants}
    for s, t, distance in pairs:
        for first in [key for key in plants if key[0] == s]:
            for second in [key for key in plants if key[0] == t]:
                if max(first[1], second[1]) < min(first[2], second[2]):
                    links[first].append((second, lambda a, key=second, d=distance: _at_distance(plants[key], a, d, up)))
                    links[second].append((first, lambda a, key=first, d=distance: _at_distance(plants[key], a, d, up)))
                    continue
                for early, late in ((first, second), (second, first)):
                    if 0 <= late[1] - early[2] < HANDOVER:
                        offset = p[early[2] - 1, late[0]] - p[early[2] - 1, early[0]]
                        offset -= (offset @ up) * up
                        for key, other, sign in ((late, early, 1.0), (early, late, -1.0)):
                            links[other].append(
                                (key, lambda anchor, key=key, o=sign * offset: _on_level(anchor + o, plants[key], up))
                            )
    return links


def _on_level(point: np.ndarray, height_of: np.ndarray, up: np.ndarray) -> np.ndarray:
    """`point` (3,) at the height of `height_of` (3,) along up."""
    return point + ((height_of - point) @ up) * up


def _linked_plants(plants: dict, pairs, p: np.ndarray, up: np.ndarray) -> dict:
    """`plants` {(site, start, stop): target (3,)} with the plants of two rigidly linked sites
    (`pairs`) placed relative to each other (_links). Linked plants form groups (a toe planted
    through two plants of its ankle, a heel lifting and landing again): each group's longest
    plant stays, and the others are placed in turn relative to the one placed before them they
    are linked to, so every link of a chain holds; a link closing a loop holds only
    approximately."""
    links = _links(plants, pairs, p, up)
    out = dict(plants)
    placed = set()
    for root in sorted(plants, key=lambda key: (key[1] - key[2], key[1], key[0])):  # longest first
        if root in placed:
            continue
        placed.add(root)
        queue = [root]
        while queue:
            anchor = queue.pop(0)
            for key, place in links[anchor]:
                if key not in placed:
                    out[key] = place(out[anchor])
                    placed.add(key)
                    queue.append(key)
    return out


def _lifted_heights(heights: np.ndarray, mask: np.ndarray, pairs, floor: float) -> np.ndarray:
    """(N, S) heights of the contact sites, each frame's raised by the depth below `floor` of
    the deepest of the site and the sites rigidly linked to it (`pairs`) in contact then: a
    foot sunk through the floor (legs made longer) plants its ankle as high above the floor as
    its toe is above the sole."""
    depth = np.where(mask, np.maximum(floor - heights, 0.0), 0.0)
    lift = depth.copy()
    for s, t, _ in pairs:
        lift[:, s] = np.maximum(lift[:, s], depth[:, t])
        lift[:, t] = np.maximum(lift[:, t], depth[:, s])
    return heights + lift


def planted_targets(clip, contacts: Contacts) -> np.ndarray:
    """Where each site should stay planted: (N, S, 3) length units, NaN outside contacts.

    Per contact interval, the mean world position of the site over the interval in `clip` (the
    original), at the median of its heights along up there (a one-frame dip does not lower
    it), each frame's height first raised by how far the site or a site rigidly linked to it
    is below the floor (`contacts.ground`); a height within SNAP_FRACTION x reach of the floor
    is put on it. Two sites a fixed distance apart (an ankle and its toe) whose intervals
    overlap get targets that distance apart (_linked_plants), so both can be met at once.
    """
    if contacts.mask.shape[0] != clip.n_frames:
        raise ValueError(f"contacts cover {contacts.mask.shape[0]} frames, the clip has {clip.n_frames}")
    up = clip.skeleton.up
    p = site_positions(clip, contacts.sites)
    pairs = _rigid_pairs(p, clip.skeleton.reach)
    floor = contacts.ground
    heights = _lifted_heights(p @ up, contacts.mask, pairs, floor)
    plants = {}  # (site, start, stop) -> target (3,)
    for s in range(len(contacts.sites)):
        for a, b in contacts.intervals(s):
            mean = p[a:b, s].mean(axis=0)
            height = float(np.median(heights[a:b, s]))
            if abs(height - floor) <= SNAP_FRACTION * clip.skeleton.reach:
                height = floor
            plants[s, a, b] = mean + (height - mean @ up) * up
    plants = _linked_plants(plants, pairs, p, up)
    targets = np.full(p.shape, np.nan)
    for (s, a, b), target in plants.items():
        targets[a:b, s] = target
    return targets

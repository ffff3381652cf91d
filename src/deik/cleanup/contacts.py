"""Foot contacts of a clip: which sites touch the ground in which frames (cleanup/plants.py: where).

Contacts are detected from the sites' heights along `skeleton.up` and their speeds, or given by
the user as frame ranges. Frames are 0-based; a contact interval (start, stop) excludes stop.

Detection defaults, chosen on the shared humanoid clips (Y up, metres, reach 1.08 m):
- height: HEIGHT_FRACTION = 6 % of the body's reach (body_reach) above the ground (6.5 cm): the ankle
  joint of a flat foot, about 5 cm above the sole, counts; a heel raised for push-off does not.
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
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from deik.errors import InputError, UnknownNameError
from deik.io.motion import message_prefix
from deik.io.trajectory import Motion
from deik.model.capsules import body_reach
from deik.model.skeleton import Skeleton

FOOT_WORDS = ("foot", "toe", "heel", "ankle")
HEIGHT_FRACTION = 0.06
SPEED_FRACTION = 0.5
MIN_FRAMES = 2


def foot_sites(skeleton: Skeleton) -> tuple[str, ...]:
    """Joints and sites whose names contain foot, toe, heel or ankle (any case), each joint
    followed by its sites; ValueError when there are none."""
    found = [f for f, name in enumerate(skeleton.frame_names) if any(word in name.lower() for word in FOOT_WORDS)]
    if not found:
        raise InputError(
            f"skeleton {skeleton.name!r} has no joint or site named like a foot "
            f"({', '.join(FOOT_WORDS)}); name the contact sites with --contact SITE"
        )
    J = skeleton.n_joints
    owner = lambda f: (f, 0) if f < J else (int(skeleton.site_joint[f - J]), 1)  # noqa: E731
    return tuple(skeleton.frame_names[f] for f in sorted(found, key=owner))


def true_runs(column: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of each run of True in a (N,) bool array, stop exclusive."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], column.astype(np.int8), [0]])))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


def running_max(values: np.ndarray, w: int) -> np.ndarray:
    """(N, ...) the largest of `values` (N, ...) within `w` frames of each, along the first axis
    (the end frames held beyond the ends, which changes no maximum). In log2(2w + 1) passes:
    each doubles the span a row covers, and two overlapping spans cover the window."""
    if w <= 0 or not len(values):
        return np.array(values, copy=True)
    width = 2 * w + 1
    level, span = np.pad(values, [(w, w)] + [(0, 0)] * (values.ndim - 1), mode="edge"), 1
    while 2 * span <= width:
        level, span = np.maximum(level[:-span], level[span:]), 2 * span
    n = len(values)
    return np.maximum(level[:n], level[width - span : width - span + n])


@dataclass(frozen=True, eq=False)
class Contacts:
    """Which of `sites` touch the ground in each frame: `mask` (N, S) bool, read-only.

    `detected`: True when found by a detector, whose thresholds `height` (length units above
    `ground`, or above the site's clearance) and `speed` (length units per second) it keeps;
    both None for contacts the user gave. `ground`: height of the floor along skeleton.up,
    length units. `clearance` (S,): how far above the floor each site sits when it touches (a
    limb's radius; cleanup/ground.py), None for 0 (a sole, a toe tip). `seams`: the steps n
    (frame n to n + 1) where the clip's pose jumps (cleanup/cuts.py, two takes in one file): a
    contact over one is two, one planted on each side.
    """

    sites: tuple[str, ...]
    mask: np.ndarray
    detected: bool
    height: float | None
    speed: float | None
    ground: float
    clearance: np.ndarray | None = None
    seams: tuple[int, ...] = ()

    def __post_init__(self):
        sites, mask = tuple(self.sites), np.array(self.mask, dtype=bool)
        if mask.ndim != 2 or mask.shape[1] != len(sites):
            raise InputError(f"mask must have shape (N, {len(sites)}), got {mask.shape}")
        if len(set(sites)) != len(sites):
            raise InputError(f"contact sites repeat: {sites}")
        mask.setflags(write=False)
        object.__setattr__(self, "sites", sites)
        object.__setattr__(self, "mask", mask)
        clearance = np.zeros(len(sites)) if self.clearance is None else np.array(self.clearance, float)
        if clearance.shape != (len(sites),):
            raise InputError(f"clearance must have shape ({len(sites)},), got {clearance.shape}")
        clearance.setflags(write=False)
        object.__setattr__(self, "clearance", clearance)
        object.__setattr__(self, "seams", tuple(sorted({int(n) for n in self.seams})))

    def intervals(self, site: int | str) -> list[tuple[int, int]]:
        """Contact intervals (start, stop) of a site, by index or name; stop exclusive; a run of
        frames over a seam is two intervals."""
        if isinstance(site, str):
            if site not in self.sites:
                raise UnknownNameError(f"{site!r} is not a contact site; the sites are {self.sites}")
            site = self.sites.index(site)
        out = []
        for a, b in true_runs(self.mask[:, site]):
            cuts = [n + 1 for n in self.seams if a <= n and n + 1 < b]
            out += list(zip([a, *cuts], [*cuts, b]))
        return out

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


def site_positions(clip: Motion, sites: Sequence[str]) -> np.ndarray:
    """World positions (N, S, 3) of `sites` in every frame; KeyError for unknown names."""
    index = [clip.skeleton.frame_index(name) for name in sites]
    return clip.kinematics.p_world_frame[:, index]


def threshold(value: float | None, default: float, what: str) -> float:
    """`value` (default `default` when None) checked to be a number >= 0, else ValueError."""
    value = default if value is None else float(value)
    if not value >= 0:
        raise InputError(f"the contact {what} threshold must be a number >= 0, got {value}")
    return value


def detect_contacts(
    clip: Motion, sites: Sequence[str] | None = None, height: float | None = None, speed: float | None = None
) -> Contacts:
    """Contacts of `sites` (default foot_sites) found in `clip` (see the module notes).

    A site touches the ground in frame n when its height along up is at most ground + `height`
    (length units; default 6 % of reach) and its speed, by central differences over frame_time
    (one-sided at the ends), is at most `speed` (length units per second; default 0.5 reach/s).
    Runs shorter than 2 frames are dropped. KeyError with suggestions for unknown site names.
    """
    sk = clip.skeleton
    sites = foot_sites(sk) if sites is None else tuple(sites)
    if not sites:
        raise InputError("detect_contacts needs at least one site")
    if clip.n_frames == 0:
        raise InputError(f"{message_prefix(clip)}the clip has no frames (Frames: 0): there are no contacts to detect")
    height = threshold(height, HEIGHT_FRACTION * body_reach(sk), "height")
    speed = threshold(speed, SPEED_FRACTION * body_reach(sk), "speed")
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


def fill_gaps(
    mask: np.ndarray, frames: int = MIN_FRAMES, positions: np.ndarray | None = None, step: float | np.ndarray = np.inf
) -> np.ndarray:
    """(N, S) contact `mask` with its gaps shorter than `frames` frames between two contact
    runs filled: a point that is slow and low on both sides of one frame never left the floor,
    and two plants either side would make it jump. With `positions` (N, S, 3), a gap across
    which the point moves (from the run's last frame to the next's first) more than `step`
    (length units, a number or (S,)) a frame on average stays: the point went somewhere,
    faster than resting speed (a pivot, a shuffle), and one plant over both runs would hold it
    still through a move the capture makes."""
    mask = np.array(mask, bool)
    step = np.broadcast_to(step, mask.shape[1:])
    for s in range(mask.shape[1]):
        runs = true_runs(mask[:, s])
        for (_, stop), (start, _) in zip(runs, runs[1:]):
            moved = 0.0 if positions is None else np.linalg.norm(positions[start, s] - positions[stop - 1, s])
            if start - stop < frames and moved <= step[s] * (start - stop + 1):
                mask[stop:start, s] = True
    return mask


def drop_short(mask: np.ndarray, frames: int = MIN_FRAMES) -> np.ndarray:
    """(N, S) contact `mask` without its runs shorter than `frames` frames."""
    mask = np.array(mask, bool)
    for s in range(mask.shape[1]):
        for a, b in true_runs(mask[:, s]):
            if b - a < frames:
                mask[a:b, s] = False
    return mask


def contacts_from_ranges(clip: Motion, ranges: dict[str, list[tuple[int, int]]]) -> Contacts:
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
                raise InputError(
                    f"contact range ({start}, {stop}) of site {name!r} is outside the "
                    f"clip or empty; ranges are (start, stop) with stop exclusive, "
                    f"valid frames: {valid}"
                )
            mask[start:stop, s] = True
    heights = site_positions(clip, sites) @ clip.skeleton.up
    chosen = heights[mask] if mask.any() else heights.ravel()
    ground = float(chosen.min()) if chosen.size else math.nan
    return Contacts(sites, mask, False, None, None, ground)

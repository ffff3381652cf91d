"""Rests read through a capture's shake: where a clip's points shake (cleanup/noise.py) more than
motion captured cleanly shows, the shake hides where they rest, and these rules find them again.
Speeds are length units per second, times seconds, `limit` the resting speed (cleanup/ground.py).

A capture shakes when the median, over the points read, of their noise at rest
(noise.noise_levels) is above noise.NOISY x span (shaking_levels). At 30 fps a capture is not
low-passed (noise.py); at 45 fps or more it is, and the filtered motion no longer shakes that
much, so `deik clip` reads a rest's edges (held_through_noise) on the capture as given, where the
shake shows, and `deik retarget` on its source as it reads it.

- Slow through noise (slow_through_noise): the shake adds to every speed, and a resting toe moved
  10-20 mm a frame by it read fast in the frames that hold its rest's ends or a short pivot:
  unplanted, they slid 2-20 mm a frame (`python -m benchmarks.clip_targets`: the game rigs' kick
  and punch with noise). A point is also slow where its speed is at most resting speed plus
  NOISE_SPEED times the deviation its own white noise gives that speed, and it moves along the
  ground over DRIFT_SECONDS either side at most DRIFT x resting speed (drift_speeds): the shake
  averages out over those frames and a slide does not, so a foot sliding just under resting
  speed is not read as resting through its noise (a punch's toe sliding 7 mm a frame, planted
  so, sank the body 10-16 mm).
- Edges held through noise (held_through_noise): a single frame's shake can still be a few of its
  deviations, and where it falls on the first or last frame of a rest that frame reads fast: left
  unplanted it keeps the shake, a slide of several millimetres in a frame in which the foot stood
  (the walk, kick, punch and dance with other draws of the same noise slid 4.7-14.5 mm a frame
  there, unlisted: tests/cleanup/test_clip_shaking.py). So a rest carries on, at either end, through up
  to DRIFT_SECONDS of frames in which the point is near the floor (the resting band), lies in
  height within HELD deviations of its noise in height of where it rested in the frames of the
  rest nearest that end (their mean, whose own noise the bound counts), and either drifts slowly
  (as above) or lies along the ground within HELD deviations of its noise along the ground of
  where it rested. The height keeps a foot that is still coming down, or already lifting, off the
  floor's plants: a toe carried back into the frames in which it still came down as its heel
  struck fought the heel's plant, and a foot carried into the frame it rose 13 mm in jolted where
  it was let go (the procedural walk at 30 fps with noise: 6 mm a frame, 11 frames missed). The
  deviations are read along the ground and in height apart, each at least the median of the
  body's points (a point's own, read from the few frames it rests in, fell to half its noise on
  made-up paths): a foot's shake is mostly along the ground (a turn of the leg swings it), and
  read together they halved it. At HELD = 3.5 deviations a frame resting through white noise
  passes both bounds 99.7 % of the time; DRIFT_SECONDS is the most a rest is carried on, 2 frames
  at 30 fps, 3 at 60, 6 at 120 (one frame at 30 fps left more cases of `python -m
  benchmarks.noise_draws` sliding past 5 mm a frame: docs/decisions.md).
"""

from __future__ import annotations

import numpy as np

from deik.cleanup.noise import NOISY, noise_levels
from deik.cleanup.speeds import NO_SEAMS, SMOOTH, point_speeds, rates, smoothed

NOISE_SPEED = 2.0  # deviations of a point's noise in its speed that a shaking rest may read
DRIFT = 0.7  # of resting speed: how fast a shaking rest may move along the ground over DRIFT_SECONDS either side
DRIFT_SECONDS = 0.05
HELD = 3.5  # deviations of a point's noise: how far a shaking rest's edge may lie from where it rested


def shaking_levels(positions: np.ndarray, frame_time: float, limit: float, span: float) -> np.ndarray | None:
    """(K,) the capture noise of each point at `positions` (N, K, 3) (noise.noise_levels, length
    units) where the capture shakes (the median of those read above NOISY x `span`, the body's
    size); None where it does not, and under 5 frames."""
    levels = noise_levels(positions, frame_time, limit)
    read = levels[levels > 0]
    return levels if read.size and np.median(read) > NOISY * span else None


def drift_speeds(positions: np.ndarray, frame_time: float, up: np.ndarray) -> np.ndarray:
    """(N, K) how fast points at `positions` (N, K, 3) move along the ground (across `up` (3,)) from
    DRIFT_SECONDS before each frame to DRIFT_SECONDS after it (fewer at the clip's ends)."""
    N = len(positions)
    along = positions - (positions @ up)[..., None] * up
    reach = max(1, int(np.ceil(DRIFT_SECONDS / frame_time)))
    frames = np.arange(N)
    before, after = np.maximum(frames - reach, 0), np.minimum(frames + reach, N - 1)
    return np.linalg.norm(along[after] - along[before], axis=-1) / (np.maximum(after - before, 1)[:, None] * frame_time)


def slow_through_noise(
    positions: np.ndarray, frame_time: float, limit: float, span: float, up: np.ndarray, seams: np.ndarray = NO_SEAMS
) -> np.ndarray:
    """(N, K) bool: the frames in which points at `positions` (N, K, 3) are slow through their
    capture noise (module notes; `span` the body's size, `up` (3,) the up axis; no speed spans the
    `seams`, a drift across one is a jump); none where the capture does not shake."""
    levels = shaking_levels(positions, frame_time, limit, span)
    if levels is None:
        return np.zeros(positions.shape[:2], bool)
    impulse = np.zeros(2 * int(np.ceil(3 * SMOOTH / frame_time)) + 3)
    impulse[len(impulse) // 2] = 1.0
    gain = np.linalg.norm(rates(smoothed(impulse, frame_time), frame_time))  # white noise's deviation in a speed
    fast = point_speeds(positions, frame_time, seams) > limit + NOISE_SPEED * gain * levels
    return ~fast & (drift_speeds(positions, frame_time, up) <= DRIFT * limit)


def _at_least_typical(levels: np.ndarray) -> np.ndarray:
    """`levels` (K,), each raised to the median of those read: a point's own level, read from the
    few frames it rests in, may fall well under its noise (module notes)."""
    read = levels[levels > 0]
    return np.maximum(levels, np.median(read)) if read.size else levels


def _in_deviations(positions: np.ndarray, frame_time: float, limit: float, up: np.ndarray) -> np.ndarray:
    """(N, K, 3) points at `positions` (N, K, 3) in a frame of two directions along the ground and
    `up`, each coordinate over the point's noise along the ground or in height (inf where a noise
    is not read)."""
    basis = np.column_stack([np.linalg.svd(np.eye(3) - np.outer(up, up))[0][:, :2], up])
    coordinates = positions @ basis
    along, height = (_at_least_typical(noise_levels(c, frame_time, limit)) for c in np.split(coordinates, [2], axis=-1))
    scale = np.stack([along, along, height], axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(scale > 0, coordinates / scale, np.inf)


def _carried(off: np.ndarray, calm: np.ndarray, bound: float) -> int:
    """How many frames, in order away from a rest, carry it on (module notes): `off` (M, 3) their
    offsets from where it rested in deviations of the point's noise (along the ground, then in
    height), `calm` (M,) whether each drifts slowly; `bound` the deviations allowed."""
    held = (calm | (np.linalg.norm(off[:, :2], axis=-1) <= bound)) & (np.abs(off[:, 2]) <= bound)
    return len(held) if held.all() else int(np.argmin(held))


def held_through_noise(
    rest: np.ndarray,
    positions: np.ndarray,
    low: np.ndarray,
    frame_time: float,
    limit: float,
    span: float,
    up: np.ndarray,
) -> np.ndarray:
    """`rest` (N, K) with each run carried on through the frames at its ends in which the points at
    `positions` (N, K, 3), as captured, rest through their noise (module notes: edges held
    through noise); `low` (N, K) whether each is near the floor; as it is where the capture does
    not shake (`span` the body's size, `up` (3,) the up axis)."""
    rest = np.array(rest, bool)
    if shaking_levels(positions, frame_time, limit, span) is None:
        return rest
    scaled = np.where(low[..., None], _in_deviations(positions, frame_time, limit, up), np.inf)
    calm = low & (drift_speeds(positions, frame_time, up) <= DRIFT * limit)
    most = max(1, int(np.ceil(DRIFT_SECONDS / frame_time)))
    for k in range(rest.shape[1]):
        runs = np.flatnonzero(np.diff(np.concatenate([[0], rest[:, k].astype(np.int8), [0]])))
        for start, stop in zip(runs[::2], runs[1::2]):
            w = min(most + 1, stop - start)
            bound = HELD * np.sqrt(1.0 + 1.0 / w)  # a frame's noise and that of the mean of w frames
            before = np.arange(start - 1, max(start - most, 0) - 1, -1)
            after = np.arange(stop, min(stop + most, len(rest)))
            with np.errstate(invalid="ignore"):
                landed = scaled[before, k] - scaled[start : start + w, k].mean(axis=0)
                lifted = scaled[after, k] - scaled[stop - w : stop, k].mean(axis=0)
            first = start - _carried(landed, calm[before, k], bound)
            end = stop + _carried(lifted, calm[after, k], bound)
            rest[first:end, k] = True
    return rest

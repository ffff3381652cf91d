"""Rests read through a capture's shake: where a clip's points shake (cleanup/noise.py) more than
motion captured cleanly shows, the shake hides where they rest, and these rules find them again.
Speeds are length units per second, times seconds, `limit` the resting speed (cleanup/ground.py).

A capture shakes when the median, over the points read, of their noise is above noise.NOISY x
span (shaking_levels). The noise is read at rest, or, where the frames are dense enough to be
low-passed and no point rests long enough, over all frames (noise.read_noise: a run's feet at
120 fps rest 0.07 s). At lower rates a smooth motion's fourth differences are not small beside
its second: read over all frames, a clean kick played twice as fast at 30 fps read as shaking,
and a punch shaken by 1 degree on every channel as shaking far more than it does, and their
retargets onto human.urdf planted false rests (the punch slid 11 mm a frame, 0.02 before).

At 30 fps a capture is not low-passed (noise.py); at 45 fps or more it is, and the filtered
motion no longer shakes that much, so `deik clip` reads a rest's edges (held_through_noise) on
the capture as given, where the shake shows, and `deik retarget` likewise on its source as given.

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
  benchmarks.noise_draws` sliding past 5 mm a frame: docs/decisions.md). At the clip's first and
  last frames a rest is carried on as far as they lie within 2 x DRIFT_SECONDS: a speed there is
  read on fewer frames and the shake weighs more, and a foot resting from the first frame of the
  punch shaken by 0.35 degrees read fast for three frames and kept a 31 mm step of the shake.
- Gaps bridged through noise: where the shake hides a few frames inside a rest, the frames either
  side are still carried on only if they lie within the bound, and one frame past it leaves the
  gap (the punch on the game rig with digits and its 13th draw of the noise, whose toe rested
  from frame 31 on: its frames 32 and 33, 4.3 and 4.4 deviations from where it rested, kept a
  step of 18.9 mm). So two
  runs of a point at most DRIFT_SECONDS apart, the frames between them near the floor, are one
  rest when where the point rested before the gap and after it (the means of each side's frames
  nearest the gap) lie apart by no more than resting speed moves it between them, give or take
  HELD deviations of the two means' noise, and in height within HELD of those deviations: a
  point that went somewhere in the gap (a shuffle, a pivot) keeps its two rests.
"""

from __future__ import annotations

import numpy as np

from deik.cleanup.contacts import true_runs
from deik.cleanup.noise import NOISY, low_passed_rate, noise_levels, read_noise
from deik.cleanup.speeds import NO_SEAMS, SMOOTH, point_speeds, rates, smoothed

NOISE_SPEED = 2.0  # deviations of a point's noise in its speed that a shaking rest may read
DRIFT = 0.7  # of resting speed: how fast a shaking rest may move along the ground over DRIFT_SECONDS either side
DRIFT_SECONDS = 0.05
HELD = 3.5  # deviations of a point's noise: how far a shaking rest's edge may lie from where it rested


def _noise(positions: np.ndarray, frame_time: float, limit: float) -> np.ndarray:
    """(K,) the noise of each point at `positions` (N, K, D) (module notes): noise.read_noise
    where the frames are dense enough to be low-passed, else read at rest only (noise_levels)."""
    read = read_noise if low_passed_rate(frame_time) else noise_levels
    return read(positions, frame_time, limit)


def shaking_levels(positions: np.ndarray, frame_time: float, limit: float, span: float) -> np.ndarray | None:
    """(K,) the capture noise of each point at `positions` (N, K, 3) (_noise, length
    units) where the capture shakes (the median of those read above NOISY x `span`, the body's
    size); None where it does not, and under 5 frames."""
    levels = _noise(positions, frame_time, limit)
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


def _in_deviations(
    positions: np.ndarray, frame_time: float, limit: float, up: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(N, K, 3) points at `positions` (N, K, 3) in a frame of two directions along the ground and
    `up`, each coordinate over the point's noise along the ground or in height (inf where a noise
    is not read), and (K,) that noise along the ground (length units)."""
    basis = np.column_stack([np.linalg.svd(np.eye(3) - np.outer(up, up))[0][:, :2], up])
    coordinates = positions @ basis
    along, height = (_at_least_typical(_noise(c, frame_time, limit)) for c in np.split(coordinates, [2], axis=-1))
    scale = np.stack([along, along, height], axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(scale > 0, coordinates / scale, np.inf), along


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
    `positions` (N, K, 3), as captured, rest through their noise, and the short gaps between runs
    they rest through bridged (module notes: edges held, gaps bridged through noise); `low`
    (N, K) whether each is near the floor; as it is where the capture does not shake (`span` the
    body's size, `up` (3,) the up axis)."""
    rest = np.array(rest, bool)
    if shaking_levels(positions, frame_time, limit, span) is None:
        return rest
    scaled, along = _in_deviations(positions, frame_time, limit, up)
    scaled = np.where(low[..., None], scaled, np.inf)
    calm = low & (drift_speeds(positions, frame_time, up) <= DRIFT * limit)
    most = max(1, int(np.ceil(DRIFT_SECONDS / frame_time)))
    for k in range(rest.shape[1]):
        for start, stop in true_runs(rest[:, k]):
            first, end = _carried_edges(scaled[:, k], calm[:, k], (start, stop), most)
            rest[first:end, k] = True
        step = limit * frame_time / along[k] if along[k] > 0 else np.inf
        runs = true_runs(rest[:, k])
        for sooner, later in zip(runs, runs[1:]):
            if _bridged(scaled[:, k], sooner, later, step, most):
                rest[sooner[1] : later[0], k] = True
    return rest


def _carried_edges(scaled: np.ndarray, calm: np.ndarray, run: tuple[int, int], most: int) -> tuple[int, int]:
    """(first, stop) of the rest `run` (start, stop) of a point carried on at either end (module
    notes: edges held through noise), `scaled` (N, 3) its points in deviations of its noise
    (_in_deviations, inf where not near the floor), `calm` (N,) where it drifts slowly; at most
    `most` frames, or to the clip's edge where that lies within 2 x `most`."""
    start, stop = run
    n = len(scaled)
    w = min(most + 1, stop - start)
    bound = HELD * np.sqrt(1.0 + 1.0 / w)  # a frame's noise and that of the mean of w frames
    before = np.arange(start - 1, start - (start if start <= 2 * most else most) - 1, -1)
    after = np.arange(stop, stop + (n - stop if n - stop <= 2 * most else most))
    with np.errstate(invalid="ignore"):
        landed = scaled[before] - scaled[start : start + w].mean(axis=0)
        lifted = scaled[after] - scaled[stop - w : stop].mean(axis=0)
    return start - _carried(landed, calm[before], bound), stop + _carried(lifted, calm[after], bound)


def _bridged(scaled: np.ndarray, sooner: tuple[int, int], later: tuple[int, int], step: float, most: int) -> bool:
    """Whether a point rests on through the gap between its runs `sooner` and `later` (start,
    stop) (module notes: gaps bridged through noise): `scaled` (N, 3) its points in deviations of
    its noise (_in_deviations, inf where not near the floor), `step` resting speed's move in a
    frame in those deviations; at most `most` frames apart, each side read on its `most` + 1
    frames nearest the gap."""
    gap = later[0] - sooner[1]
    first, end = max(sooner[0], sooner[1] - most - 1), min(later[1], later[0] + most + 1)
    if gap > most or not np.isfinite(scaled[first:end]).all():  # both sides and the gap near the floor
        return False
    a, b = scaled[first : sooner[1]], scaled[later[0] : end]
    moved = b.mean(axis=0) - a.mean(axis=0)
    apart = (len(a) + len(b)) / 2.0 + gap  # frames between the two means' middles
    noise = HELD * np.sqrt(1.0 / len(a) + 1.0 / len(b))
    return bool(np.linalg.norm(moved[:2]) <= step * apart + noise and abs(moved[2]) <= noise)

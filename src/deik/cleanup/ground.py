"""Where a clip's body rests: the floor it stands on, how high above it each point sits when it
touches, and which points rest in which frames. Sizes are shares of the body's span
(cleanup/body.py), speeds spans per second, durations seconds: no unit, frame rate or name counts.

- Slow: a point whose speed (of its path smoothed by a Gaussian of SMOOTH seconds,
  cleanup/speeds.py) is at most SPEED x span per second. In a capture that shakes, a point is
  also slow through its noise, and a rest carries on through its edges (cleanup/shaking.py):
  the first read on the motion the fix sees, the second on the capture as given (Paths.captured).
- Floor (detect_floor): the level the body rests on: the median, over the frames in which a
  point of the body is slow, of the lowest slow point's surface (its height less its radius:
  a sole's, a kneeling knee's, a lying back's). When that level lies within GROUND_PLANE x span
  of height 0, the floor is the file's ground plane, height 0: captures are made on it, and
  their resting contacts sit on it, a little above or below (a long leg's foot sinks, a radius
  is an estimate). Without any slow point nothing rests to show where the floor is, and it is
  the 5th percentile of each frame's lowest surface ("lowest points"), which lifts nothing, or
  the file's ground plane when that percentile or the median lies within GROUND_PLANE x span
  of it ("ground plane, lowest points": a game's in-place clip, sunk into the plane it was
  made on). A body whose lowest point lies on the plane in a typical frame moves over it: a
  dance that never stops, its left leg 8 % longer, sank a foot 100 mm through the plane in the
  lowest 5 % of its frames (28 mm in half of them), and a floor that low was met in every
  frame with the foot 35 mm under the plane (docs/decisions.md).
  FloorChoice says which and how.
- Clearance: how far above the floor a point sits when it touches: its radius (cleanup/body.py).
- Resting (detect_resting): a point rests in a frame when it is slow and its surface (its height
  above floor + clearance) is at most BAND x span. A foot's heel or toe that rises (faster than
  RISING x resting speed) while the foot stands on its sole (its ankle above both by at least
  half the ankle's height over the sole, the foot pitched by at most 30 degrees, FLAT) rests
  only up to SOLE_BAND x span above the floor, or above the level the body rests at where that
  is higher (feet floating over the file's ground plane). A sole site is on the body's
  surface: standing on it, its height is the foot's distance from the floor, known to the
  capture's error rather than to an estimated radius, and a sole that rises past SOLE_BAND (2
  cm on the shared humanoid) is lifting off; the wider band held a foot that rose slowly 2-3
  cm before a jump planted (the shared jump at 30 fps), its heel still along the ground as it
  rose and its toe pulled 17 mm up by the plants. One that sits still above SOLE_BAND rests on
  a surface the sole sites miss (the shared get-up's toes stay 27 mm up as it crouches), and a
  foot on its toes, its side or its top (kneeling, lying) touches the floor with a surface the
  sole sites do not lie on: both keep the wider band; gaps shorter than GAP seconds are filled and
  runs shorter than SHORTEST seconds dropped (each at least a frame or two). A gap is a move,
  not filled, when the point lies on the body's surface (a sole site, no radius) and moves
  across it faster than resting speed on average (from the run's last frame to the next's
  first): the sole went somewhere (a toe shuffled 16 mm in a frame between two rests of the
  shared punch, a dancer's toe swivelled on), and one plant over both would hold it still
  through a move the capture makes. A joint with a radius (a knee, a hand) rolls over its
  skin as the body rocks on it, so its centre moves while the contact stays: its gaps are
  filled. A run's last frames
  (at most GAP seconds of them) are dropped while the point already moves faster than SPEED
  into them from the frame before: a lift-off. A speed is a central difference, which averages
  a lift-off's first fast step with the slow one before it, and a plant held in that frame
  stops the toe there and lets it jump when it is let go (10 mm in a frame on the shared walk),
  a jolt the fix then takes back, floor lift and all; a run to the clip's last frame keeps it.
  A landing keeps its first frame: the
  point arrives there and stays; the smoothing, which averages a landing's last fast steps into
  it, would begin the rest as many frames late as it reaches, so a run begins sooner while the
  point moves at most resting speed into it, unsmoothed (_landed). A plant holds a point still along the ground only
  (cleanup/plants.py), so a heel that begins to lift as the foot rolls onto its toes may
  still rest: it rises about the toe without sliding, as high as in the capture (the foot's
  roll, cleanup/warmstart.py). A point still sliding fast as it lands does not rest until it
  slows: planting it sooner would stop it in a frame, a jolt. A clip's first and last frames
  take their neighbours' slowness: there a speed is a one-sided difference over one frame,
  which doubles a capture's jitter, and a foot resting from the first frame of a noisy clip
  was planted from the second, the first left 24 mm away (the shared kick with capture noise).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deik.cleanup.body import Body, body_of, on_body
from deik.cleanup.contacts import Contacts, drop_short, fill_gaps
from deik.cleanup.cuts import cut_steps
from deik.cleanup.shaking import held_through_noise, slow_through_noise
from deik.cleanup.speeds import NO_SEAMS, SMOOTH, point_speeds, rates, smoothed
from deik.errors import InputError
from deik.io.motion import message_prefix
from deik.io.trajectory import Motion
from deik.model.kinematics import forward_kinematics

SPEED = 0.1
GROUND_PLANE = 0.04
BAND = 0.02
SOLE_BAND = 0.01  # of the span: the band of a sole standing on its sole (module notes)
FLAT = 0.5  # sine of the steepest pitch of a foot standing on its sole (30 degrees)
RISING = 0.1  # of resting speed: a sole rising faster is lifting (module notes: Resting)
GAP = 0.05
SHORTEST = 0.05


@dataclass(frozen=True)
class FloorChoice:
    """The floor a fix keeps: `height` along up (length units), `how` it was found ("given",
    "ground plane", "resting contacts", "lowest points", "ground plane, lowest points"), and
    `resting` the level the resting contacts sit at (None when given or nothing rests)."""

    height: float
    how: str
    resting: float | None = None

    def describe(self, unit: str) -> str:
        """One line for people: the height, how it was found and where the contacts rest."""
        rest = "" if self.resting is None else f"; resting contacts sit at {self.resting:.4g} {unit}"
        words = {
            "given": "given",
            "ground plane": "the file's ground plane, where the resting contacts sit",
            "resting contacts": "where the resting contacts sit",
            "lowest points": "nothing rests: the lowest points",
            "ground plane, lowest points": "nothing rests: the file's ground plane, near the lowest points",
        }
        return f"floor at {self.height:.4g} {unit} ({words[self.how]}{rest})"

    def record(self) -> dict:
        """The floor as JSON: height (length units), how it was found, the resting level."""
        return {"height": self.height, "how": self.how, "resting_contacts_height": self.resting}


def ends_as_neighbours(slow: np.ndarray) -> np.ndarray:
    """(N, K) `slow` with each end frame taking its neighbour's (module notes: Resting); as it
    is with fewer than 3 frames."""
    slow = np.array(slow, bool)
    if len(slow) >= 3:
        slow[0], slow[-1] = slow[1], slow[-2]
    return slow


@dataclass(frozen=True, eq=False)
class Paths:
    """The body's points over a clip: `heights` (N, F) along up and `slow` (N, F) bool, for every
    joint and site of body.skeleton; `positions` (N, F, 3); `seams` (C,) the steps n (frame n to
    n + 1) where the pose jumps (cleanup/cuts.py: two takes in one file), which no speed spans;
    `captured` (N, F, 3) the positions as captured where the clip was low-passed (None: as
    `positions`), where its shake is read (cleanup/shaking.py)."""

    positions: np.ndarray
    heights: np.ndarray
    slow: np.ndarray
    seams: np.ndarray
    captured: np.ndarray | None = None


def body_paths(clip: Motion, body: Body, split_at_cuts: bool = False) -> Paths:
    """The Paths of `clip`'s frames on `body`; with `split_at_cuts`, its seams are the steps where
    its pose jumps (cleanup/cuts.py), else none. The report measures its resting points so, a
    point resting beside a seam slow there and listed when it slides; the fix plants without
    them (docs/decisions.md: planting both sides of a seam apart twisted the motion)."""
    sk = body.skeleton
    p = forward_kinematics(sk, clip.frames).p_world_frame
    seams = cut_steps(p[:, body.own], body.span, clip.frame_time) if split_at_cuts else NO_SEAMS
    slow = point_speeds(p, clip.frame_time, seams) <= SPEED * body.span
    return Paths(p, p @ sk.up, slow, seams)


def _median_lowest(values: np.ndarray, slow: np.ndarray) -> float | None:
    """The median over the frames with a slow point of the lowest slow value; None without."""
    lowest = np.where(slow, values, np.inf).min(axis=1, initial=np.inf)
    finite = lowest[np.isfinite(lowest)]
    return float(np.median(finite)) if finite.size else None


def resting_level(body: Body, paths: Paths) -> float | None:
    """The level the body rests at (module notes: Floor): the median, over the frames with a
    slow point, of the lowest slow point's surface; None when nothing is ever slow."""
    return _median_lowest(surface_heights(body, paths), paths.slow & body.part)


def detect_floor(clip: Motion, body: Body, paths: Paths | None = None) -> FloorChoice:
    """The floor of `clip` (module notes)."""
    if clip.n_frames == 0:
        raise InputError(f"{message_prefix(clip)}the clip has no frames (Frames: 0): there is no floor to detect")
    paths = paths or body_paths(clip, body)
    level = resting_level(body, paths)
    if level is None:
        return lowest_points(body, paths)
    if abs(level) <= GROUND_PLANE * body.span:
        return FloorChoice(0.0, "ground plane", level)
    return FloorChoice(level, "resting contacts", level)


def lowest_points(body: Body, paths: Paths) -> FloorChoice:
    """The floor when nothing rests on one: the file's ground plane when the 5th percentile or
    the median of each frame's lowest surface lies within GROUND_PLANE x span of it, else that
    percentile (module notes)."""
    lowest = surface_heights(body, paths).min(axis=1)
    low, typical = (float(np.percentile(lowest, share)) for share in (5.0, 50.0))
    near = min(abs(low), abs(typical)) <= GROUND_PLANE * body.span
    return FloorChoice(0.0, "ground plane, lowest points") if near else FloorChoice(low, "lowest points")


def surface_heights(body: Body, paths: Paths) -> np.ndarray:
    """(N, F) how high the body's surface lies at each joint and site (its height less its
    radius; inf for what is no part of the body)."""
    return np.where(body.part, paths.heights - body.radius, np.inf)


def clearances(body: Body) -> np.ndarray:
    """(F,) each point's clearance above the floor (module notes); NaN for what is no part of
    the body (a carrier joint), and for a foot's joints below its ankle (a toe joint): they lie
    just above the sole, whose sites keep the foot out of the floor, and a second floor row
    there would hold the toe joint in place while the sole rolls onto it, turning the foot on
    its side."""
    below_ankle = [f for foot in body.feet for f in map(body.skeleton.frame_index, foot.chain[1:])]
    toes = np.zeros(len(body.radius), bool)
    toes[[f for f in below_ankle if f < body.skeleton.n_joints]] = True
    return np.where(body.part & ~toes, body.radius, np.nan)


def rest_runs(
    mask: np.ndarray,
    frame_time: float,
    positions: np.ndarray | None = None,
    step: float = np.inf,
    surface: np.ndarray | None = None,
) -> np.ndarray:
    """`mask` (N, K) with gaps under GAP seconds filled, but for the points on the body's
    `surface` (K,) bool (None: none) the gaps across which they move more than `step` a frame
    (module notes: a move), each run's last frames dropped (at most GAP seconds of them) while
    the point, at `positions` (N, K, 3) (smoothed; None: none dropped), moves more than `step`
    (length units) from the frame before (module notes: a lift-off), and runs under SHORTEST
    dropped (a run of the whole clip stays, however short the clip)."""
    gap = max(1, int(round(GAP / frame_time)))
    shortest = min(max(2, int(round(SHORTEST / frame_time))), len(mask))
    moves = np.inf if surface is None else np.where(surface, step, np.inf)
    mask = fill_gaps(mask, gap + 1, positions, moves)
    if positions is not None:
        mask = _lifting_off(mask, np.linalg.norm(np.diff(positions, axis=0), axis=-1) > step, gap)
    return drop_short(mask, shortest)


def _lifting_off(mask: np.ndarray, moves: np.ndarray, most: int) -> np.ndarray:
    """`mask` (N, K) with each run's last frames dropped, at most `most` of them, while the point
    `moves` (N-1, K) bool (row n: from frame n to n+1) into that frame from the one before; but
    a run to the clip's last frame: what follows it is unknown, a step into it may be noise, and
    a last frame left unplanted was free to any repair (the shared kick with noise and a game
    rig's toes: the toe jumped 20 mm there)."""
    mask = np.array(mask, bool)
    for k in range(mask.shape[1]):
        edges = np.flatnonzero(np.diff(np.concatenate([[0], mask[:, k].astype(np.int8), [0]])))
        for start, stop in zip(edges[::2], edges[1::2]):
            end = stop
            while stop < len(mask) and end - start > 1 and stop - end < most and moves[end - 2, k]:
                end -= 1
            mask[end:stop, k] = False
    return mask


def _landed(mask: np.ndarray, low: np.ndarray, still: np.ndarray, most: int) -> np.ndarray:
    """`mask` (N, K) with each run begun up to `most` frames sooner (the frames the smoothing
    reaches: SMOOTH seconds), while the frame before its first is `low` (N, K) and the point
    moves no more than resting speed from it into the run's first, `still` (N-1, K) (row n: from
    frame n to n+1, unsmoothed): the frame it arrived in. The smoothed speed that finds a rest
    averages a landing's last fast steps into the first frames on the floor: at 120 fps a run's
    toe began to rest two frames after it arrived and the plant, held from there, pulled it 8 mm
    in one of them. detect_resting begins runs sooner only where the smoothing reaches two frames
    or more, rounded (1.8 at 90 fps, where the walk's heel slid 1.9 mm a frame into a plant that
    began a frame late): at 60 fps, one frame sooner let the shared get-up's heel slide 1.5 mm a
    frame into its plant in frames called met, and at 30 fps it reaches less than a frame."""
    mask = np.array(mask, bool)
    for k in range(mask.shape[1]):
        for start in np.flatnonzero(np.diff(np.concatenate([[0], mask[:, k].astype(np.int8)])) == 1):
            first = start
            while (
                first > 0
                and start - first < most
                and low[first - 1, k]
                and still[first - 1, k]
                and not mask[max(first - 2, 0) : first, k].any()  # a frame's gap stays between two rests
            ):
                first -= 1
            mask[first:start, k] = True
    return mask


def detect_resting(
    clip: Motion,
    body: Body,
    floor: float,
    points: tuple[str, ...] | None = None,
    paths: Paths | None = None,
    band: float | None = None,
    speed: float | None = None,
    idle: bool | None = None,
) -> Contacts:
    """Contacts of `points` (default body.contact_points(); joints and sites of body.skeleton)
    with the floor at `floor`, found as the module notes say; `band` (length units above the
    point's clearance) and `speed` (length units per second) override BAND x span and SPEED x
    span. Points never at rest are kept when `idle` (default: when `points` are given). The
    Contacts carry each point's clearance. KeyError with suggestions for unknown names."""
    sk = body.skeleton
    drop_idle = not idle if idle is not None else points is None
    points = tuple(body.contact_points() if points is None else points)
    if not points:
        raise InputError("detect_resting needs at least one joint or site")
    index = [sk.frame_index(name) for name in points]
    paths = paths or body_paths(clip, body)
    given_band, band = band, BAND * body.span if band is None else band
    limit = SPEED * body.span if speed is None else speed
    positions = paths.positions[:, index]
    captured = positions if paths.captured is None else paths.captured[:, index]
    if speed is None:
        slow = paths.slow[:, index] | slow_through_noise(
            positions, clip.frame_time, limit, body.span, sk.up, paths.seams
        )
    else:
        slow = point_speeds(positions, clip.frame_time, paths.seams) <= limit
    slow = ends_as_neighbours(slow)
    clear = body.radius[index]
    above = paths.heights[:, index] - floor - clear
    if given_band is None:  # the soles' band is measured from where the body rests, if above the floor
        level = max(resting_level(body, paths) or floor, floor)
        standing = _standing_soles(body, paths, points, clip.frame_time)
        low = np.where(standing, above - (level - floor) <= min(SOLE_BAND * body.span, band), above <= band)
    else:
        low = above <= band
    smooth = smoothed(positions, clip.frame_time, paths.seams)
    rest = rest_runs(slow & low, clip.frame_time, smooth, limit * clip.frame_time, surface=clear == 0)
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=-1)
    reach = round(SMOOTH / clip.frame_time)  # frames the smoothing reaches: 2 at 90 and 120 fps, 1 at 60
    rest = _landed(rest, low, steps <= limit * clip.frame_time, reach if reach >= 2 else 0)
    if speed is None:
        rest = held_through_noise(rest, captured, low, clip.frame_time, limit, body.span, sk.up)
    keep = rest.any(axis=0) if drop_idle else np.ones(len(points), bool)
    kept = tuple(str(name) for name in np.array(points)[keep])
    return Contacts(kept, rest[:, keep], True, band, limit, floor, clear[keep], tuple(paths.seams))


def _standing_soles(body: Body, paths: Paths, points: tuple[str, ...], frame_time: float) -> np.ndarray:
    """(N, K) bool: whether each of `points` is a foot's heel or toe rising in a frame in which
    its foot stands on its sole (module notes: Resting); `frame_time` seconds."""
    sk = body.skeleton
    standing = np.zeros((len(paths.heights), len(points)), bool)
    for foot in body.feet:
        heel, toe, ankle = (sk.frame_index(name) for name in (foot.heel, foot.toe, foot.ankle))
        rise = np.abs(paths.heights[:, heel] - paths.heights[:, toe])
        length = np.linalg.norm(paths.positions[:, heel] - paths.positions[:, toe], axis=-1)
        above = paths.heights[:, ankle] - np.maximum(paths.heights[:, heel], paths.heights[:, toe])
        flat = (rise <= FLAT * length) & (above >= 0.5 * body.radius[ankle])
        for sole in (foot.heel, foot.toe):
            if sole in points and len(paths.heights) > 1:
                height = smoothed(paths.heights[:, sk.frame_index(sole)], frame_time, paths.seams)
                rising = rates(height, frame_time, paths.seams) > RISING * SPEED * body.span
                standing[:, points.index(sole)] = flat & rising
    return standing


def given_contacts(clip: Motion, body: Body, floor: float, masks: dict[str, np.ndarray]) -> Contacts:
    """Contacts the user gave, {joint or site of body.skeleton: frames in contact (N,) bool}, on
    the floor at `floor`, each with its clearance (module notes). KeyError for unknown names."""
    sites = tuple(masks)
    index = [body.skeleton.frame_index(name) for name in sites]
    clear = body.radius[index]
    columns = [np.asarray(masks[name], bool) for name in sites]
    mask = np.stack(columns, axis=1) if sites else np.zeros((clip.n_frames, 0), bool)
    return Contacts(sites, mask, False, None, None, floor, clear)


def resting_body(clip: Motion) -> tuple[Body, FloorChoice, Contacts | None]:
    """(the body, its floor, every point of it that rests: the contacts `deik clip IN --out OUT`
    plants with no other flags) of `clip` (cleanup/body.py; module notes). Contacts name the
    body's joints and sites, sole sites included: fix with fix_clip(clip, goals, body=body)."""
    body = body_of(clip)
    motion = on_body(clip, body)
    paths = body_paths(motion, body)
    floor = detect_floor(motion, body, paths)
    contacts = detect_resting(motion, body, floor.height, paths=paths)
    return body, floor, contacts if contacts.sites else None

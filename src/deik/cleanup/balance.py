"""Balance that keeps the motion's dynamics: a centre-of-mass track whose zero-moment point
stays over the support, bent no harder than the capture moves.

The zero-moment point (ZMP) of a frame, with the body as a point mass at its centre of mass c
(the cart-table model), is z = c_g - h / (g + a_u) a_g: c_g and a_g the COM's ground position and
acceleration, a_u its upward acceleration, h its height above the floor, g gravity. Standing
still it is the COM's ground projection; walking, the COM leans out of the support while the
ZMP stays inside it. A frame whose COM falls freely (g + a_u < g / 2) has no ZMP to keep.

The support of a frame is the convex hull of its contact plants on the ground grown by SOLE x
reach, the half width of a sole (an ankle and a toe tip stand for a foot some 10 cm wide), as
half-planes (support_halfplanes). The track is the COM (of the motion with its contacts met,
in a fix) plus a ground shift s (N, 2) minimising the spring energy of s (cleanup/spacetime.py,
fade FADE_SECONDS) while the shifted ZMP z + s - k s'' (k = h / (g + a_u)) of every balanced
frame lies inside its support, each half-plane a penalty row while it is crossed (an active
set); accelerations are taken of the path lightly smoothed (_acceleration). A shift that must accelerate by
more than a budget (BUDGET x the capture's largest point acceleration) somewhere would add a
jolt the capture does not have, and one longer than LONGEST_SHIFT x reach would change the
performance: the frame with the largest crossing near the worst excess is then skipped, and so
on until the rest hold. Skipped frames keep the capture's balance and are reported; where the
track's equations cannot be solved (a clip whose accelerations dwarf gravity, at microseconds
per frame), every frame is skipped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deik.cleanup.banded import band_apply, band_compose, band_transpose, solve_spd_band
from deik.cleanup.contacts import Contacts
from deik.cleanup.dynamics import widened
from deik.cleanup.spacetime import spring_bands
from deik.io.trajectory import Motion
from deik.model.capsules import body_reach
from deik.model.geometry import convex_hull, ground_frame, polygon_distance
from deik.model.kinematics import Kinematics, forward_kinematics
from deik.model.skeleton import Skeleton

SOLE = 0.04  # of reach (4.3 cm on the shared humanoid): how far a sole reaches around its contact points
FADE_SECONDS = 0.2  # how long a COM shift takes to build up and fade
ROW_WEIGHT = 1e6  # of a ZMP row (reach units squared) against the shift's spring energy
ACTIVE_SET_ROUNDS = 30
LONGEST_SHIFT = 0.08  # of reach (8.6 cm on the shared humanoid): the furthest the track moves the COM
BUDGET = 0.05  # of the capture's largest point acceleration: the most the COM shift may accelerate
SMOOTHING = 0.025  # seconds: the COM path is smoothed this much before its accelerations are taken
FREE_FALL = 0.5  # of g: a COM accelerating down faster than (1 - FREE_FALL) g has no ZMP


def horizontal_axes(skeleton: Skeleton) -> np.ndarray:
    """(2, 3) the two ground axes of `skeleton` (perpendicular to its up direction)."""
    return ground_frame(np.asarray(skeleton.up, float))[:2]


def support_halfplanes(points: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """(A (K, 2), b (K,)): the convex hull of ground points (S, 2) grown by `radius` > 0 is
    about {q: A q <= b}: each hull edge moved out by radius, and each corner cut by a line
    radius from it, so the region lies within about 1.1 radius of the hull. A point or a
    segment (collinear points) grows into a stadium cut the same way."""
    corners = convex_hull(points)
    normals = []
    if len(corners) >= 3:  # counter-clockwise hull: outward normals of its edges
        edges = np.roll(corners, -1, axis=0) - corners
        normals += [np.stack([edges[:, 1], -edges[:, 0]], axis=1)]
    elif len(corners) == 2:
        edge = corners[1] - corners[0]
        normals += [np.array([[edge[1], -edge[0]], [-edge[1], edge[0]]])]
    # corner cuts: eight directions around every corner (a point's octagon, a segment's caps)
    angles = np.arange(8) * np.pi / 4
    normals += [np.stack([np.cos(angles), np.sin(angles)], axis=1)]
    A = np.concatenate(normals)
    A /= np.linalg.norm(A, axis=1, keepdims=True)
    b = (corners @ A.T).max(axis=0) + radius
    return A, b


def zero_moment_point(
    com: np.ndarray, up: np.ndarray, floor: float, frame_time: float, gravity: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(zmp (N, 2), lever (N,) in s^2, falling (N,) bool) of a COM path com (N, 3): the
    ground ZMP of the module notes, lever k = h / (g + a_u), and the frames in free fall (no
    ZMP: NaN there); accelerations as _acceleration takes them."""
    axes = ground_frame(np.asarray(up, float))[:2]
    if len(com) < 3:
        return com @ axes.T, np.zeros(len(com)), np.zeros(len(com), bool)
    acceleration = band_apply(_acceleration(len(com), frame_time), com)
    upward = gravity + acceleration @ up
    falling = upward < FREE_FALL * gravity
    lever = np.where(falling, 0.0, (com @ up - floor) / np.where(falling, 1.0, upward))
    zmp = com @ axes.T - lever[:, None] * (acceleration @ axes.T)
    return np.where(falling[:, None], np.nan, zmp), lever, falling


def zmp_outside_support(
    kin: Kinematics, skeleton: Skeleton, contacts: Contacts, frame_time: float, gravity: float
) -> np.ndarray:
    """(N,) how far (length units) the ZMP of the motion with kinematics `kin` lies outside its
    support: the hull of the sites in contact where `kin` puts them, grown by SOLE x reach; 0
    inside, NaN without contact or in free fall."""
    axes = horizontal_axes(skeleton)
    zmp, _, falling = zero_moment_point(kin.p_world_com, skeleton.up, contacts.ground, frame_time, gravity)
    feet = kin.p_world_frame[:, [skeleton.frame_index(site) for site in contacts.sites]] @ axes.T
    out = np.full(len(zmp), np.nan)
    patterns, inverse = np.unique(contacts.mask, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    for k, pattern in enumerate(patterns):
        rows = (inverse == k) & ~falling
        if pattern.any() and rows.any():
            out[rows] = np.maximum(
                polygon_distance(zmp[rows], feet[rows][:, pattern]) - SOLE * body_reach(skeleton), 0.0
            )
    return out


def _acceleration(N: int, frame_time: float) -> np.ndarray:
    """(N, 2W + 1) banded by rows (cleanup/banded.py), N >= 3: the acceleration of a path (length
    units / s^2) at each frame: its second difference (the end frames taking their neighbours')
    after a Gaussian smoothing over SMOOTHING seconds (standard deviation; 4 of them each side, at
    most the clip's length: at a microsecond per frame the whole clip is one smoothing window).
    A captured COM trembles by a millimetre, which second differences at 60 Hz make metres per
    s^2. Past its ends the path is carried on straight (point reflection), so smoothing bends
    nothing there. One linear operator serves the capture's ZMP and the shift's, so the track's
    ZMP is what it plans."""
    sigma = SMOOTHING / frame_time
    half = min(int(np.ceil(4 * sigma)), N - 1)
    offsets = np.arange(-half, half + 1)
    kernel = np.exp(-0.5 * (offsets / max(sigma, 1e-9)) ** 2)
    kernel /= kernel.sum()
    rows, cols, data = [], [], []
    n = np.arange(N)
    for j, w in zip(offsets, kernel):
        t = n + j
        inside = (t >= 0) & (t < N)
        low, high = t < 0, t >= N
        rows += [n[inside], n[low], n[low], n[high], n[high]]
        cols += [t[inside], np.zeros(low.sum(), int), np.minimum(-t[low], N - 1)]
        cols += [np.full(high.sum(), N - 1), np.maximum(2 * (N - 1) - t[high], 0)]
        data += [np.full(inside.sum(), w), np.full(low.sum(), 2 * w), np.full(low.sum(), -w)]
        data += [np.full(high.sum(), 2 * w), np.full(high.sum(), -w)]
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    smooth = np.zeros((N, 2 * half + 1))  # a reflected column lies within `half` of its row too
    np.add.at(smooth, (rows, cols - rows + half), np.concatenate(data))
    second = np.zeros((N, 5))
    centres = np.clip(n, 1, N - 2)
    second[n[:, None], (centres - n + 2)[:, None] + np.array([-1, 0, 1])] = [1.0, -2.0, 1.0]
    return band_compose(second, smooth) / frame_time**2


def _solve_shift(zmp, lever, planes, balanced, frame_time, fade_frames, reach) -> np.ndarray:
    """(N, 2) the shift of the module notes for the `balanced` frames: each round poses a penalty
    row for every half-plane its ZMP crosses (or, held there by its row, lies on), until the set
    of rows stops changing. `planes`: (normals (M, 2), offsets (M,), frame (M,)) of every
    supported frame's half-planes."""
    N = len(zmp)
    # banded by rows; under 3 frames no acceleration, but a half width of 2 holds the spring's bands
    mover = -lever[:, None] * (_acceleration(N, frame_time) if N >= 3 else np.zeros((N, 5)))
    mover[:, mover.shape[1] // 2] += 1.0  # the ZMP moves by mover @ s per axis
    width = mover.shape[1] - 1  # rows couple frames up to this far apart (two movers' half widths)
    # the normal equations' upper half (cleanup/banded.py), unknowns frame by frame (s[0, 0], s[0, 1],
    # s[1, 0], ...): first the spring energy of s / reach, each axis on its own
    spring = np.zeros((2 * N, 2 * width + 2))
    for axis in (0, 1):
        for d, band in enumerate(spring_bands(N, fade_frames)):
            spring[axis::2, 2 * d][: len(band)] = band / reach**2
    normals, offsets, frame = planes
    own = balanced[frame]
    offsets = offsets - (normals * zmp[frame]).sum(axis=1)  # what the shift may move the ZMP by
    held = np.zeros(len(frame), bool)
    shift = np.zeros((N, 2))
    for _ in range(ACTIVE_SET_ROUNDS):
        over = (normals * band_apply(mover, shift)[frame]).sum(axis=1) - offsets
        now = own & ((over > 0) | (held & (over > -1e-9 * reach)))  # a held row stays on its edge
        if _ and np.array_equal(now, held):
            break
        held = now
        if not held.any():
            return np.zeros((N, 2))
        shift = _penalised_shift(mover, spring, normals[held], offsets[held], frame[held], reach)
    return shift


def _penalised_shift(mover, spring, normals, offsets, frame, reach) -> np.ndarray:
    """(N, 2) the shift s minimising s^T spring s (`spring` the upper half of its banded matrix,
    as _solve_shift builds it) plus ROW_WEIGHT / reach^2 x sum_r (normals[r] . (mover s)[frame[r]]
    - offsets[r])^2 over the rows r (R,), by its normal equations."""
    N, width = len(mover), mover.shape[1] - 1
    weight = ROW_WEIGHT / reach**2
    back = band_transpose(mover)
    pairs = ((0, 0), (0, 1), (1, 1))
    gram = np.stack([np.bincount(frame, weight * normals[:, a] * normals[:, b], minlength=N) for a, b in pairs], 1)
    blocks = band_compose(back, mover[:, :, None] * gram[:, None, :])  # mover^T diag(gram[:, k]) mover
    upper = spring.copy()
    for (a, b), block in zip(pairs, np.moveaxis(blocks, 2, 0)):
        for row, column in ((a, b), (b, a)) if a != b else ((a, b),):  # unknown (n, row) against (n + d, column)
            d = np.arange(int(row > column), width + 1)
            upper[row::2, 2 * d + column - row] += block[:, width + d]
    pull = np.stack([np.bincount(frame, weight * normals[:, a] * offsets, minlength=N) for a in (0, 1)], 1)
    return solve_spd_band(upper, band_apply(back, pull).reshape(2 * N)).reshape(N, 2)


@dataclass(frozen=True)
class BalanceTrack:
    """Where the COM should go: `track` (N, 3) length units (the capture's COM shifted along the
    ground), `steered` (N,) the frames whose COM a fix should hold on it, `balanced` (N,) the
    frames whose ZMP the track keeps over the support, `skipped` (N,) those with a support left
    to the capture because holding them would take more than the `budget` of acceleration,
    and `shift` (N, 2) on the ground axes."""

    track: np.ndarray
    steered: np.ndarray
    balanced: np.ndarray
    skipped: np.ndarray
    shift: np.ndarray
    budget: float


def _worst_in_each_stretch(over: np.ndarray, candidates: np.ndarray, need: np.ndarray, reach: int) -> list[int]:
    """One frame per stretch of `over` (N,) frames (stretches closer than 2 `reach` frames are one):
    the `candidates` (N,) frame within `reach` frames of it with the largest `need` (N,)."""
    N = len(over)
    near = widened(over, reach)  # each stretch widened by reach
    edges = np.flatnonzero(np.diff(np.concatenate([[0], near.astype(np.int8), [0]])))
    picked = []
    for start, stop in zip(edges[::2], edges[1::2]):
        inside = np.zeros(N, bool)
        inside[start:stop] = True
        inside &= candidates
        if inside.any():
            picked.append(int(np.flatnonzero(inside)[need[inside].argmax()]))
    return picked


def balance_track(
    clip: Motion,
    contacts: Contacts,
    plants: np.ndarray,
    gravity: float,
    share: float = BUDGET,
    skip: np.ndarray | None = None,
    frames: np.ndarray | None = None,
) -> BalanceTrack:
    """The BalanceTrack of `clip` standing on `contacts` at `plants` (N, S, 3) (where the fix puts
    them: plants.planted_targets), with `gravity` (length units / s^2), the shift's
    acceleration budget `share` x the capture's largest acceleration of a joint or site, and
    the frames `skip` (N,) skipped from the start; see the module notes. The track shifts the
    COM of `frames` (N, D) (default the clip's): a fix plans balance on its motion with the
    contacts met, whose COM rises and falls a little differently from the capture's."""
    sk = clip.skeleton
    N = clip.n_frames
    axes = horizontal_axes(sk)
    kin = clip.kinematics
    com = kin.p_world_com if frames is None else forward_kinematics(sk, frames).p_world_com
    peak = np.linalg.norm(np.diff(kin.p_world_frame, 2, axis=0), axis=-1).max(initial=0.0) / clip.frame_time**2
    budget = share * peak
    zmp, lever, falling = zero_moment_point(com, sk.up, contacts.ground, clip.frame_time, gravity)
    supported = contacts.mask.any(axis=1) & ~falling
    normals, offsets, frame = [np.zeros((0, 2))], [np.zeros(0)], [np.zeros(0, int)]
    need = np.zeros(N)  # how far the capture's ZMP crosses the support
    for n in np.flatnonzero(supported):
        A, b = support_halfplanes(plants[n, contacts.mask[n]] @ axes.T, SOLE * body_reach(sk))
        normals.append(A), offsets.append(b), frame.append(np.full(len(b), n))
        need[n] = max((A @ zmp[n] - b).max(), 0.0)
    planes = (np.concatenate(normals), np.concatenate(offsets), np.concatenate(frame))
    fade = min(max(FADE_SECONDS / clip.frame_time, 1.0), max(N, 1))  # longer than the clip is the clip
    skipped = np.zeros(N, bool) if skip is None else np.array(skip, bool) & supported
    while True:
        balanced = supported & ~skipped
        try:
            shift = _solve_shift(zmp, lever, planes, balanced, clip.frame_time, fade, body_reach(sk))
        except np.linalg.LinAlgError:  # accelerations far from g (microsecond frames): no track holds
            skipped, balanced, shift = supported.copy(), np.zeros(N, bool), np.zeros((N, 2))
            break
        added = np.zeros(N)
        if N >= 3:
            added[1:-1] = np.linalg.norm(np.diff(shift, 2, axis=0), axis=1) / clip.frame_time**2
        with np.errstate(divide="ignore", invalid="ignore"):  # no budget (under 3 frames): any added is over
            over = (
                np.maximum(
                    np.where(added > 0, added / budget, 0.0),
                    np.linalg.norm(shift, axis=1) / (LONGEST_SHIFT * body_reach(sk)),
                )
                > 1.0
            )
        picked = _worst_in_each_stretch(over, balanced, need, int(np.ceil(2 * fade)))
        if not over.any() or not picked:
            break
        skipped[picked] = True  # the frames that need the most shift near each jolt
    size = np.linalg.norm(shift, axis=1)
    steered = balanced | (size > 0.01 * size.max(initial=0.0))
    return BalanceTrack(com + shift @ axes, steered, balanced, skipped, shift, budget)

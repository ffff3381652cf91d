"""Capture noise: how much a clip's points jitter where they should rest, and the clip low-passed
when that is more than motion captured cleanly shows.

A marker-based capture solves every frame on its own, so its points shake from frame to frame
(white noise) on top of the motion. Where a point rests, the motion adds almost nothing to its
fourth differences along the frames, and white noise of standard deviation s gives them a
median absolute value of 0.6745 sqrt(70) s: noise_levels reads s there, per point. On the
shared clips (30 to 120 fps) the median over the body's points is at most 0.02 % of the span,
with 0.2 degrees of noise on every channel 0.11 % or more (tests/cleanup/test_clip_noise.py).

Noisy speeds hide rests: at 120 fps the shake moves a resting toe about 1 m/s. A clip whose
points shake more than NOISY x span at rest, at a frame rate where the filter spans a frame or
more (WIDEST_FRAME), is low-passed before anything else (low_passed): every channel averaged by
a Gaussian of LOW_PASS seconds (a 6 Hz low-pass, where filters of captured human motion sit),
then each joint's Euler triple moved onto the average of the rotation matrices it makes, so
that near gimbal lock it averages as the rotation it is and no channel jumps. At 30 fps the
plants remove the noise where points rest. The fix then plants, lifts and reports the motion
without the shake, its jolts measured against the capture as given (ClipGoals.captured);
`deik retarget` low-passes its source the same way.

Fast motion: 6 Hz is below what a run's swing or a kick holds, and one width for the whole clip
moves the shared run's swinging toe 81 mm and its wrists 58 mm from the motion without noise at
120 fps (relative to the hips; the noise alone moves no point more than 14 mm). So each joint
takes, frame by frame, the widest of SCALES widths (22 ms down to 5.5 ms, then none) whose
departure from the capture its noise explains: at most BIAS times the mean departure the
channels' own white noise (read from their fourth differences) makes. A resting or slowly
moving joint keeps the full 22 ms; a joint turning fast keeps its capture, where the shake is
small against the motion and nothing rests to be hidden.

Resampled clips: a clip made from a slower capture by interpolating k frames per captured
frame (30 fps slerped to 60 or 120) bends only at the captured frames, so its second
differences are large every k-th frame and small between: white noise to the fourth-difference
test. Where nothing rests and one phase of the frames modulo k holds second differences at
least INTERPOLATED times those of every other phase, the noise is read from the frames between
the captured ones, where a clean interpolation is nearly straight and noise added after it is
not: the ORDER-th differences of their second differences, k frames apart (a curved path's
bend there changes slowly), against those unit white noise gives.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from deik.io.euler import tait_bryan_triples
from deik.model.rotations import axis_angle_matrix
from deik.model.skeleton import Skeleton

QUIET = 0.05  # seconds: the smoothing of the paths on which noise is read where a point may rest
NOISE_FRAMES = 8  # windows of five quiet frames a point needs for its noise to be read
NOISY = 5e-4  # of the span: the median noise at rest above which a clip is low-passed
WHITE = 0.75 * np.sqrt(70.0 / 6.0)  # fourth over second differences (median sizes) above which a path is noise
WIDEST_FRAME = 1.0  # frames: a low-pass narrower than this (under 45 fps) is left to the plants
LOW_PASS = 0.022  # seconds: the Gaussian's width (a 6 Hz cut-off) a noisy clip is low-passed by
FOURTH = 0.6745 * np.sqrt(70.0)  # median |fourth difference| of unit white noise
INTERPOLATED = 2.5  # one phase's second differences over every other's: a clip resampled up
ORDER = 2  # differences taken along each in-between phase's second differences
RESAMPLED = range(2, 9)  # frames per captured frame (k) looked for
STEPS = 3  # Gauss-Newton steps that put a triple's averaged angles onto its averaged rotation
DAMPING = 1e-4  # of a step's normal equations: a combination of angles the rotation barely moves stays
SCALES = 5  # widths of the low-pass tried, LOW_PASS x 2^(-j/2) for j < SCALES, then the capture itself
BIAS = 2.0  # a width that moves a joint more than this many times its noise alone does moves the motion
SETTLE = 2.0  # frames: the Gaussian smoothing each joint's departures and chosen widths
MEAN_TURN = 2.0 * np.sqrt(2.0 / np.pi)  # mean angle of a rotation by unit white noise on three channels
MEAN_CHANGE = np.sqrt(2.0 / np.pi)  # mean absolute value of unit white noise


def gaussian(values: np.ndarray, sigma: float, fit_ends: bool = False) -> np.ndarray:
    """values (N, ...) averaged along the frames by a Gaussian of `sigma` frames cut at three
    sigma; as they are below 0.3 frames. Where the window passes an end, the end frame is held
    beyond it, or with `fit_ends` each frame there is the Gaussian-weighted straight line
    through the frames it has (the plain average inside): a held end pulls a moving body's
    first and last frames back along its path (26 mm on a run at 120 fps), while a speed read
    from held ends falls to 0 there, as a point at rest at the clip's edge does."""
    values = np.asarray(values, float)
    if sigma < 0.3 or len(values) < 2:
        return values.copy()
    half = int(np.ceil(3 * sigma))
    k = np.arange(-half, half + 1, dtype=float)
    w = np.exp(-0.5 * (k / sigma) ** 2)
    pad = [(half, half)] + [(0, 0)] * (values.ndim - 1)
    if not fit_ends:
        return sliding_window_view(np.pad(values, pad, mode="edge"), len(k), axis=0) @ (w / w.sum())
    inside = sliding_window_view(np.pad(np.ones(len(values)), half), len(k))
    shape = (-1,) + (1,) * (values.ndim - 1)
    s0, s1, s2 = ((inside @ (w * k**j)).reshape(shape) for j in range(3))
    windows = sliding_window_view(np.pad(values, pad), len(k), axis=0)
    return (s2 * (windows @ w) - s1 * (windows @ (w * k))) / (s0 * s2 - s1**2)


def noise_levels(p: np.ndarray, frame_time: float, speed: float) -> np.ndarray:
    """(K,) the deviation of the capture noise of each point of p (N, K, 3), length units, read
    where it may rest (module notes): from its fourth differences along the frames of the
    windows in which its path, smoothed over QUIET seconds, moves at most `speed` (length units
    per second); 0 for a point with fewer than NOISE_FRAMES such windows."""
    N, K = p.shape[:2]
    out = np.zeros(K)
    if N < 5:
        return out
    path = gaussian(p, max(QUIET / frame_time, 1.0))
    calm = np.linalg.norm(np.gradient(path, frame_time, axis=0), axis=-1) <= speed
    windows = calm[:-4] & calm[1:-3] & calm[2:-2] & calm[3:-1] & calm[4:]
    fourth = np.abs(np.diff(p, 4, axis=0))
    for k in np.flatnonzero(windows.sum(axis=0) >= NOISE_FRAMES):
        out[k] = np.median(fourth[windows[:, k], k]) / FOURTH
    return out


@dataclass(frozen=True)
class Noise:
    """A clip's capture noise: `level`, the median over the body's points of their noise at rest
    (length units; 0 when nothing rests long enough to read it), and `low_pass`, the seconds
    of the Gaussian it is low-passed by (None: clean enough to keep)."""

    level: float
    low_pass: float | None

    def record(self) -> dict:
        """The JSON record: level (length units) and low_pass_s (None: kept as captured)."""
        return {"level": self.level, "low_pass_s": self.low_pass}

    def describe(self, unit: str, before: str = "the fix") -> str:
        """One line for people, in `unit`, the filter applied `before` a stage ("" when none is)."""
        if self.low_pass is None:
            return ""
        return (
            f"capture noise {self.level:.3g} {unit} at rest: low-passed by Gaussians of up to "
            f"{self.low_pass * 1000:.0f} ms ({0.1325 / self.low_pass:.0f} Hz), narrower where a joint turns fast, "
            f"before {before}"
        )


def capture_noise(p: np.ndarray, span: float, frame_time: float, speed: float) -> Noise:
    """The Noise of the body's points p (N, K, 3) (module notes; `span` the body's, `speed`
    resting speed, length units per second): low-passed above NOISY x span where the filter
    spans a frame or more. In a clip in which no point is ever quiet long enough (a run at 120
    fps rolls its feet faster than resting speed), the noise is read over all frames: between
    the captured frames of a clip resampled up (module notes), else on the points whose fourth
    differences are those of white noise against their second (median sizes sqrt(70) :
    sqrt(6)), not the much smaller share a smooth motion gives."""
    levels = read_noise(p, frame_time, speed)
    read = levels[levels > 0]
    level = float(np.median(read)) if read.size else 0.0
    noisy = level > NOISY * span and low_passed_rate(frame_time)
    return Noise(level, LOW_PASS if noisy else None)


def low_passed_rate(frame_time: float) -> bool:
    """Whether frames `frame_time` seconds apart are dense enough for a shaking capture to be
    low-passed: the filter spans WIDEST_FRAME frames or more (45 fps and up)."""
    return LOW_PASS / frame_time >= WIDEST_FRAME


def read_noise(p: np.ndarray, frame_time: float, speed: float) -> np.ndarray:
    """(K,) the noise of each point of p (N, K, 3) (or (N, K, D): a point's D coordinates),
    length units: noise_levels, or where no point is quiet long enough to read it there, over
    all frames as capture_noise says; 0 for a point whose noise is not read."""
    levels = noise_levels(p, frame_time, speed)
    if levels.any() or len(p) < 5:
        return levels
    levels = _between_captured_frames(p)
    if levels is None:
        fourth, second = (np.median(np.abs(np.diff(p, k, axis=0)), axis=(0, 2)) for k in (4, 2))
        white = fourth >= WHITE * second  # what the motion adds to fourth differences is far less
        levels = np.where(white, fourth / FOURTH, 0.0)
    return levels


def _between_captured_frames(p: np.ndarray) -> np.ndarray | None:
    """(K,) the noise of each point of p (N, K, 3) read between the captured frames of a clip
    resampled up from a slower capture (module notes, "Resampled clips"); None when p shows no
    such phase."""
    second_signed = np.diff(p, 2, axis=0)  # (N - 2, K, 3), centred on frames 1 .. N - 2
    second = np.abs(second_signed)
    centre = np.arange(1, len(p) - 1)
    best, ratio = None, INTERPOLATED
    for k in RESAMPLED:
        if len(centre) < 3 * k:
            break
        size = np.array([np.median(second[centre % k == r]) for r in range(k)])
        top = int(np.argmax(size))
        others = np.delete(size, top).max()
        if size[top] >= ratio * others:
            best, ratio = (k, top), size[top] / max(others, np.finfo(float).tiny)
    if best is None:
        return None
    k, top = best
    phase = centre % k
    changes = [np.abs(np.diff(second_signed[phase == r], ORDER, axis=0)) for r in range(k) if r != top]
    weights = np.zeros(k * ORDER + 1)
    weights[::k] = np.diff(np.eye(ORDER + 1), ORDER, axis=0)[0]  # the series' differences, k frames apart
    spread = np.sqrt(np.sum(np.convolve(weights, [1.0, -2.0, 1.0]) ** 2))  # of unit white noise
    return np.median(np.concatenate(changes), axis=(0, 2)) / (0.6745 * spread)


def low_passed(skeleton: Skeleton, frames: np.ndarray, seconds: float, frame_time: float) -> np.ndarray:
    """(N, D) `frames` (N, D) low-passed along the frames by Gaussians of up to `seconds`, each
    joint in each frame by the widest that does not move the motion (module notes, "Fast
    motion"): the filter at SCALES widths (averaged), each joint's departure from the capture
    under each (its rotation's angle, or a channel's own change), smoothed over SETTLE frames,
    against what the channels' noise alone moves it by (fourth differences, as for points);
    the widest under BIAS times that, with every narrower one, is taken, the choice smoothed
    over SETTLE frames and the two widths beside it blended."""
    frames = np.asarray(frames, float)
    widths = [seconds * 2 ** (-j / 2) for j in range(SCALES)]
    candidates = np.stack([_averaged(skeleton, frames, w / frame_time) for w in widths] + [frames])
    noise = (
        np.median(np.abs(np.diff(frames, 4, axis=0)), axis=0) / FOURTH if len(frames) > 4 else np.zeros(frames.shape[1])
    )
    out, n = np.empty_like(frames), np.arange(len(frames))
    for unit in _joint_units(skeleton):
        expected = np.sqrt(np.mean(noise[unit] ** 2)) * (MEAN_TURN if len(unit) == 3 else MEAN_CHANGE)
        moved = np.stack([gaussian(_departure(skeleton, unit, c, frames), SETTLE) for c in candidates[:-1]])
        fits = np.flip(np.cumprod(np.flip(moved <= BIAS * expected, 0), 0), 0).astype(bool)  # and every narrower
        scale = np.clip(gaussian(np.where(fits.any(0), np.argmax(fits, 0), SCALES).astype(float), SETTLE), 0, SCALES)
        below = np.floor(scale).astype(int)
        share = (scale - below)[:, None]
        chosen = candidates[:, :, unit]
        out[:, unit] = (1 - share) * chosen[below, n] + share * chosen[np.minimum(below + 1, SCALES), n]
    return out


def _averaged(skeleton: Skeleton, frames: np.ndarray, sigma: float) -> np.ndarray:
    """(N, D) `frames` (N, D) averaged along the frames by a Gaussian of `sigma` frames: every
    channel as values, then each Tait-Bryan triple moved, by damped Gauss-Newton steps, onto
    the average of the rotation matrices it makes (projected onto rotations). Near gimbal lock
    a rotation barely moves along one combination of the triple's angles, and its Euler values
    read back from the averaged matrix jump there by tens of degrees; the damped steps leave
    that combination where the averaged channels put it, so no channel jumps."""
    out = gaussian(frames, sigma, fit_ends=True)
    for triple in tait_bryan_triples(skeleton):
        axes = skeleton.dof_axis[triple]
        target = _nearest_rotations(gaussian(_triple_matrices(axes, frames[:, triple])[0], sigma, fit_ends=True))
        out[:, triple] = _moved_onto(axes, out[:, triple], target)
    return out


def smoothed_change(
    skeleton: Skeleton, frames: np.ndarray, change: np.ndarray, sigma: float, where: np.ndarray | None = None
) -> np.ndarray:
    """(N, D) a `change` (N, D) of `frames` (N, D) averaged along the frames by a Gaussian of
    `sigma` frames (ends held), whatever Euler values the frames are written in: every channel
    as values, then each Tait-Bryan triple moved (damped steps, as _averaged) onto its frame's
    rotation turned by the average of the turns the change makes there (in the joint's frame,
    R^T R', projected onto rotations). So a twin of a rotation (other Euler values) changes as
    the rotation does. Only the frames `where` (N,) bool (default all) are averaged; the others
    keep `change`."""
    where = np.ones(len(frames), bool) if where is None else where
    out = frames + np.where(where[:, None], gaussian(change, sigma), change)
    for triple in tait_bryan_triples(skeleton):
        if not change[:, triple].any():  # a joint the change leaves alone (a still finger)
            continue
        axes = skeleton.dof_axis[triple]
        before = _triple_matrices(axes, frames[:, triple])[0]
        turn = np.swapaxes(before, -1, -2) @ _triple_matrices(axes, frames[:, triple] + change[:, triple])[0]
        target = before[where] @ _nearest_rotations(gaussian(turn, sigma)[where])
        rows = np.ix_(np.flatnonzero(where), triple)
        out[rows] = _moved_onto(axes, frames[rows] + change[rows], target)
    return out - frames


def _moved_onto(axes: np.ndarray, angles: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(N, 3) the Tait-Bryan triple about `axes` (3, 3) at `angles` (N, 3) moved by STEPS damped
    Gauss-Newton steps onto the rotations `target` (N, 3, 3) (_averaged's notes)."""
    out = angles.copy()
    for _ in range(STEPS):
        R, jacobian = _triple_matrices(axes, out)
        M = np.swapaxes(R, -1, -2) @ target
        turn = 0.5 * np.stack([M[:, 2, 1] - M[:, 1, 2], M[:, 0, 2] - M[:, 2, 0], M[:, 1, 0] - M[:, 0, 1]], axis=1)
        normal = np.swapaxes(jacobian, -1, -2) @ jacobian + DAMPING * np.eye(3)
        out += np.linalg.solve(normal, (np.swapaxes(jacobian, -1, -2) @ turn[..., None]))[..., 0]
    return out


def _joint_units(skeleton: Skeleton) -> list[np.ndarray]:
    """DOF indices of what low_passed chooses a width for: each Tait-Bryan triple, every other channel alone."""
    triples = tait_bryan_triples(skeleton)
    inside = {int(d) for triple in triples for d in triple}
    return triples + [np.array([d]) for d in range(skeleton.n_dofs) if d not in inside]


def _departure(skeleton: Skeleton, unit: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N,) how far frames `a` are from `b` (N, D) in `unit`: a triple's angle between its two
    rotations (radians), a channel's difference."""
    if len(unit) != 3:
        return np.abs(a[:, unit[0]] - b[:, unit[0]])
    axes = skeleton.dof_axis[unit]
    Ra, Rb = (_triple_matrices(axes, x[:, unit])[0] for x in (a, b))
    cosine = (np.trace(np.swapaxes(Ra, -1, -2) @ Rb, axis1=-2, axis2=-1) - 1.0) / 2.0
    return np.arccos(np.clip(cosine, -1.0, 1.0))


def _triple_matrices(axes: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rotations (N, 3, 3), Jacobian (N, 3, 3)) of a Tait-Bryan triple about `axes` (3, 3)
    (intrinsic, in order) at `angles` (N, 3) radians: R = R1 R2 R3, and the body-frame turn per
    radian of each angle as the columns (R3^T R2^T a1, R3^T a2, a3)."""
    R1, R2, R3 = (axis_angle_matrix(axes[k], angles[:, k]) for k in range(3))
    T3 = np.swapaxes(R3, -1, -2)
    columns = [T3 @ np.swapaxes(R2, -1, -2) @ axes[0], T3 @ axes[1], np.broadcast_to(axes[2], T3.shape[:-1])]
    return R1 @ R2 @ R3, np.stack(columns, axis=-1)


def _nearest_rotations(M: np.ndarray) -> np.ndarray:
    """(N, 3, 3) the rotations nearest the matrices M (N, 3, 3) (Frobenius; a reflection's sign fixed)."""
    u, _, vt = np.linalg.svd(M)
    u[..., -1] *= np.sign(np.linalg.det(u @ vt))[..., None]
    return u @ vt

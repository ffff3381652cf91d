"""How fast a clip's points move: their paths smoothed along the frames and differentiated, each
run of frames between seams (steps where the pose jumps: cleanup/cuts.py, two takes in one file)
on its own, a jump between takes being no motion to average in. Times in seconds, speeds in
length units per second.

SMOOTH is the Gaussian's width: 20 ms, under a frame at 30 fps, two and a half at 120, enough to
average a capture's frame-to-frame jitter out of a speed without spreading a foot's landing over
more than a frame or two.
"""

from __future__ import annotations

import numpy as np

from deik.cleanup.noise import gaussian

SMOOTH = 0.02  # seconds
NO_SEAMS = np.zeros(0, np.int64)


def segments(n: int, seams: np.ndarray) -> list[slice]:
    """The runs of `n` frames between the `seams` (C,): step k is from frame k to k + 1."""
    edges = [0, *(int(k) + 1 for k in seams), n]
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def smoothed(p: np.ndarray, frame_time: float, seams: np.ndarray = NO_SEAMS) -> np.ndarray:
    """p (N, ...) smoothed along the frames by a Gaussian of SMOOTH seconds (ends held), each run
    between `seams` on its own."""
    runs = segments(len(p), seams)
    parts = [gaussian(p[run], SMOOTH / frame_time) if run.stop - run.start >= 3 else p[run] for run in runs]
    return np.concatenate(parts) if parts else np.asarray(p, float)


def rates(values: np.ndarray, frame_time: float, seams: np.ndarray = NO_SEAMS) -> np.ndarray:
    """values (N, ...) differentiated along the frames (central differences, one-sided at the
    ends of each run between `seams`; 0 for a run of one frame), per second."""
    out = np.zeros(np.shape(values), float)
    for run in segments(len(values), seams):
        if run.stop - run.start >= 2:
            out[run] = np.gradient(values[run], frame_time, axis=0)
    return out


def point_speeds(p: np.ndarray, frame_time: float, seams: np.ndarray = NO_SEAMS) -> np.ndarray:
    """(N, K) speed of points p (N, K, 3) along their smoothed paths, length units per second
    (`rates` of `smoothed`, each run between `seams` on its own; 0 for a single frame)."""
    return np.linalg.norm(rates(smoothed(p, frame_time, seams), frame_time, seams), axis=-1)

"""A point's own acceleration peak is taken around each frame (cleanup/dynamics.own_peaks), so a
pop in a quiet stretch of a long take counts even when the same point moves harder elsewhere."""

import dataclasses

import numpy as np
import pytest

from deik.cleanup.calm import calm
from deik.cleanup.contacts import running_max
from deik.cleanup.dynamics import PEAK_RATIO, PEAK_SECONDS, SLACK, jolted_frames, own_peaks, point_acceleration_ratios
from deik.io.bvh import parse_bvh
from judging.rigs import format_rig, pose_points
from judging.walk import procedural_walk

FPS = 30.0
SWING_SECONDS = 3.0  # the arm swings hard this long, then hangs still
POP_SECONDS = 7.0  # where the test's pop goes: more than PEAK_SECONDS after the swing


@pytest.mark.parametrize(("n", "w"), [(1, 3), (2, 1), (5, 2), (50, 7), (200, 30), (7, 100)])
def test_the_running_maximum_is_the_largest_within_w_frames(n, w):
    values = np.random.default_rng(n + w).random((n, 3))
    expected = np.array([values[max(0, m - w) : m + w + 1].max(axis=0) for m in range(n)])
    np.testing.assert_array_equal(running_max(values, w), expected)
    np.testing.assert_array_equal(running_max(values[:, 0], w), expected[:, 0])


def test_own_peaks_is_the_largest_within_the_window_or_the_still_floor():
    rng = np.random.default_rng(3)
    values = rng.gamma(1.0, 5.0, (200, 4))
    values[120:] *= 0.001  # a still stretch
    frame_time, reach = 1 / 60, 1.7
    got = own_peaks(values, frame_time, reach)
    w = int(round(PEAK_SECONDS / frame_time))
    still = SLACK["position_acceleration"] / (PEAK_RATIO - 1) * reach
    for m in range(len(values)):
        expected = np.maximum(values[max(0, m - w) : m + w + 1].max(axis=0), still)
        np.testing.assert_allclose(got[m], expected)


def _swing_then_hang():
    """The procedural walk, 9 s, its right arm swinging +-60 degrees at 2 Hz for SWING_SECONDS,
    then hanging still: (the rig, the clip deik reads)."""
    case = procedural_walk(seconds=9.0, fps=FPS)
    rig = case.rig
    t = np.arange(len(rig.frames)) / FPS
    column = next(k for k, (j, c) in enumerate(rig.columns) if rig.names[j] == "RightShoulder" and c == "Zrotation")
    frames = rig.frames.copy()
    frames[:, column] += np.where(t < SWING_SECONDS, 60.0 * np.sin(2 * np.pi * 2.0 * t), 0.0)
    rig = dataclasses.replace(rig, frames=frames)
    return rig, parse_bvh(format_rig(rig), "take.bvh")


def _hand_acceleration(rig) -> np.ndarray:
    """(N - 2,) the right hand's acceleration (m/s^2) by the benchmark's own kinematics."""
    hand = rig.point_names().index("RightElbow_end")
    return np.linalg.norm(np.diff(pose_points(rig)[:, hand], 2, axis=0), axis=-1) * FPS**2


def test_a_pop_in_a_quiet_stretch_of_a_long_take_jolts_though_the_point_moves_harder_elsewhere():
    rig, clip = _swing_then_hang()
    n = int(POP_SECONDS * FPS)
    displacement = np.zeros_like(clip.frames)
    displacement[n, clip.skeleton.dof_names.index("RightShoulder.Zrotation")] = 0.05  # 2.9 degrees for one frame
    displacement[:, 1] = 0.002  # and a steady 2 mm lift, which jolts nothing
    fixed = clip.with_frames(clip.frames + displacement)
    popped = dataclasses.replace(rig, frames=rig.frames.copy())
    column = next(k for k, (j, c) in enumerate(rig.columns) if rig.names[j] == "RightShoulder" and c == "Zrotation")
    popped.frames[n, column] += np.degrees(0.05)
    before, after = _hand_acceleration(rig), _hand_acceleration(popped)
    # the pop stays under the hand's peak over the whole take (a clip-wide rule lets it through) ...
    assert after[n - 1] < before.max()
    # ... and is three times the hand's largest anywhere in the stretch after the swing
    w = int((POP_SECONDS - SWING_SECONDS - 1.0) * FPS)
    assert after[n - 1] > 3 * before[n - 1 - w :].max()

    assert jolted_frames(clip, fixed)[n]
    ratios = point_acceleration_ratios(clip, fixed)
    assert ratios[clip.skeleton.frame_names.index("RightElbow_end")] > 2 * PEAK_RATIO
    calmed, taken = calm(clip, displacement)
    assert taken[n] and not taken[: n - w].any()
    assert np.nanmax(point_acceleration_ratios(clip, clip.with_frames(clip.frames + calmed))) <= PEAK_RATIO
    np.testing.assert_allclose(calmed[: n - w, 1], 0.002)  # the lift is kept where nothing jolts


def test_the_same_swing_without_a_pop_does_not_jolt():
    _, clip = _swing_then_hang()
    displacement = np.zeros_like(clip.frames)
    displacement[:, 1] = 0.002
    assert not jolted_frames(clip, clip.with_frames(clip.frames + displacement)).any()

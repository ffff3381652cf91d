"""A change that jolts is smoothed before it is cut back (cleanup/calm.py, `smooth`): averaged
along the frames as rotations (noise.smoothed_change), so it keeps its size where cutting it back
drops it; the warm start keeps the smoothed stretches that do better (warm_choice.smoothed_stretches)."""

import numpy as np

from deik.cleanup.calm import calm
from deik.cleanup.dynamics import jolted_frames
from deik.cleanup.noise import gaussian, smoothed_change
from deik.cleanup.warm_choice import Tried, chosen, smoothed_stretches
from deik.io.bvh import parse_bvh
from deik.io.euler import tait_bryan_triples
from deik.model.kinematics import forward_kinematics
from judging.rigs import format_rig
from judging.walk import procedural_walk


def _walk():
    """The procedural walk as deik reads it (metres, radians)."""
    return parse_bvh(format_rig(procedural_walk(seconds=3.0).rig), "walk.bvh")


def _twins(skeleton, frames: np.ndarray, rows: slice) -> np.ndarray:
    """`frames` (N, D) with every Tait-Bryan triple of the `rows` written as its Euler twin
    (a + pi, pi - b, c + pi): the same rotations in other values."""
    out = frames.copy()
    for a, b, c in tait_bryan_triples(skeleton):
        out[rows, a] += np.pi
        out[rows, b] = np.pi - out[rows, b]
        out[rows, c] += np.pi
    return out


def _points(skeleton, frames: np.ndarray) -> np.ndarray:
    return forward_kinematics(skeleton, frames).p_world_frame


def test_a_smoothed_change_is_the_same_motion_whatever_euler_values_the_frames_are_written_in():
    clip = _walk()
    sk, frames = clip.skeleton, clip.frames
    rng = np.random.default_rng(4)
    change = np.cumsum(rng.normal(0.0, 0.01, frames.shape), axis=0)  # a wandering change, radians
    change[:, ~np.isin(np.arange(sk.n_dofs), np.concatenate(tait_bryan_triples(sk)))] = 0.0
    rows = slice(len(frames) // 3, 2 * len(frames) // 3)
    twins = _twins(sk, frames, rows)
    twin_change = _twins(sk, frames + change, rows) - twins  # the same new rotations
    np.testing.assert_allclose(_points(sk, twins + twin_change), _points(sk, frames + change), atol=1e-9)
    sigma = 3.0
    smoothed = _points(sk, frames + smoothed_change(sk, frames, change, sigma))
    smoothed_twins = _points(sk, twins + smoothed_change(sk, twins, twin_change, sigma))
    assert np.abs(smoothed_twins - smoothed).max() < 1e-6  # metres
    # averaging the values instead mixes the twins' values with the others' at the seams
    naive = _points(sk, twins + gaussian(twin_change, sigma))
    assert np.abs(naive - smoothed).max() > 0.01
    # and the smoothing does smooth: the change's frame-to-frame turn falls
    moved = _points(sk, frames + change)
    assert np.abs(np.diff(smoothed, 2, axis=0)).max() < 0.5 * np.abs(np.diff(moved, 2, axis=0)).max()


def test_smoothing_keeps_a_lift_that_cutting_back_drops():
    """The walk lifted 2 cm for a third of a second, the lift starting and stopping in a frame:
    it jolts at its ends. Cut back, the lift falls away around them; smoothed, it keeps most of
    its height there and nothing jolts."""
    clip = _walk()
    lift = np.zeros_like(clip.frames)
    up = clip.skeleton.dof_names.index("Hips.Yposition")
    lift[30:40, up] = 0.02
    assert jolted_frames(clip, clip.with_frames(clip.frames + lift)).any()
    cut, cut_taken = calm(clip, lift)
    smoothed, smoothed_taken = calm(clip, lift, smooth=True)
    assert not jolted_frames(clip, clip.with_frames(clip.frames + smoothed)).any()
    assert cut_taken[30:40].any() and smoothed_taken[30:40].any()
    assert smoothed[30:40, up].sum() > 1.5 * cut[30:40, up].sum()
    assert smoothed[33:37, up].min() > 0.9 * 0.02  # the middle of the lift holds


def _tried(on_floor, met, slides, calmed) -> Tried:
    n = len(on_floor)
    as_bool = lambda values: np.array(values, bool)  # noqa: E731
    return Tried(as_bool(on_floor), as_bool(met), as_bool(calmed), np.zeros(n, bool), np.array(slides, float))


def test_a_smoothed_stretch_is_kept_where_it_loses_no_goal_and_slides_no_further():
    calmed = [0, 1, 1, 1, 0, 1, 1, 0, 1, 1]
    cut = _tried([1, 0, 0, 1, 1, 1, 1, 1, 1, 1], [1, 0, 0, 0, 1, 1, 1, 1, 1, 0], [0, 1, 1, 1, 0, 0, 0, 0, 1, 1], calmed)
    # frames 1-3: the floor gained, nothing lost; 5-6: a goal lost; 8-9: a point slides 3 further
    smoothed = _tried(
        [1, 1, 1, 1, 1, 1, 1, 1, 1, 1], [1, 0, 1, 0, 1, 0, 1, 1, 1, 1], [0, 2, 1, 1, 0, 0, 0, 0, 4, 1], calmed
    )
    kept = smoothed_stretches(cut, smoothed, sliding=1.0)
    np.testing.assert_array_equal(kept, [0, 1, 1, 1, 0, 0, 0, 0, 0, 0])
    # a stretch no better anywhere is not kept
    assert not smoothed_stretches(cut, cut, sliding=1.0).any()
    # a step up to twice the cut one's (at least the tolerance) plus the tolerance: 2.5 where the
    # cut one steps 1 is kept (the get-up at 120 fps gained 36 frames on the floor so), 3.5 is not
    for step, keep in ((2.5, True), (3.5, False)):
        stepping = _tried([1] * 10, [1, 0, 1, 0, 1, 0, 1, 1, 1, 1], [0, step, 1, 1, 0, 0, 0, 0, 0, 0], calmed)
        assert smoothed_stretches(cut, stepping, sliding=1.0)[1] == keep


def test_a_try_that_sinks_frames_deep_in_the_floor_is_not_kept_for_more_frames_on_it():
    """A warm start whose calm took a lift back sinks frames deep in the floor (the shared
    get-up with bending toes: 25 frames 58 mm under): more frames just on the floor elsewhere
    do not buy it over a try whose misses lie just under it."""
    n = 10
    shallow = _tried([1, 1, 1, 0, 0, 0, 1, 1, 1, 1], [1] * n, [0] * n, [0] * n)
    deep = _tried([1, 1, 1, 1, 1, 0, 0, 1, 1, 1], [1] * n, [0] * n, [0] * n)
    sunk = np.zeros(n, bool)
    sunk[5:7] = True
    deep = Tried(deep.on_floor, deep.met, deep.calmed, deep.far, deep.slides, sunk=sunk)
    assert chosen({"shallow": shallow, "deep": deep}) == "shallow"
    # with nothing deep, the most frames on the floor wins, as before
    level = Tried(deep.on_floor, deep.met, deep.calmed, deep.far, deep.slides, sunk=np.zeros(n, bool))
    assert chosen({"shallow": shallow, "level": level}) == "level"

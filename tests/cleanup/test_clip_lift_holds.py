"""A known defect, recorded: a lifted floor holds a point still far above the floor.

With floor lifts (warmstart.floor_lifts) a point that sinks in some frames is lifted to its capture
height plus an envelope of its depth; where the envelope is 0 that is its capture height, and a
point within FLOOR_HOLD margins of its level is held where it is (warmstart.floor_rows). So in
every frame away from its sink the point is held at its capture height, however high it is: on
the shared get-up, whose right hand, elbow, ankles and heels sink somewhere in the clip, every
one of them was held at its captured height through the whole clip, the warm start moved the
root 4 to 6 cm along the ground instead (frames 80-110 and the last ones), and the pelvis ended
3 cm short of the capture's travel (with the steps of tests/cleanup/test_clip_overshoot.py
halved; without, that warm start is not kept). Levelling the lift at the floor where the envelope
is 0 passes this test and ends the drift (the pelvis then travels 0.240 m, the capture 0.238),
but alone it changed which warm start fix_clip keeps on other clips (benchmarks/clip_targets.py:
dance_a met 97 of 98 frames, not 80, and nothing of it went under the floor, 1.7 mm before; the
jump went 9 mm under it, 0 before, and the run found 1 of its 2 foot runs), so the test is an
expected failure until a rule keeps both.
"""

from __future__ import annotations

import numpy as np
import pytest

from deik.cleanup.warmstart import FLOOR_HOLD, floor_lifts, floor_rows


def held_frames() -> tuple[np.ndarray, np.ndarray]:
    """(heights (N,), held (N,) bool): a point 0.3 m up that dips 1 cm under the floor in the
    middle of a clip far longer than the dip's envelope, and the frames its lifted floor row
    holds it in."""
    n = np.arange(400)
    heights = 0.3 - 0.31 * np.exp(-(((n - 200) / 6.0) ** 2))
    peaks = np.abs(np.diff(heights, 2)).max(keepdims=True)
    level = floor_lifts(heights[:, None], np.zeros(1), peaks)
    up = np.array([0.0, 1.0, 0.0])
    x = heights[:, None, None] * up
    jac = np.broadcast_to(up[:, None], (len(n), 1, 3, 1))
    _, rows = floor_rows(x, jac, up, level, margin=1e-4, hold=FLOOR_HOLD)
    return heights, np.abs(rows[:, 0, 0]) > 0


def test_the_dip_is_lifted_and_held():
    heights, held = held_frames()
    assert heights.min() < -0.009 and held[heights < 0.05].all()


@pytest.mark.xfail(strict=True, reason="a lifted floor holds a point at its capture height far above it (notes)")
def test_a_point_far_above_the_floor_is_not_held():
    heights, held = held_frames()
    assert not held[heights > 0.29].any()  # 1 cm below its height away from the dip

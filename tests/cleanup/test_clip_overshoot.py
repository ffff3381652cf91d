"""A known defect, recorded: the warm start keeps a Gauss-Newton step that overshoots.

A space-time step is the least-squares step of the goal rows linearised at the current pose; far
from that pose (a bone the rows barely turn, as the shared get-up's arm lying on the floor, whose
first step turned a shoulder 2.1 radians) it overshoots, and every later step started from the
overshoot: the get-up's warm start with floor lifts ended with its arms swung through 118 degrees
and a hand accelerating 20 times its peak, all of it taken back by calm. Here the procedural walk
sunk into the floor is warm-started with every step made OVERSHOOT times too long: a warm start
that went back along a step raising the rows' error would still lift the body out; this one ends
metres under the floor. Halving such steps until the error falls passes this test, but it also
changed which warm start fix_clip keeps on other clips (the longer-legs walk of
tests/cleanup/test_clip_body_contacts.py met 7 frames, not 15; the get-up's hips drifted 3.5 cm),
so the test is an expected failure until a step rule passes both.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import deik.cleanup.warmstart as warmstart
from deik.cleanup.body import on_body
from deik.cleanup.clip_goals import ClipGoals, fixed_goals, sized_goals
from deik.cleanup.coherence import hinge_channels
from deik.cleanup.ground import clearances, resting_body
from deik.io.bvh import parse_bvh
from deik.model.kinematics import forward_kinematics
from judging.rigs import format_rig
from judging.walk import procedural_walk

SUNK, OVERSHOOT = 0.03, 6.0  # metres under the floor; how much too long every step is


def sunk_walk():
    """The procedural walk lowered SUNK, its feet through the floor at height 0, as a Clip."""
    rig = procedural_walk().rig
    frames = rig.frames.copy()
    frames[:, rig.columns.index((0, "Yposition"))] -= SUNK
    return parse_bvh(format_rig(dataclasses.replace(rig, frames=frames)), "sunk.bvh")


def deepest_after_warm_start(monkeypatch, overshoot: float, lift: bool) -> tuple[float, float]:
    """(capture, warm start): how far the body's surface goes under the floor at 0, metres, with
    every space-time step `overshoot` times its length, the floor `lift`ed along envelopes or not."""
    step = warmstart.spacetime_step
    monkeypatch.setattr(warmstart, "spacetime_step", lambda *a, **k: overshoot * step(*a, **k))
    clip = sunk_walk()
    body, _, contacts = resting_body(clip)
    motion = on_body(clip, body)
    clearance = clearances(body)
    goals = sized_goals(ClipGoals(contacts, floor=0.0, floor_clearance=clearance), body.span)
    weights = warmstart.dof_weights(motion)
    movable = np.broadcast_to(~hinge_channels(motion), motion.frames.shape)
    fixed = fixed_goals(motion, goals, weights)
    d = warmstart.warm_start(body.skeleton, motion.poses(), fixed, movable, weights, lifting=warmstart.Lifting(lift))
    radius = np.nan_to_num(clearance, nan=-np.inf)
    depth = [
        (radius - forward_kinematics(body.skeleton, frames).p_world_frame @ body.skeleton.up).max()
        for frames in (motion.poses(), motion.poses() + d)
    ]
    return depth[0], depth[1]


@pytest.mark.xfail(strict=True, reason="the warm start keeps an overshooting step (module notes)")
@pytest.mark.parametrize("lift", [False, True])
def test_a_warm_start_whose_steps_overshoot_still_lifts_the_body_out_of_the_floor(monkeypatch, lift):
    before, exact = deepest_after_warm_start(monkeypatch, 1.0, lift)
    assert before > 0.5 * SUNK  # the feet go through the floor
    assert exact < 1e-3  # and the warm start takes them out
    monkeypatch.undo()
    _, overshot = deepest_after_warm_start(monkeypatch, OVERSHOOT, lift)
    assert overshot < 1e-3

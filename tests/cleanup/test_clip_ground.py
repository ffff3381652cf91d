"""Where a clip rests (cleanup/ground.py), on motions whose answer is known: the procedural walk
(judging/walk.py: each foot flat and still on the floor at 0 through its stance), raised
onto a platform, sunk a little, in centimetres, at another frame rate, with a foot that kicks
instead of stepping."""

import dataclasses

import numpy as np
import pytest

from deik.cleanup.contacts import true_runs
from deik.cleanup.dynamics import widened
from deik.cleanup.ground import resting_body
from deik.io.bvh import parse_bvh
from judging.cases import Case, anon, studio
from judging.rigs import format_rig
from judging.walk import STANCE, procedural_walk


def read(case: Case):
    return parse_bvh(format_rig(case.rig), f"{case.name}.bvh")


def lifted(case: Case, height: float) -> Case:
    """`case` with its root raised by `height` metres (its Yposition channel)."""
    rig = case.rig
    frames = rig.frames.copy()
    frames[:, [k for k, (j, c) in enumerate(rig.columns) if j == 0 and c == "Yposition"]] += height * case.unit
    return dataclasses.replace(case, rig=dataclasses.replace(rig, frames=frames))


def stance(case: Case, side: str) -> np.ndarray:
    """(N,) bool: the frames in which the procedural walk's `side` foot is down, from its own gait."""
    from judging.walk import PERIOD

    t = np.arange(len(case.rig.frames)) * case.rig.frame_time
    phase = t / PERIOD + (0.5 if side == "Left" else 0.0)
    return phase - np.floor(phase) < STANCE


@pytest.mark.parametrize("height, floor, how", [(0.0, 0.0, "ground plane"), (-0.012, 0.0, "ground plane")])
def test_the_floor_is_the_file_s_ground_plane_where_the_feet_rest_near_it(height, floor, how):
    _, found, _ = resting_body(read(lifted(procedural_walk(), height)))
    assert (found.height, found.how) == (floor, how)
    assert found.resting == pytest.approx(height, abs=0.003)  # the soles rest where the capture put them


def test_a_body_walking_on_a_platform_rests_on_the_platform():
    _, found, _ = resting_body(read(lifted(procedural_walk(), 0.4)))  # a stage 40 cm up
    assert found.how == "resting contacts" and found.height == pytest.approx(0.4, abs=0.003)


@pytest.mark.parametrize("family", ["source", "studio", "anon"])
def test_a_walking_foot_rests_in_its_stance_and_lifts_in_its_swing(family):
    """The contacts are the stance phases, within two frames at each end, whatever the unit (cm),
    the joint names or the frame rate (120 fps): thresholds follow the body and the clock."""
    walk = procedural_walk()
    case = {"source": walk, "studio": studio(walk), "anon": anon(walk)}[family]
    body, _, contacts = resting_body(read(case))
    slack = int(round(0.07 / case.rig.frame_time))
    for foot, side in zip(body.feet, ("Right", "Left")):
        if case.names[f"{side}Ankle"] != foot.ankle:
            side = "Left" if side == "Right" else "Right"
        down = stance(case, side)
        for site in (foot.heel, foot.toe):
            rest = contacts.mask[:, contacts.sites.index(site)]
            assert not (rest & ~widened(down, slack)).any()  # never while the foot swings
            for a, b in true_runs(down):  # each stance found, give or take two frames at its ends
                inside = rest[a:b]
                assert inside[slack : len(inside) - slack].all() or b - a <= 2 * slack + 1, (site, a, b)


def test_a_kicking_foot_flies_and_the_standing_foot_rests():
    walk = procedural_walk()
    rig = walk.rig
    frames = rig.frames.copy()
    column = {name: k for k, name in enumerate(f"{rig.names[j]}.{c}" for j, c in rig.columns)}
    t = np.arange(len(frames)) * rig.frame_time
    frames[:, column["RightHip.Zrotation"]] = 70 * np.sin(np.pi * t / t[-1]) ** 2  # the right leg kicks up and down
    kick = dataclasses.replace(walk, rig=dataclasses.replace(rig, frames=frames))
    body, _, contacts = resting_body(read(kick))
    right = next(foot for foot in body.feet if foot.ankle == "RightAnkle")
    up = np.sin(np.pi * t / t[-1]) ** 2 > 0.2
    for site in (right.heel, right.toe):
        if site in contacts.sites:
            assert not contacts.mask[up, contacts.sites.index(site)].any()


def test_a_foot_standing_on_its_sole_has_left_the_floor_once_it_rises_3_cm():
    """The procedural walk's root rises 4 cm and back over the second half of a stance, so the
    flat standing foot rises off the floor and slows at the top: where its sole is 3 cm or more
    up, its heel and toe do not rest (a sole lies on the body's surface: its height is the
    foot's distance from the floor), while the other stances are found as before."""
    walk = procedural_walk()
    rig, down = walk.rig, stance(walk, "Right")
    a, b = true_runs(down)[1]
    middle = (a + b) // 2
    rise = np.zeros(len(rig.frames))
    rise[middle:b] = 0.04 * np.sin(np.pi * np.arange(b - middle) / (b - middle)) ** 2
    up = rise > 0.03
    frames = rig.frames.copy()
    frames[:, [k for k, (j, c) in enumerate(rig.columns) if j == 0 and c == "Yposition"]] += rise[:, None]
    body, _, contacts = resting_body(read(dataclasses.replace(walk, rig=dataclasses.replace(rig, frames=frames))))
    right = next(foot for foot in body.feet if foot.ankle == "RightAnkle")
    assert up.sum() >= 3
    for site in (right.heel, right.toe):
        rest = contacts.mask[:, contacts.sites.index(site)]
        assert not rest[up].any(), site
        assert rest[a + 3 : middle].all(), site  # it rested until it rose


@pytest.mark.parametrize("height", [0.03, -0.03])
def test_a_walk_3_cm_above_or_under_its_ground_plane_still_rests_in_every_stance(height):
    """The file's ground plane stays the floor, and the feet rest where the capture put them."""
    case = lifted(procedural_walk(), height)
    body, found, contacts = resting_body(read(case))
    assert (found.height, found.how) == (0.0, "ground plane")
    slack = int(round(0.07 / case.rig.frame_time))
    for foot, side in zip(body.feet, ("Right", "Left")):
        for a, b in true_runs(stance(case, side if case.names[f"{side}Ankle"] == foot.ankle else "Left")):
            for site in (foot.heel, foot.toe):
                assert contacts.mask[a + slack : b - slack, contacts.sites.index(site)].all(), (site, a, b)

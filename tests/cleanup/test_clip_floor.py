"""Floor metrics, jerk, position deviation and the goal table against hand-made motions whose
answers are known (a foot put down, slid, lifted and pushed through the floor)."""

from types import SimpleNamespace

import numpy as np
import pytest

from deik.cleanup.clip_goals import ClipGoals, goal_names
from deik.cleanup.contacts import contacts_from_ranges
from deik.cleanup.document import goal_table
from deik.cleanup.summary import clip_report, per_frame_errors
from deik.cleanup.units import guess_unit, metres_per_unit
from deik.io.bvh import Clip
from deik.model.build import build_skeleton
from deik.model.joints import Joint, Site, translation


def stage(poses, scale=1.0, frame_time=0.1) -> Clip:
    """A body moved by translations (Y up) carrying a foot site at its origin, an ankle site 5 cm
    above it and a head 1.7 m up, beside a fixed ground joint; lengths x `scale` (100: cm)."""
    joints = [Joint("ground", None), Joint("body", "ground", dofs=translation("XYZ"), mass=1.0)]
    sites = [
        Site("foot", "body"),
        Site("ankle", "body", (0.0, 0.05 * scale, 0.0)),
        Site("head", "body", (0, 1.7 * scale, 0)),
    ]
    return Clip.from_poses(build_skeleton(joints, sites), scale * np.asarray(poses, float), frame_time)


# the foot, in contact in frames 0-4: still, slides 3 cm along the floor, lifts to 6 cm and
# slides 3 cm up there, then (out of contact) goes 3 cm through the floor
FOOT = [(0, 0, 0), (0, 0, 0), (0.03, 0, 0), (0.03, 0.06, 0), (0.06, 0.06, 0), (0.06, -0.03, 0)]


@pytest.mark.parametrize("scale,unit", [(1.0, "m"), (100.0, "cm")])
def test_floor_metrics_of_a_foot_that_slides_lifts_and_sinks(scale, unit):
    clip = stage(FOOT, scale)
    contacts = contacts_from_ranges(clip, {"foot": [(0, 5)], "ankle": [(0, 5)]})
    metres = metres_per_unit(unit)
    report = clip_report(clip, clip, contacts, metres=metres)
    # contact steps 0-1, 1-2, 2-3, 3-4; only 1-2 slides more than 2.5 cm low down (3-4 is 6 cm up)
    assert report["foot_skating_ratio_share"]["before"] == pytest.approx(0.25)
    # the ankle floats like the foot: heights count above each site's own planted height
    assert report["floating_max_mm"]["after"] == pytest.approx(60.0)
    assert report["floating_mean_mm"]["after"] == pytest.approx(2 * 60.0 / 5)
    assert report["penetration_max_mm"]["before"] == pytest.approx(30.0)
    assert report["penetration_mean_mm"]["before"] == pytest.approx(30.0 / 6)
    assert report["contacts_per_frame_mean_count"]["before"] == pytest.approx(10 / 6)
    series = per_frame_errors(clip, clip, contacts, metres=metres)
    np.testing.assert_allclose(series["penetration_mm"]["after"], [0, 0, 0, 0, 0, 30.0], atol=1e-9)
    np.testing.assert_allclose(series["floating_mm"]["after"][:5], [0, 0, 0, 60.0, 60.0], atol=1e-9)
    assert np.isnan(series["floating_mm"]["after"][5])  # out of contact


def test_jerk_of_a_cubic_path_and_the_position_deviation_of_a_shift():
    t = np.arange(8) * 0.1
    poses = np.zeros((8, 3))
    poses[:, 0] = t**3  # third derivative 6 units/s^3 for everything the body carries
    clip = stage(poses)
    shifted = stage(poses + [0.0, 0.0, 0.1])  # 10 cm sideways
    report = clip_report(clip, shifted)
    assert report["jerk_mean_m_per_s3"]["before"] == pytest.approx(6.0 / 2)  # the ground joint does not move
    assert report["jerk_max_m_per_s3"]["after"] == pytest.approx(6.0)
    assert report["joint_position_deviation_max_mm"]["after"] == pytest.approx(100.0)
    assert report["joint_position_deviation_mean_mm"]["after"] == pytest.approx(50.0)  # ground 0, body 100
    assert report["joint_position_deviation_max_mm"]["before"] == 0.0
    jerk = per_frame_errors(clip, shifted)["jerk_m_per_s3"]["after"]
    assert np.isnan(jerk[:2]).all() and np.isnan(jerk[-1])  # row n at frame n + 2
    np.testing.assert_allclose(jerk[2:-1], 6.0)


def test_the_goal_table_merges_balance_rows_and_states_units():
    nan = np.nan
    fix = SimpleNamespace(
        labels=("contact foot", "balance", "balance", "fidelity", "coherence"),
        tolerances=np.array([0.0004, 0.01, 0.01, -1.0, -1.0]),
        before=np.array([[0.002, 0.03, nan, 0.0, 0.2], [0.001, nan, 0.05, 0.0, 0.3]]),
        after=np.array([[0.0001, 0.001, nan, 0.01, 0.02], [nan, nan, 0.002, 0.02, 0.01]]),
    )
    rows = goal_table(fix, metres=1.0)
    assert [r["key"] for r in rows] == ["contact_foot", "balance", "fidelity", "coherence"]
    contact, balance, fidelity, coherence = rows
    assert contact["unit"] == "mm" and contact["tolerance"] == pytest.approx(0.4)
    np.testing.assert_allclose(contact["before"], [2.0, 1.0])
    assert np.isnan(contact["after"][1])
    np.testing.assert_allclose(balance["before"], [30.0, 50.0])  # one row, each frame its active goal
    assert fidelity["unit"] == "deg" and fidelity["tolerance"] is None
    np.testing.assert_allclose(fidelity["after"], np.degrees([0.01, 0.02]))
    np.testing.assert_array_equal(coherence["before"], [0.0, 0.0])  # the capture changes nothing


def test_goal_names_follow_the_goals_clip_problem_poses():
    clip = stage(FOOT)
    contacts = contacts_from_ranges(clip, {"foot": [(0, 5)], "ankle": [(0, 2)]})
    names = goal_names(ClipGoals(contacts, balance=True, coherence=0.0))
    # one balance goal (the centre of mass on its track, cleanup/balance.py); no coherence term
    assert names == ["contact foot", "contact ankle", "balance", "fidelity"]


def test_the_length_unit_is_guessed_from_the_size_and_checked():
    assert guess_unit(stage(FOOT).skeleton) == "m"
    assert guess_unit(stage(FOOT, 100.0).skeleton) == "cm"
    with pytest.raises(ValueError, match="unknown length unit 'ft'; use one of m, cm, mm, in, cmu"):
        metres_per_unit("ft")


@pytest.mark.parametrize("unit", ["m", "cmu", "cm", "mm"])
@pytest.mark.parametrize("stature", [1.1, 1.75, 2.1])
def test_a_person_from_a_child_to_a_tall_adult_is_read_in_the_unit_they_were_written_in(unit, stature):
    """The built-in humanoid (1.75 m) made `stature` tall and written in `unit`, "cmu" the CMU
    database's 1/0.45 inch: the guess takes it back to its unit."""
    import dataclasses

    import deik

    h = deik.humanoid()
    scale = stature / 1.75 / metres_per_unit(unit)
    person = dataclasses.replace(h, offsets=h.offsets * scale, site_offset=h.site_offset * scale)
    assert guess_unit(person) == unit

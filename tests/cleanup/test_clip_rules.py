"""Issue 27's rules for `deik clip IN --out OUT` with no other flags, on generated cases nobody tuned
for (the procedural walk of judging/walk.py on other rig families, played backwards or
faster, with capture noise under the floor), judged by judging/clips.py, which shares no
code with deik (its own BVH reader and kinematics, the DeepMimic collision shapes, its own contact
detector, the floor at 0): sliding of every resting point at most 1 mm per frame, nothing of the
body more than 2 mm under the floor, no point accelerating beyond 1.1 times its own peak, the body
travelling as far and the feet landing where they did; position channels held; the same answer in
any unit; a change that would jolt taken back and reported."""

import dataclasses
import json

import numpy as np
import pytest

from deik.cleanup.calm import calm
from deik.cleanup.dynamics import PEAK_RATIO, point_acceleration_ratios
from deik.cli.app import main
from deik.io.bvh import parse_bvh, read_bvh
from helpers import shared_path
from judging.cases import TRANSFORMS, source_case
from judging.clips import contact_points, judge, resting
from judging.rigs import format_rig, parse_rig
from judging.walk import procedural_walk


def cleaned(case, tmp_path):
    """(deik's JSON report, the cleaned rig) of `deik clip IN --out OUT --json J` on `case`."""
    source, out, report = tmp_path / "in.bvh", tmp_path / "out.bvh", tmp_path / "out.json"
    source.write_text(format_rig(case.rig))
    assert main(["clip", str(source), "--out", str(out), "--json", str(report), "--quiet"]) == 0
    return json.loads(report.read_text()), parse_rig(out.read_text(), case.rig.position_mode)


@pytest.mark.parametrize("transform", ["none", "studio", "anon", "backwards", "fast", "noisy"])
def test_the_default_command_meets_every_target_on_a_generated_walk(transform, tmp_path):
    walk = procedural_walk()
    case = walk if transform == "none" else TRANSFORMS[transform](walk)
    report, result = cleaned(case, tmp_path)
    measured = judge(case, case.rig, result, ~np.array(report["met_per_frame"]), case.truth)
    assert measured["sliding_mm_per_frame"] <= 1.0
    assert measured["depth_mm"] <= 2.0
    assert measured["peak_ratio"] <= PEAK_RATIO
    assert abs(measured["travel_m"] - measured["travel_capture_m"]) <= max(0.05 * measured["travel_capture_m"], 0.02)
    assert measured["misses_listed"]
    assert report["floor"]["how"] == "ground plane" and report["floor"]["height"] == 0.0
    if transform == "noisy":  # the capture slid and sank: the cleaned clip does not, and steps as the walk did
        assert measured["sliding_capture_mm_per_frame"] > 5 and measured["depth_capture_mm"] > 5
    assert measured["steps_matched"] == measured["steps"] > 0


def test_position_channels_below_the_first_translating_joint_keep_the_capture_s_values(tmp_path):
    case = TRANSFORMS["studio"](procedural_walk())  # six channels on every joint, a Reference root
    _, result = cleaned(case, tmp_path)
    held = [k for k, (j, c) in enumerate(case.rig.columns) if j > 0 and c.endswith("position")]
    np.testing.assert_allclose(result.frames[:, held], case.rig.frames[:, held], atol=1e-6)
    moved = [k for k, (j, c) in enumerate(case.rig.columns) if j == 0 and c.endswith("position")]
    assert np.abs(result.frames[:, moved] - case.rig.frames[:, moved]).max() > 0  # the root carries the fix


def _scaled(walk, scale: float):
    """The case `walk` with every length (offsets, sites, position channels) times `scale`."""
    rig = walk.rig
    frames = rig.frames.copy()
    frames[:, [k for k, (_, c) in enumerate(rig.columns) if c.endswith("position")]] *= scale
    sites = tuple((name, j, offset * scale) for name, j, offset in rig.sites)
    rig = dataclasses.replace(rig, offsets=rig.offsets * scale, sites=sites, frames=frames)
    return dataclasses.replace(walk, rig=rig)


def test_a_walk_in_the_cmu_database_s_unit_is_reported_and_weighed_in_it(tmp_path, monkeypatch):
    """A person in 1/0.45 inch (a CMU BVH) is read as "cmu": the report's lengths in it, and
    gravity, for --balance, 9.81 m/s^2 in those units (docs/clips.md, Units)."""
    import deik.cleanup.clean as clean

    passed = {}
    goals = clean.ClipGoals
    monkeypatch.setattr(clean, "ClipGoals", lambda *a, **k: passed.update(k) or goals(*a, **k))
    report, _ = cleaned(_scaled(procedural_walk(), 0.45 / 0.0254), tmp_path)
    assert report["length_unit"] == "cmu" and report["metres_per_length_unit"] == pytest.approx(0.0254 / 0.45)
    assert passed["gravity"] == pytest.approx(9.81 * 0.45 / 0.0254)


@pytest.mark.parametrize("scale", [1e-3, 100.0])
def test_a_clip_in_any_unit_is_fixed_to_the_same_angles(scale, tmp_path):
    """Every size and tolerance follows the body: the walk in millimetres of a metre or in
    centimetres comes back with the rotation channels it has in metres."""
    walk = procedural_walk()
    scaled = _scaled(walk, scale)
    results = []
    for k, case in enumerate((walk, scaled)):
        folder = tmp_path / str(k)
        folder.mkdir()
        results.append(cleaned(case, folder)[1].frames)
    rotation = [k for k, (_, c) in enumerate(walk.rig.columns) if c.endswith("rotation")]
    np.testing.assert_allclose(results[1][:, rotation], results[0][:, rotation], atol=1e-4)  # degrees


def test_a_change_that_would_jolt_is_taken_back_and_reported():
    clip = parse_bvh(format_rig(procedural_walk().rig), "walk.bvh")
    displacement = np.zeros_like(clip.frames)
    displacement[30, clip.skeleton.dof_names.index("RightShoulder.Zrotation")] = 0.5  # a one-frame arm pop
    displacement[:, 1] = 0.002  # and a steady 2 mm lift, which jolts nothing
    calmed, taken = calm(clip, displacement)
    assert taken[30] and taken.sum() < clip.n_frames // 2 and not taken[:10].any()
    fixed = clip.with_frames(clip.frames + calmed)
    assert np.nanmax(point_acceleration_ratios(clip, fixed)) <= PEAK_RATIO
    np.testing.assert_allclose(calmed[:10, 1], 0.002)  # the lift is kept where nothing jolts


def test_deik_limits_then_clip_does_not_pin_the_body_to_its_path(tmp_path):
    """Issue 30 item 1: a table from `deik limits --margin 10` leaves the root's translation out,
    so `deik clip --limits` may lift and shift the body as without the table."""
    source = tmp_path / "walk.bvh"
    source.write_text(format_rig(TRANSFORMS["noisy"](procedural_walk()).rig))  # sunk: needs lifting
    assert main(["limits", str(source), "--margin", "10", "--out", str(tmp_path / "limits.json")]) == 0
    table = json.loads((tmp_path / "limits.json").read_text())
    assert "Hips.Xposition" not in table and "Hips.Zrotation" in table
    reports = []
    for name, extra in (("free", []), ("limited", ["--limits", str(tmp_path / "limits.json")])):
        argv = ["clip", str(source), "--out", str(tmp_path / f"{name}.bvh"), "--json", str(tmp_path / f"{name}.json")]
        assert main(argv + extra + ["--quiet"]) == 0
        reports.append(json.loads((tmp_path / f"{name}.json").read_text()))
    assert reports[1]["frames_met"] >= reports[0]["frames_met"] - 2
    for key in ("sliding_max_mm_per_frame", "penetration_max_mm"):
        assert reports[1]["metrics"][key]["after"] <= reports[0]["metrics"][key]["after"] + 0.5, key
    assert read_bvh(tmp_path / "limited.bvh").n_frames == len(TRANSFORMS["noisy"](procedural_walk()).rig.frames)


@pytest.mark.shared_data
@pytest.mark.parametrize("name, transform", [("jump", "none"), ("jump", "backwards"), ("dance_a", "none")])
def test_a_landing_that_sinks_is_taken_out_of_the_floor_and_the_flight_keeps_the_capture(name, transform, tmp_path):
    """The shared jump lands with a heel 13 mm under the floor and the dance with a foot 26 mm
    under it: cleaned by default, nothing of the body is more than 2 mm under the floor (the
    landing foot is carried up whole, not tipped toe down onto the floor, which jolted and was
    taken back), no point accelerates past 1.1x its own peak, and the frames 0.2 s or more from
    any rest of the capture's feet (the jump's flight) keep every rotation within 2 degrees."""
    case = source_case(shared_path("humanoid", f"humanoid3d_{name}.bvh"))
    case = case if transform == "none" else TRANSFORMS[transform](case)
    report, result = cleaned(case, tmp_path)
    measured = judge(case, case.rig, result, ~np.array(report["met_per_frame"]))
    assert measured["depth_capture_mm"] > 10 and measured["depth_mm"] <= 2.0
    assert measured["peak_ratio"] <= PEAK_RATIO and measured["misses_listed"]
    if name == "jump":
        assert measured["steps_matched"] == measured["steps"] > 0  # the feet land when the capture's do
        names, points, clear = contact_points(case, case.rig)
        feet = [k for k, point in enumerate(names) if point.endswith(("heel", "toe"))]
        rests = np.flatnonzero(resting(points[:, feet], clear[feet], case.rig.frame_time).any(axis=1))
        far = np.abs(np.arange(len(points))[:, None] - rests[None, :]).min(axis=1) >= round(0.2 / case.rig.frame_time)
        rotation = [k for k, (_, c) in enumerate(case.rig.columns) if c.endswith("rotation")]
        assert far.sum() >= 5  # the flight is long enough to have such frames
        assert np.abs(result.frames[far][:, rotation] - case.rig.frames[far][:, rotation]).max() <= 2.0


@pytest.mark.shared_data
@pytest.mark.parametrize("name", ["dance_a", "jump"])
def test_a_foot_lifts_and_lands_where_the_capture_s_does(name, tmp_path):
    """On another rig (30 fps): the shared dance rests its left toe, then swivels it on along the
    floor faster than resting speed before it lifts; the shared jump lifts both feet 2-3 cm
    slowly before it takes off. Cleaned by default, every resting run of the feet is found
    again, lifting and landing within 0.07 s of the capture's (the swivel kept, not held still
    by one plant through it; the rising feet not held planted), and the other targets hold."""
    case = TRANSFORMS["studio"](source_case(shared_path("humanoid", f"humanoid3d_{name}.bvh")))
    report, result = cleaned(case, tmp_path)
    measured = judge(case, case.rig, result, ~np.array(report["met_per_frame"]))
    assert measured["steps_matched"] == measured["steps"] > 0
    assert measured["sliding_mm_per_frame"] <= 1.0 and measured["depth_mm"] <= 2.0
    assert measured["peak_ratio"] <= PEAK_RATIO and measured["misses_listed"]


@pytest.mark.shared_data
def test_a_foot_resting_from_the_first_frame_of_a_noisy_clip_is_planted_from_that_frame(tmp_path):
    """The shared kick with capture noise (0.2 degrees on every rotation, 1 mm on the root) and
    12 mm under the floor: its standing toe rests from the first frame, where a speed by a
    one-sided difference doubles the noise. Cleaned by default, it is planted from that frame:
    no resting point of the kick without the noise slides more than 1 mm in a frame (the first
    frame was left 24 mm from the plant that began in the second), and every resting run of
    the feet is found again."""
    case = TRANSFORMS["noisy"](source_case(shared_path("humanoid", "humanoid3d_kick.bvh")))
    report, result = cleaned(case, tmp_path)
    measured = judge(case, case.rig, result, ~np.array(report["met_per_frame"]), case.truth)
    assert measured["sliding_capture_mm_per_frame"] > 5  # the noise moves the capture's resting feet
    assert measured["sliding_mm_per_frame"] <= 1.0 and measured["misses_listed"]
    assert measured["steps_matched"] == measured["steps"] > 0 and measured["depth_mm"] <= 2.0

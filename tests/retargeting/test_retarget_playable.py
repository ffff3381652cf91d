"""Retargets a robot can play, judged by an independent measurement (judging/retargets.py:
yourdfpy's transforms of the written trajectory CSV, its own BVH reader and contact detector),
on shared clips and on cases made from them: continuous joint values (no wraps or Euler twins),
steps within the URDF's velocity limits or listed per frame and DOF, every resting point planted
(hands, knees), nothing under the floor, hands near their scaled source points, the same on the
scaled rig, on robots with other joint orders and continuous joints, and on another rig family
in centimetres; and a report that agrees with that measurement."""

import math
import re
import tomllib

import numpy as np
import pytest

import deik
import deik.io.trajectory
import deik.io.urdf
from benchmarks import retarget_quality as quality
from deik.io.load import load_skeleton
from deik.retargeting.continuity import continuous_within_limits, rotation_triples
from deik.retargeting.maps import read_map
from deik.retargeting.measures import limit_violations
from helpers import ROOT, shared_path
from judging import retargets as judge

URDF_MAP = ROOT / "examples/maps/shared_bvh_to_human_urdf.toml"
HANDS = ["LeftElbow_end", "RightElbow_end"]


def _cut(path, frames, folder, case=None):
    """The clip at `path` cut to `frames` (and made into `case`), written under `folder`."""
    bvh = judge.read_bvh_file(path)
    bvh.frames = bvh.frames[frames[0] : frames[1]]
    if case:
        bvh = quality.source_case(bvh, case)
    out = folder / f"{path.stem}_{case or 'cut'}.bvh"
    quality.write_bvh_file(out, bvh)
    return out


def _onto_robot(source, robot, joint_map, folder, hands=HANDS):
    """Retarget through the command line, judge the files it wrote; (figures, deik's report)."""
    figures = quality.onto_robot(source, robot, joint_map, folder, hands)
    return figures, figures.pop("deik")


def _assert_playable(figures):
    assert figures["sliding_max_mm_per_frame"] <= judge.SLIDING_BOUND, figures["sliding_worst_point"]
    assert figures["penetration_max_mm"] <= judge.PENETRATION_BOUND
    assert figures["wrist_distance_max_mm"] <= figures["wrist_bound_mm"]
    if "step_excess_max" in figures:
        assert figures["wrap_count"] == 0
        assert figures["step_excess_max"] <= 1.0, figures["step_worst"]


def test_continuous_values_are_the_same_poses_nearest_the_frame_before():
    h = deik.humanoid()
    rng = np.random.default_rng(3)
    smooth = np.clip(h.reference + np.cumsum(rng.normal(0, 0.02, (40, h.n_dofs)), axis=0), h.lower, h.upper)
    jumpy = smooth.copy()
    for triple in rotation_triples(h):  # every third frame as its Euler twin, some turned by 2 pi
        twin = jumpy[::3, triple] + math.pi
        twin[:, 1] = math.pi - jumpy[::3, triple[1]]
        jumpy[::3, triple] = twin
    jumpy[1::4, :6] += 2 * math.pi * (h.dof_kind[:6] == 0)
    fixed = continuous_within_limits(h, jumpy)
    before, after = deik.forward_kinematics(h, jumpy), deik.forward_kinematics(h, fixed)
    assert np.abs(before.p_world_frame - after.p_world_frame).max() < 1e-9  # the same poses
    assert not limit_violations(h, fixed).any()
    assert np.abs(np.diff(fixed, axis=0)).max() < 0.2  # radians: no wrap, no twin between frames
    assert np.abs(fixed - smooth).max() < 1e-9  # where the smooth original was


def test_a_urdf_ball_joint_is_a_triple_and_a_continuous_joint_unwraps(tmp_path):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(
        '<robot name="arm"><link name="base"/><link name="v1"/><link name="v2"/><link name="upper"/>'
        '<link name="hand"/>'
        '<joint name="z" type="revolute"><parent link="base"/><child link="v1"/><axis xyz="0 0 1"/>'
        '<limit lower="-3.1" upper="3.1" velocity="2"/></joint>'
        '<joint name="x" type="revolute"><parent link="v1"/><child link="v2"/><axis xyz="-1 0 0"/>'
        '<limit lower="-1" upper="3.1" velocity="2"/></joint>'
        '<joint name="y" type="revolute"><parent link="v2"/><child link="upper"/><axis xyz="0 1 0"/>'
        '<limit lower="-1.5" upper="3.1" velocity="2"/></joint>'
        '<joint name="spin" type="continuous"><parent link="upper"/><child link="hand"/>'
        '<origin xyz="0 -0.3 0"/><axis xyz="0 1 0"/></joint></robot>'
    )
    sk = load_skeleton(str(urdf), up=(0, 1, 0)).skeleton
    assert [list(t) for t in rotation_triples(sk)] == [[0, 1, 2]]
    turning = np.zeros((30, 4))
    turning[:, 3] = np.linspace(0, 3 * math.pi, 30)  # the wrist spins one and a half turns
    turning[:, :3] = [0.3, 0.5, 0.2]
    wrapped = turning.copy()
    wrapped[:, 3] = (wrapped[:, 3] + math.pi) % (2 * math.pi) - math.pi
    fixed = continuous_within_limits(sk, wrapped)
    np.testing.assert_allclose(fixed, turning, atol=1e-9)  # unwrapped past pi, the ball joint kept
    assert deik.io.urdf.read_velocity_limits(urdf) == {"z": 2.0, "x": 2.0, "y": 2.0}


@pytest.mark.shared_data
def test_a_crawl_onto_the_robot_plants_hands_and_knees(tmp_path):
    source = _cut(shared_path("humanoid", "humanoid3d_crawl.bvh"), (60, 120), tmp_path)
    figures, report = _onto_robot(source, shared_path("robots", "human.urdf"), URDF_MAP, tmp_path)
    assert {"LeftKnee", "RightKnee"} & set(figures["resting_points"])  # knees rest in the crawl
    assert {"LeftElbow_end", "RightElbow_end"} & set(figures["resting_points"])  # and hands
    _assert_playable(figures)


@pytest.mark.shared_data
def test_the_report_agrees_with_the_independent_measurement(tmp_path):
    robot_path = tmp_path / "slow.urdf"  # velocity limits a tenth of human.urdf's: some steps cannot keep them
    robot_path.write_text(
        re.sub(
            r'velocity="([^"]+)"',
            lambda m: f'velocity="{float(m[1]) / 10:g}"',
            shared_path("robots", "human.urdf").read_text(),
        )
    )
    source = _cut(shared_path("humanoid", "humanoid3d_kick.bvh"), (0, 24), tmp_path)
    result = deik.retarget(source, str(robot_path), joint_map=str(URDF_MAP))
    csv = tmp_path / "kick.csv"
    deik.io.trajectory.write_trajectory(csv, result.motion)
    robot = judge.read_robot(robot_path)
    pairing, names, values, dt = judge.robot_pairing(robot, csv, tomllib.loads(URDF_MAP.read_text()))
    # the steps past a velocity limit, per frame and DOF, as the URDF's limits and the CSV give them
    expected = set()
    for d, name in enumerate(names):
        limit = robot.velocity.get(name)
        if limit is not None:
            steps = np.abs(np.diff(values[:, d]))
            expected |= {(int(n), name) for n in np.flatnonzero(steps > limit * dt + 1e-9)}
    assert expected  # a tenth of the limits is too slow for a kick
    assert {(v["frame"], v["dof"]) for v in result.report["velocity_violations"]} == expected
    assert result.report["summary"]["velocity_violations_count"] == len(expected)
    # penetration per frame: the deepest link origin or mapped point under the floor at 0, in mm
    depth = np.maximum(0.0, -pairing.body[..., 1].min(axis=1)) * 1000
    np.testing.assert_allclose(result.report["per_frame"]["penetration_mm"], depth, atol=1e-6)
    assert result.report["floor"]["height"] == 0.0 and result.report["summary"]["floor_height"] == 0.0
    # sliding per frame over the contacts deik holds, and per point
    contacts, mm = result.contacts, 1000.0
    where = {p.site: k for k, p in enumerate(read_map(URDF_MAP).points)}
    moved = np.linalg.norm(np.diff(pairing.target, axis=0), axis=-1) * mm
    both = contacts.mask[1:] & contacts.mask[:-1]
    per_frame = np.array(result.report["per_frame"]["contact_sliding_mm_per_frame"][1:], dtype=float)
    for n in range(len(both)):
        steps = [moved[n, where[site]] for s, site in enumerate(contacts.sites) if both[n, s]]
        if steps:
            assert per_frame[n] == pytest.approx(max(steps), abs=1e-6)
    for s, site in enumerate(contacts.sites):
        if both[:, s].any():
            largest = moved[both[:, s], where[site]].max()
            assert result.report["points"][site]["sliding_max_mm_per_frame"] == pytest.approx(largest, abs=1e-6)


@pytest.mark.shared_data
@pytest.mark.parametrize("case, clip, frames", [("backwards", "kick", (0, 30)), ("studio", "walk", (0, 30))])
def test_hard_cases_onto_the_robot_stay_playable(tmp_path, case, clip, frames):
    source = _cut(shared_path("humanoid", f"humanoid3d_{clip}.bvh"), frames, tmp_path, case)
    joint_map, hands = URDF_MAP, HANDS
    if case == "studio":  # centimetres, a Reference root, position channels on every joint, other names
        joint_map, hands = tmp_path / "studio.toml", quality.STUDIO_WRISTS
        joint_map.write_text(quality.toml_text(quality.studio_map(tomllib.loads(URDF_MAP.read_text()))))
    figures, report = _onto_robot(source, shared_path("robots", "human.urdf"), joint_map, tmp_path, hands)
    assert figures["resting_points"]  # the feet rest, whatever the rig calls them
    _assert_playable(figures)


@pytest.mark.shared_data
def test_robots_with_another_joint_order_and_continuous_joints(tmp_path):
    text = shared_path("robots", "human.urdf").read_text()
    robot = tmp_path / "human_mixed.urdf"
    robot.write_text(quality.robot_case(quality.robot_case(text, "continuous"), "reordered"))
    source = _cut(shared_path("humanoid", "humanoid3d_dance_a.bvh"), (0, 40), tmp_path)
    figures, report = _onto_robot(source, robot, URDF_MAP, tmp_path)
    _assert_playable(figures)
    names, _, values = judge.read_trajectory_csv(tmp_path / (source.stem + ".csv"))
    assert names[6:] != list(load_skeleton(str(shared_path("robots", "human.urdf")), up=(0, 1, 0)).skeleton.dof_names)


@pytest.mark.shared_data
def test_a_robot_standing_on_z_retargets_as_the_same_robot_on_y(tmp_path):
    """human.urdf stood on +Z (a root turned a quarter about X, as most robots are modelled) and
    its map saying so: the crawl's hands and knees rest and are held, judged along +Z, with key
    points as near as on the robot standing on +Y."""
    source = _cut(shared_path("humanoid", "humanoid3d_crawl.bvh"), (60, 120), tmp_path)
    robot, joint_map = tmp_path / "human_z_up.urdf", tmp_path / "z_up.toml"
    robot.write_text(quality.robot_case(shared_path("robots", "human.urdf").read_text(), "z_up"))
    joint_map.write_text(quality.toml_text(quality.z_up_map(tomllib.loads(URDF_MAP.read_text()))))
    (tmp_path / "y").mkdir(), (tmp_path / "z").mkdir()
    upright = _onto_robot(source, shared_path("robots", "human.urdf"), URDF_MAP, tmp_path / "y")[0]
    standing = _onto_robot(source, robot, joint_map, tmp_path / "z")[0]
    _assert_playable(standing)
    assert {"LeftKnee", "RightKnee"} & set(standing["resting_points"])
    assert standing["resting_points"] == upright["resting_points"]
    assert standing["keypoint_error_mean_mm"] == pytest.approx(upright["keypoint_error_mean_mm"], abs=1.0)


@pytest.mark.shared_data
@pytest.mark.parametrize("clip,frames", [("crawl", (60, 120)), ("dance_a", (0, 60))])
def test_a_robot_of_ball_joints_four_times_as_tall(tmp_path, clip, frames):
    """The model the shared clips were captured for, pybullet's DeepMimic humanoid: eight ball
    joints (docs/formats.md: three rotations each), bones four times the clips', judged by the
    judge's own reading of a ball; its feet and knees rest and stay planted."""
    source = _cut(shared_path("humanoid", f"humanoid3d_{clip}.bvh"), frames, tmp_path)
    robot = shared_path("humanoid", "humanoid_deepmimic_source.urdf")
    figures, report = _onto_robot(source, robot, ROOT / "examples/maps/shared_bvh_to_deepmimic_urdf.toml", tmp_path)
    assert figures["resting_points"]
    _assert_playable(figures)
    names = judge.read_trajectory_csv(tmp_path / (source.stem + ".csv"))[0]
    assert "right_hip.Xrotation" in names
    assert figures["keypoint_error_mean_mm"] <= 0.01 * figures["wrist_bound_mm"] / 0.1  # 1 % of stature


@pytest.mark.shared_data
def test_the_scaled_rig_has_the_same_contacts_and_floor(tmp_path):
    source = _cut(shared_path("humanoid", "humanoid3d_crawl.bvh"), (60, 120), tmp_path)
    figures = quality.onto_rig(source, tmp_path)
    report = figures.pop("deik")
    assert {"LeftKnee", "RightKnee"} & set(figures["resting_points"])
    _assert_playable(figures)
    assert report["floor_height"] == pytest.approx(figures["floor_source"], abs=0.01)  # metres: the same floor


@pytest.mark.shared_data
def test_a_map_scale_out_of_range_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text('scale = 1e-300\nup = [0, 1, 0]\n[points]\nHips = "middle_pelvis"\nNeck = "middle_head"\n')
    with pytest.raises(ValueError, match=r"tiny.toml: scale: scale = 1e-300 makes the source .* near 0.9"):
        deik.retarget(
            shared_path("humanoid", "humanoid3d_walk.bvh"), shared_path("robots", "human.urdf"), joint_map=path
        )


def test_a_csv_header_quotes_a_dof_named_with_a_comma_or_a_quote(tmp_path):
    """A URDF joint named `left,knee_Z` wrote a header of 45 fields over rows of 44 (exit 0)."""
    import csv
    import dataclasses

    from helpers import robot_arm

    arm = robot_arm()
    names = list(arm.dof_names)
    names[:2] = ["left,knee_Z", 'a "quoted" name']
    skeleton = dataclasses.replace(arm, dof_names=tuple(names))
    motion = deik.io.trajectory.Trajectory(skeleton, np.zeros((3, arm.n_dofs)), 1 / 30)
    path = tmp_path / "motion.csv"
    deik.io.trajectory.write_trajectory(path, motion)
    rows = list(csv.reader(path.read_text().splitlines(keepends=True)))
    assert rows[0] == ["frame", "time_s", *names]
    assert {len(row) for row in rows} == {arm.n_dofs + 2}


@pytest.mark.shared_data
def test_the_space_time_pass_runs_until_it_stops_gaining(tmp_path):
    """The whole get-up onto its own rig scaled: stopped after a fixed 30 iterations, its pass
    left the contacts sliding 0.37 mm a frame; run until a round gains little, 0.02."""
    figures = quality.onto_rig(shared_path("humanoid", "humanoid3d_getup_facedown.bvh"), tmp_path)
    figures.pop("deik")
    _assert_playable(figures)
    assert figures["sliding_max_mm_per_frame"] <= 0.1, figures["sliding_worst_point"]

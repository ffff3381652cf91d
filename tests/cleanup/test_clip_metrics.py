"""Clip metrics against hand computations, and the report picture."""

import math
import os

import numpy as np
import pytest

from deik.cleanup.contacts import contacts_from_ranges, detect_contacts
from deik.cleanup.metrics import com_outside_support, foot_sliding, joint_deviation, velocity_spikes
from deik.cleanup.summary import clip_report, per_frame_errors
from deik.io.bvh import Clip, read_bvh
from deik.model.build import build_skeleton
from deik.model.joints import ROTATE, Joint, Site, euler, translation
from deik.model.kinematics import forward_kinematics
from deik.viz.clip_report import plot_clip_report
from helpers import shared_path


def walk() -> Clip:
    return read_bvh(shared_path("humanoid", "humanoid3d_walk.bvh"))


def stage(poses, frame_time=0.1) -> Clip:
    """Three fixed sites a, b, c on the ground (Y up) and a body of mass 1 kg moved by
    translation DOFs (its position is the centre of mass), swinging an arm that carries a site."""
    joints = [
        Joint("ground", None),
        Joint("body", "ground", dofs=translation("XYZ"), mass=1.0),
        Joint("arm", "body", (0.0, 1.0, 0.0), dofs=euler("Z")),
    ]
    sites = [
        Site("a", "ground"),
        Site("b", "ground", (1.0, 0.0, 0.0)),
        Site("c", "ground", (0.0, 0.0, 1.0)),
        Site("foot", "body"),
        Site("hand", "arm", (1.0, 0.0, 0.0)),
    ]
    return Clip.from_poses(build_skeleton(joints, sites), np.asarray(poses, float), frame_time)


def test_foot_sliding_is_zero_while_pinned_and_the_step_length_otherwise():
    poses = np.zeros((6, 4))
    poses[:, 3] = np.linspace(0.0, 1.0, 6)  # the arm swings all along: the foot does not care
    poses[3:, 0] = [0.002, 0.004, 0.007]  # the foot slides 2 then 3 mm per frame from frame 3
    clip = stage(poses)
    contacts = contacts_from_ranges(clip, {"foot": [(0, 3), (3, 6)]})
    sliding = foot_sliding(clip, contacts)
    np.testing.assert_allclose(sliding[:, 0], [0.0, 0.0, 0.002, 0.002, 0.003], atol=1e-15)
    cut = contacts_from_ranges(clip, {"foot": [(0, 2), (4, 6)]})
    assert np.isnan(foot_sliding(clip, cut)[1:3, 0]).all()  # not in contact in both frames
    report = clip_report(clip, clip, contacts)
    assert report["sliding_mean_mm_per_frame"]["before"] == pytest.approx(1.4)
    assert report["sliding_max_mm_per_frame"]["after"] == pytest.approx(3.0)
    assert report["sliding_max_mm_per_frame"]["unit"] == "mm/frame"
    in_cm = clip_report(clip, clip, contacts, metres=0.01)  # the same numbers read as centimetres
    assert in_cm["sliding_max_mm_per_frame"]["after"] == pytest.approx(0.03)


def test_com_outside_a_hand_made_triangle():
    com = [
        (0.2, 0.5, 0.2),
        (1.0, 0.3, 1.0),
        (-0.5, 0.0, 0.5),
        (2.0, 0.0, -1.0),
        (0.5, 0.0, 0.3),
        (0.6, 0.0, 0.8),
        (0.5, 0.0, 0.5),
    ]
    clip = stage(np.concatenate([com, np.zeros((7, 1))], axis=1))
    ranges = {"a": [(0, 6)], "b": [(0, 5)], "c": [(0, 4)]}  # frame 4: a-b, 5: a alone, 6: none
    outside = com_outside_support(clip, contacts_from_ranges(clip, ranges))
    # inside; beyond the edge x + z = 1; left of edge a-c; nearest corner b; above segment a-b;
    # from corner a; no support
    expected = [0.0, 1 / math.sqrt(2), 0.5, math.sqrt(2), 0.3, 1.0, math.nan]
    np.testing.assert_allclose(outside, expected, atol=1e-12)


def flipped_euler(clip: Clip) -> np.ndarray:
    """Every ZXY triple (a, b, c) replaced by the same rotation (a + pi, pi - b, c + pi)."""
    sk, frames = clip.skeleton, clip.frames.copy()
    for k in range(sk.n_joints):
        own = np.arange(sk.joint_dof_start[k], sk.joint_dof_start[k + 1])
        a, b, c = own[sk.dof_kind[own] == ROTATE]
        frames[:, [a, b, c]] = frames[:, [a, b, c]] * [1, -1, 1] + np.pi
    return frames


@pytest.mark.shared_data
def test_joint_deviation_compares_rotations_not_euler_numbers():
    clip = walk()
    flipped = Clip(clip.skeleton, flipped_euler(clip), clip.frame_time, clip.layout)
    assert np.abs(np.degrees(flipped.frames - clip.frames)).max() > 90
    mean, top = joint_deviation(clip, flipped)
    assert top.max() < 1e-6


@pytest.mark.shared_data
@pytest.mark.parametrize("channel", ["RightKnee.Zrotation", "RightKnee.Yrotation"])
def test_joint_deviation_of_one_joint_turned_by_a_known_angle(channel):
    clip = walk()  # Z is the first and Y the last of the ZXY channels: either turns the knee by 30 deg
    frames = clip.frames.copy()
    frames[:, clip.skeleton.dof_names.index(channel)] += np.radians(30.0)
    mean, top = joint_deviation(clip, Clip(clip.skeleton, frames, clip.frame_time, clip.layout))
    np.testing.assert_allclose(top, 30.0, atol=1e-9)
    np.testing.assert_allclose(mean, 30.0 / clip.skeleton.n_joints, atol=1e-9)


def test_velocity_spikes_of_a_steady_turn():
    clip = stage(np.outer(np.arange(5), [0.0, 0.0, 0.0, 0.1]), frame_time=0.1)
    spikes = velocity_spikes(clip)
    assert spikes["dof_names"] == ("arm.Zrotation",)
    np.testing.assert_allclose(spikes["dof_velocity"], np.degrees(1.0))
    np.testing.assert_allclose(spikes["dof_acceleration"], 0.0, atol=1e-9)
    # the hand turns at 1 rad/s on a unit circle: centripetal 1 unit/s^2, up to the chord error
    hand = spikes["frame_names"].index("hand")
    np.testing.assert_allclose(spikes["position_acceleration"][:, hand], 1.0, rtol=1e-3)


@pytest.mark.shared_data
def test_velocity_spikes_find_an_injected_pop():
    clip = walk()
    before = velocity_spikes(clip)
    frames = clip.frames.copy()
    frames[10, clip.skeleton.dof_names.index("RightKnee.Zrotation")] += np.radians(20.0)
    after = velocity_spikes(Clip(clip.skeleton, frames, clip.frame_time, clip.layout))
    N, R = clip.n_frames, len(before["dof_names"])
    assert after["dof_velocity"].shape == (N - 1, R) and after["dof_acceleration"].shape == (N - 2, R)
    assert after["max_dof_acceleration"] > before["max_dof_acceleration"]
    top = after["max_dof_acceleration_frame"], after["max_dof_acceleration_dof"]
    assert top == (10, "RightKnee.Zrotation")
    assert after["max_position_acceleration"] > 2 * before["max_position_acceleration"]
    assert after["max_position_acceleration_frame"] == 10
    assert after["max_position_acceleration_site"] in ("RightAnkle", "RightAnkle_end")


@pytest.mark.shared_data
def test_report_and_series_of_an_unchanged_clip():
    clip = walk()
    contacts = detect_contacts(clip)
    hand = forward_kinematics(clip.skeleton, clip.frames).position("RightElbow_end")
    mask = np.arange(clip.n_frames) < 10
    reach = [("RightElbow_end", mask, np.where(mask[:, None], hand, np.nan))]
    report = clip_report(clip, clip, contacts, reach)
    for name, row in report.items():
        assert row["before"] == pytest.approx(row["after"], nan_ok=True), name
        assert name == name.lower() or "RightElbow_end" in name, name  # machine keys
    assert report["joint_angle_deviation_max_deg"]["after"] == 0.0
    assert report["reach_RightElbow_end_max_mm"]["before"] == 0.0
    assert report["sliding_max_mm_per_frame"]["before"] > 1.0
    series = per_frame_errors(clip, clip, contacts, reach)
    assert set(series) == {
        "sliding_mm_per_frame",
        "com_outside_support_mm",
        "zmp_outside_support_mm",
        "penetration_mm",
        "floating_mm",
        "joint_angle_deviation_deg",
        "joint_position_deviation_mm",
        "jerk_m_per_s3",
        "joint_velocity_deg_per_s",
        "joint_acceleration_deg_per_s2",
        "position_velocity_m_per_s",
        "position_acceleration_m_per_s2",
        "reach_RightElbow_end_mm",
        "contacts_count",
    }
    for entry in series.values():
        assert entry["before"].shape == entry["after"].shape == (clip.n_frames,)
    sliding = series["sliding_mm_per_frame"]["before"]
    assert np.isnan(sliding[0])
    assert np.nanmax(sliding) == pytest.approx(report["sliding_max_mm_per_frame"]["before"])
    assert np.isnan(series["reach_RightElbow_end_mm"]["before"][10:]).all()
    np.testing.assert_array_equal(series["contacts_count"]["after"], contacts.mask.sum(axis=1))


@pytest.mark.shared_data
def test_plot_clip_report_writes_one_png_atomically(tmp_path):
    clip = walk()
    series = per_frame_errors(clip, clip, detect_contacts(clip))
    path = tmp_path / "report.png"
    plot_clip_report({k: (v["before"], v["after"]) for k, v in series.items()}, path, clip.frame_time, "walk")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError, match="one length"):
        plot_clip_report({"bad": (np.zeros(3), np.zeros(4))}, tmp_path / "bad.png", 0.1)
    assert os.listdir(tmp_path) == ["report.png"]


def test_large_deviations_lists_each_joint_frame_beyond_the_threshold():
    from deik.cleanup.metrics import large_deviations

    poses = np.zeros((5, 4))  # body X, Y, Z, arm Z
    original = stage(poses)
    turned = poses.copy()
    turned[2, 3], turned[3, 3] = np.radians(45.0), np.radians(20.0)
    far = large_deviations(original, stage(turned), 30.0)
    assert [(f["frame"], f["joint"]) for f in far] == [(2, "arm")]
    assert abs(far[0]["deviation_deg"] - 45.0) < 1e-9
    assert large_deviations(original, original, 30.0) == []

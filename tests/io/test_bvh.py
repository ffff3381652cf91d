"""BVH import and export: pybullet ground truth for the three humanoid clips, round trips,
position channels anywhere, Euler continuity, atomic writes and one test per malformed input."""

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

import deik
from deik.errors import FileFormatError
from deik.io import atomic
from deik.io.bvh import Clip, format_bvh, parse_bvh, read_bvh, write_bvh
from deik.model.build import build_skeleton
from deik.model.joints import ROTATE, TRANSLATE, Joint, euler, hinge, translation
from deik.model.kinematics import forward_kinematics
from helpers import shared_path

CLIPS = {"walk": 39, "run": 25, "jump": 107}
END_SITES = {
    "Head": "Neck_end",
    "RightWrist": "RightElbow_end",
    "LeftWrist": "LeftElbow_end",
    "RightToe": "RightAnkle_end",
    "LeftToe": "LeftAnkle_end",
}

# Position channels on a non-root joint and between rotations; two End Sites on one joint.
TOY = """HIERARCHY
ROOT base
{
  OFFSET 1 2 3
  CHANNELS 3 Yrotation Xposition Zrotation
  JOINT arm
  {
    OFFSET 0 1 0
    CHANNELS 4 Zrotation Xposition Yrotation Yposition
    End Site
    {
      OFFSET 0 0 2
    }
    End Site
    {
      OFFSET 0.5 0 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.1
10 0.5 20 30 0.25 40 -0.75
-170 -1.5 95 -30 2 400 0.125
"""


def humanoid_path(name: str) -> Path:
    return shared_path("humanoid", f"humanoid3d_{name}.bvh")


def table_path(name: str) -> Path:
    return humanoid_path(name).with_suffix(".segments.json")


def Rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def Ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def Rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def write(tmp_path, text, name="bad.bvh"):
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return path


# --- ground truth and round trips on the shared clips ---------------------------------------


@pytest.mark.shared_data
@pytest.mark.parametrize("name", CLIPS)
def test_every_joint_end_site_and_com_matches_pybullet(name):
    clip = read_bvh(humanoid_path(name), segments=table_path(name))
    reference = json.loads(table_path(name).read_text())["pybullet_reference"]
    assert clip.n_frames == CLIPS[name] and clip.skeleton.n_dofs == 42
    assert "segment table" in clip.mass_source
    assert clip.skeleton.total_mass == pytest.approx(45.0001)
    fk = forward_kinematics(clip.skeleton, clip.frames)
    assert len(reference["positions"]) == 18
    for frame_name, positions in reference["positions"].items():
        error = np.abs(fk.position(END_SITES.get(frame_name, frame_name)) - positions).max()
        assert error < 1e-5, (frame_name, error)
    assert np.abs(fk.p_world_com - reference["com"]).max() < 1e-5


@pytest.mark.shared_data
@pytest.mark.parametrize("name", CLIPS)
def test_unchanged_clip_round_trips(name, tmp_path):
    source = humanoid_path(name)
    clip = read_bvh(source)
    write_bvh(tmp_path / "out.bvh", clip)
    again = read_bvh(tmp_path / "out.bvh")
    assert (tmp_path / "out.bvh").read_text() == source.read_text()  # even byte for byte
    assert again.layout == clip.layout and again.frame_time == clip.frame_time
    np.testing.assert_array_equal(again.skeleton.offsets, clip.skeleton.offsets)
    np.testing.assert_array_equal(again.skeleton.site_offset, clip.skeleton.site_offset)
    assert again.skeleton.site_names == clip.skeleton.site_names
    assert_same_channels(again, clip)


def assert_same_channels(a: Clip, b: Clip):
    """Within 1e-4 degrees per rotation channel and 1e-6 length units per position channel."""
    rotation = b.skeleton.dof_kind[b.channel_dofs] == ROTATE
    difference = np.abs(a.channel_values() - b.channel_values())
    assert difference[:, rotation].max(initial=0) < 1e-4
    assert difference[:, ~rotation].max(initial=0) < 1e-6


@pytest.mark.shared_data
def test_random_values_round_trip_within_tolerance(tmp_path):
    clip = read_bvh(humanoid_path("walk"))
    rng = np.random.default_rng(3)
    frames = rng.uniform(-1000, 1000, clip.frames.shape) * rng.uniform(0, 1, clip.frames.shape) ** 4
    changed = Clip(clip.skeleton, frames, clip.frame_time, clip.layout, "random", clip.mass_source)
    write_bvh(tmp_path / "random.bvh", changed)
    assert_same_channels(read_bvh(tmp_path / "random.bvh"), changed)


def test_humanoid_pose_written_and_read_back_has_the_same_positions(tmp_path):
    human = deik.humanoid()
    rng = np.random.default_rng(0)
    pose = rng.uniform(human.lower, human.upper)
    clip = Clip.from_poses(human, pose[None], 1 / 30)
    write_bvh(tmp_path / "pose.bvh", clip)
    again = read_bvh(tmp_path / "pose.bvh")
    assert again.skeleton.joint_names == human.joint_names and again.n_frames == 1
    before = forward_kinematics(human, pose)
    after = forward_kinematics(again.skeleton, again.frames[0])
    np.testing.assert_allclose(after.p_world_frame[: human.n_joints], before.p_world_frame[: human.n_joints], atol=1e-6)
    for original, read in zip(clip.layout, again.layout):  # End Sites come back in file order
        sites = [(a, b) for a, b in zip(original.children, read.children) if a in human.site_names]
        for a, b in sites:
            np.testing.assert_allclose(after.position(b), before.position(a), atol=1e-6)
    # elbows and toes turn about -X: written as Xrotation with the sign flipped
    assert clip.layout[human.joint_names.index("left_elbow")].channels == ("Xrotation",)


def test_from_poses_rejects_dofs_bvh_cannot_carry():
    tilted = build_skeleton([Joint("root", None), Joint("arm", "root", (0, 1, 0), hinge((1, 1, 0)))])
    with pytest.raises(ValueError, match=r"'arm.hinge'.*not a coordinate axis"):
        Clip.from_poses(tilted, np.zeros((1, 1)), 0.1)
    slid = build_skeleton([Joint("root", None, dofs=euler("Z") + translation("X"))])
    with pytest.raises(ValueError, match=r"'root.Xposition'.*translations must come before"):
        Clip.from_poses(slid, np.zeros((1, 2)), 0.1)
    spaced = build_skeleton([Joint("my root", None, dofs=euler("Z"))])
    with pytest.raises(ValueError, match=r"'my root' cannot be written to BVH"):
        Clip.from_poses(spaced, np.zeros((1, 1)), 0.1)


# --- position channels anywhere, limits, units ------------------------------------------------


def test_position_channels_on_any_joint_in_any_order_match_hand_computed_positions():
    clip = parse_bvh(TOY, "toy.bvh")
    sk = clip.skeleton
    assert sk.dof_names == (
        "base.Xposition",
        "base.Yrotation",
        "base.Zrotation",
        "arm.Xposition",
        "arm.Yposition",
        "arm.Zrotation",
        "arm.Yrotation",
    )
    assert sk.site_names == ("arm_end", "arm_end2")
    fk = forward_kinematics(sk, clip.frames)
    rows = [[float(v) for v in line.split()] for line in TOY.strip().splitlines()[-2:]]
    for n, (b_y, b_x, b_z, a_z, a_x, a_y, a_yp) in enumerate(rows):
        R_base = Ry(math.radians(b_y)) @ Rz(math.radians(b_z))
        p_base = np.array([1 + b_x, 2, 3])  # position channels move along the parent (world) axes
        R_arm = R_base @ Rz(math.radians(a_z)) @ Ry(math.radians(a_y))
        p_arm = p_base + R_base @ np.array([a_x, 1 + a_yp, 0])
        np.testing.assert_allclose(fk.position("base")[n], p_base, atol=1e-12)
        np.testing.assert_allclose(fk.position("arm")[n], p_arm, atol=1e-12)
        np.testing.assert_allclose(fk.rotation("arm")[n], R_arm, atol=1e-12)
        np.testing.assert_allclose(fk.position("arm_end")[n], p_arm + R_arm @ [0, 0, 2], atol=1e-12)
        np.testing.assert_allclose(fk.position("arm_end2")[n], p_arm + R_arm @ [0.5, 0, 0], atol=1e-12)
    text = format_bvh(clip)
    assert "CHANNELS 4 Zrotation Xposition Yrotation Yposition" in text
    assert text.count("End Site") == 2
    assert_same_channels(parse_bvh(text, "again.bvh"), clip)


def test_units_limits_and_reference():
    clip = parse_bvh(TOY, "toy.bvh")
    sk = clip.skeleton
    assert sk.name == "toy" and clip.frame_time == 0.1 and clip.source == "toy.bvh"
    rotation = sk.dof_kind == ROTATE
    assert (sk.lower[rotation] == -math.pi).all() and (sk.upper[rotation] == math.pi).all()
    assert clip.frames[0, sk.dof_names.index("base.Yrotation")] == pytest.approx(math.radians(10))
    # the root's translation: the clip's range widened by the reach on both sides; the arm's,
    # below a joint that translates, held at the capture's range so its bone keeps its length
    k, root = sk.dof_names.index("arm.Xposition"), sk.dof_names.index("base.Xposition")
    assert sk.dof_kind[k] == TRANSLATE
    assert (sk.lower[k], sk.upper[k]) == (0.25, 2.0)
    reach = sk.upper[root] - clip.frames[:, root].max()
    assert reach > 3 and sk.lower[root] == pytest.approx(clip.frames[:, root].min() - reach)
    freed = parse_bvh(TOY, "toy.bvh", free_translations=True).skeleton
    assert freed.upper[k] == pytest.approx(2.0 + reach) and freed.lower[k] == pytest.approx(0.25 - reach)
    assert (sk.reference == 0).all() and not clip.frames.flags.writeable


LOCAL = """HIERARCHY
ROOT hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT knee
  {
    OFFSET 0 -40 0
    CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 0 -40 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
1 90 2 0 0 0 0 -40 0 30 0 0
3 91 2 0 0 0 0 -40.2 0 -10 0 0
"""


def test_channels_that_repeat_their_offsets_are_local_positions():
    """A rig that writes six channels on every joint, its position channels repeating the OFFSET
    (within 1 %), places the joint at the channels, not at OFFSET + channels: the knee hangs 40
    units below the hips, not 80; the channel below the root is held at its captured values; the
    file comes back as it was read."""
    clip = parse_bvh(LOCAL, "local.bvh")
    kin = forward_kinematics(clip.skeleton, clip.frames)
    np.testing.assert_allclose(kin.position("knee") - kin.position("hips"), [[0, -40, 0], [0, -40.2, 0]], atol=1e-9)
    assert clip.layout[1].local_position and not clip.layout[0].local_position
    sk = clip.skeleton
    y = sk.dof_names.index("knee.Yposition")
    assert (sk.lower[y], sk.upper[y]) == pytest.approx((-0.2, 0.0))  # the DOF is the channel less the OFFSET
    assert "3.000000 91.000000 2.000000" in format_bvh(clip) and "0.000000 -40.200000 0.000000" in format_bvh(clip)
    again = parse_bvh(format_bvh(clip), "again.bvh")
    np.testing.assert_allclose(again.frames, clip.frames, atol=1e-12)


def test_clip_checks_what_it_is_given():
    clip = parse_bvh(TOY, "toy.bvh")
    sk, frames = clip.skeleton, clip.frames
    with pytest.raises(ValueError, match="every joint of the skeleton once, the root first"):
        Clip(sk, frames, 0.1, clip.layout[::-1])
    with pytest.raises(ValueError, match="frame_time must be a positive"):
        Clip(sk, frames, 0.0, clip.layout)
    with pytest.raises(ValueError, match=r"frames must have shape \(N, 7\)"):
        Clip(sk, frames[:, :3], 0.1, clip.layout)
    with pytest.raises(ValueError, match="NaN"):
        clip.with_pose(0, np.full(7, np.nan))
    with pytest.raises(ValueError, match="read-only"):
        clip.frames[0, 0] = 1.0


def test_pose_wraps_rotations_and_names_the_valid_range():
    clip = parse_bvh(TOY, "toy.bvh")
    arm_y = clip.skeleton.dof_names.index("arm.Yrotation")
    assert clip.frames[1, arm_y] == pytest.approx(math.radians(400))  # raw, as in the file
    pose = clip.pose(1)
    assert pose[arm_y] == pytest.approx(math.radians(40))
    assert pose[clip.skeleton.dof_names.index("arm.Xposition")] == 2.0
    assert ((pose >= clip.skeleton.lower) & (pose <= clip.skeleton.upper)).all()
    with pytest.raises(IndexError, match=r"frame 2 is out of range; valid frames: 0\.\.1"):
        clip.pose(2)


# --- Euler continuity ---------------------------------------------------------------------------


def equivalent_angles(clip: Clip, frames: np.ndarray, rng) -> np.ndarray:
    """The same rotations written differently: each Euler triple maybe flipped to
    (a + pi, pi - b, c + pi), then every rotation DOF shifted by random whole turns."""
    sk, out = clip.skeleton, frames.copy()
    for k in range(sk.n_joints):
        own = np.arange(sk.joint_dof_start[k], sk.joint_dof_start[k + 1])
        rot = own[sk.dof_kind[own] == ROTATE]
        flip = rng.random(len(out)) < 0.5
        out[flip, rot[0]] += math.pi
        out[flip, rot[1]] = math.pi - out[flip, rot[1]]
        out[flip, rot[2]] += math.pi
    rotation = sk.dof_kind == ROTATE
    out[:, rotation] += 2 * math.pi * rng.integers(-3, 4, out[:, rotation].shape)
    return out


@pytest.mark.shared_data
def test_with_pose_keeps_rotations_and_returns_to_the_original_angles():
    clip = read_bvh(humanoid_path("walk"))
    rng = np.random.default_rng(7)
    for n in (0, 17, 38):
        nudged = clip.frames[n] + rng.normal(0, 0.05, clip.skeleton.n_dofs)
        disguised = equivalent_angles(clip, nudged[None], rng)[0]
        new = clip.with_pose(n, disguised)
        np.testing.assert_allclose(new.frames[n], nudged, atol=1e-9)
        np.testing.assert_array_equal(np.delete(new.frames, n, 0), np.delete(clip.frames, n, 0))
        R_given = forward_kinematics(clip.skeleton, disguised).R_world_frame
        np.testing.assert_allclose(forward_kinematics(clip.skeleton, new.frames[n]).R_world_frame, R_given, atol=1e-12)


@pytest.mark.shared_data
def test_with_pose_on_random_poses_is_never_farther_than_whole_turns():
    clip = read_bvh(humanoid_path("run"))
    sk, rng = clip.skeleton, np.random.default_rng(11)
    rotation = sk.dof_kind == ROTATE
    for n in range(0, clip.n_frames, 4):
        pose = rng.uniform(-math.pi, math.pi, sk.n_dofs)
        new = clip.with_pose(n, pose).frames[n]
        np.testing.assert_allclose(
            forward_kinematics(sk, new).R_world_frame, forward_kinematics(sk, pose).R_world_frame, atol=1e-12
        )
        assert (new[~rotation] == pose[~rotation]).all()
        turned = pose + 2 * math.pi * np.round((clip.frames[n] - pose) / (2 * math.pi))
        assert np.abs(new - clip.frames[n])[rotation].max() <= math.pi + 1e-9
        assert ((new - clip.frames[n]) ** 2).sum() <= ((turned - clip.frames[n]) ** 2).sum() + 1e-9


@pytest.mark.shared_data
def test_with_frames_makes_every_frame_continuous():
    clip = read_bvh(humanoid_path("jump"))
    disguised = equivalent_angles(clip, clip.frames, np.random.default_rng(5))
    new = clip.with_frames(disguised)
    np.testing.assert_allclose(new.frames, clip.frames, atol=1e-9)
    assert new.layout == clip.layout and new.source == clip.source
    with pytest.raises(ValueError, match=r"shape \(107, 42\)"):
        clip.with_frames(disguised[:3])


# --- atomic writes --------------------------------------------------------------------------------


def test_write_into_a_missing_folder_leaves_nothing(tmp_path):
    clip = parse_bvh(TOY, "toy.bvh")
    with pytest.raises(FileNotFoundError):
        write_bvh(tmp_path / "missing" / "out.bvh", clip)
    assert list(tmp_path.iterdir()) == []


def test_write_failing_midway_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    clip = parse_bvh(TOY, "toy.bvh")
    target = tmp_path / "out.bvh"
    target.write_text("old contents")

    real = os.fdopen

    class DiskFull:
        def __init__(self, handle, *args, **kwargs):
            self.file = real(handle, *args, **kwargs)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.file.close()

        def write(self, data):
            self.file.write(data[: len(data) // 2])
            raise OSError(28, "No space left on device")

    monkeypatch.setattr(atomic.os, "fdopen", DiskFull)
    with pytest.raises(OSError, match=r"cannot write it: No space left on device") as caught:
        write_bvh(target, clip)
    assert caught.value.filename == str(target)
    assert os.listdir(tmp_path) == ["out.bvh"] and target.read_text() == "old contents"


# --- tolerated variations ----------------------------------------------------------------------


def test_crlf_tabs_spaces_case_braces_bom_and_blank_lines_are_read(tmp_path):
    messy = TOY.replace("\n", "\r\n").replace("  ", "\t \t").replace("Xposition", "XPOSITION")
    clip = read_bvh(write(tmp_path, messy + "\r\n\r\n   \n", "messy.bvh"))
    np.testing.assert_array_equal(clip.frames, parse_bvh(TOY, "toy.bvh").frames)
    assert clip.layout[0].channels == ("Yrotation", "Xposition", "Zrotation")
    compact = "\ufeff" + TOY.replace("base\n{", "base {").replace("}\n  }", "} }")
    compact = compact.replace("Frame Time: 0.1\n", "Frame Time: 0.1\n\n")
    np.testing.assert_array_equal(parse_bvh(compact, "compact.bvh").frames, clip.frames)


def test_zero_frames_and_zero_channels(tmp_path):
    empty_motion = TOY.split("Frames:")[0] + "Frames: 0\nFrame Time: 0.1\n"
    clip = parse_bvh(empty_motion, "none.bvh")
    assert clip.frames.shape == (0, 7) and np.isfinite(clip.skeleton.lower).all()
    with pytest.raises(IndexError, match="no frames"):
        clip.pose(0)
    assert parse_bvh(format_bvh(clip), "again.bvh").frames.shape == (0, 7)
    still = (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\n"
        "MOTION\nFrames: 3\nFrame Time: 0.5\n"
    )
    clip = parse_bvh(still, "still.bvh")
    assert clip.frames.shape == (3, 0) and clip.skeleton.site_names == ("a_end",)
    assert parse_bvh(format_bvh(clip), "again.bvh").frames.shape == (3, 0)


# --- malformed files: the error names the file and the line ------------------------------------


def lines_with(replacements: dict[int, str] | None = None, cut: int | None = None) -> str:
    """TOY with lines (1-based) replaced, or cut after line `cut`."""
    lines = TOY.splitlines()
    for n, text in (replacements or {}).items():
        lines[n - 1] = text
    return "\n".join(lines[:cut]) + "\n"


BAD = {
    "eof_inside_hierarchy": (lines_with(cut=8), 8, r"ends inside joint 'arm' opened at line 6"),
    "missing_closing_brace": (lines_with({18: ""}), 20, r"ends inside joint 'base'.*missing '\}'"),
    "unknown_keyword": (lines_with({5: "  ROTATION 1 2 3"}), 5, r"unknown keyword 'ROTATION'"),
    "unknown_joint_type": (lines_with({6: "  BONE arm"}), 6, r"unknown keyword 'BONE'"),
    "channel_count": (
        lines_with({5: "  CHANNELS 4 Yrotation Xposition Zrotation"}),
        5,
        r"CHANNELS says 4 channels but names 3",
    ),
    "unknown_channel": (
        lines_with({5: "  CHANNELS 3 Yrotation Wposition Zrotation"}),
        5,
        r"unknown channel 'Wposition'",
    ),
    "duplicate_channel": (
        lines_with({5: "  CHANNELS 3 Yrotation Xposition Yrotation"}),
        5,
        r"duplicate channel Yrotation in joint 'base'",
    ),
    "duplicate_joint": (lines_with({6: "  JOINT base"}), 6, r"duplicate joint name 'base' \(first at line 2\)"),
    "offset_count": (lines_with({8: "    OFFSET 0 1"}), 8, r"OFFSET needs 3 numbers \(x y z\), found 2"),
    "offset_not_a_number": (lines_with({8: "    OFFSET 0 one 0"}), 8, r"OFFSET value 'one' is not a number"),
    "offset_nan": (lines_with({4: "  OFFSET 1 nan 3"}), 4, r"NaN and infinite values are not allowed"),
    "missing_offset": (lines_with({8: ""}), 18, r"joint 'arm' \(line 6\) has no OFFSET"),
    "end_site_channels": (lines_with({12: "      CHANNELS 1 Xrotation"}), 12, r"an End Site cannot have CHANNELS"),
    "second_root": (TOY.replace("MOTION", "ROOT again\nMOTION"), 20, r"one ROOT"),
    "missing_motion": (lines_with(cut=19), 19, r"no MOTION section"),
    "missing_frames_line": (lines_with({21: "Frame Count: 2"}), 21, r"expected 'Frames: N'"),
    "fractional_frames": (lines_with({21: "Frames: 2.5"}), 21, r"expected 'Frames: N'"),
    "absurd_frames": (lines_with({21: "Frames: 1000000000000"}), 21, r"more frames than any capture holds"),
    "mac_line_ends": (TOY.replace("\n", "\r"), 1, r"lines end in CR alone.*convert them to LF"),
    "too_few_frame_lines": (lines_with(cut=23), 21, r"'Frames: 2' but only 1 frame lines follow"),
    "too_many_frame_lines": (TOY + "1 2 3 4 5 6 7\n", 25, r"more frame lines than 'Frames: 2'"),
    "frame_too_short": (lines_with({24: "1 2 3"}), 24, r"frame has 3 numbers, expected 7"),
    "frame_too_long": (lines_with({23: "1 2 3 4 5 6 7 8"}), 23, r"frame has 8 numbers, expected 7"),
    "frame_nan": (lines_with({24: "1 2 3 NaN 5 6 7"}), 24, r"channel 4 is NaN"),
    "frame_inf": (lines_with({23: "1 2 3 4 5 -inf 7"}), 23, r"channel 6 is -inf"),
    "frame_overflow": (lines_with({23: "1 2 3 4 5 1e400 7"}), 23, r"channel 6 '1e400' is beyond"),
    "frame_not_a_number": (lines_with({23: "1 2 3 4 5 6 7x"}), 23, r"channel 7 '7x' is not a number"),
    "zero_frame_time": (lines_with({22: "Frame Time: 0"}), 22, r"Frame Time must lie between 1e-06 and 3600"),
    "negative_frame_time": (lines_with({22: "Frame Time: -0.1"}), 22, r"Frame Time must lie between"),
    "subnormal_frame_time": (lines_with({22: "Frame Time: 1e-320"}), 22, r"Frame Time must lie between"),
    "empty_file": ("", 1, r"empty file"),
    "blank_file": ("\n  \n\t\n", 1, r"empty file"),
    "no_hierarchy": ("ROOT a\n{\n}\n", 1, r"must start with HIERARCHY"),
    "nul_bytes": (TOY.encode()[:40] + b"\x00\x01\x02" + TOY.encode()[40:], 5, r"not a text BVH file"),
    "not_utf8": (b"HIERARCHY\nROOT \xff\xfe\n", 2, r"not a text BVH file"),
}


@pytest.mark.parametrize("case", BAD)
def test_malformed_file_error_names_file_and_line(case, tmp_path):
    text, line, message = BAD[case]
    path = write(tmp_path, text)
    with pytest.raises(FileFormatError, match=message) as caught:
        read_bvh(path)
    assert caught.value.line == line and caught.value.source == str(path)
    assert str(caught.value).startswith(f"{path}:{line}: ")


def test_unreadable_paths_name_the_path(tmp_path):
    with pytest.raises(FileFormatError, match=r"nowhere\.bvh: no such BVH file"):
        read_bvh(tmp_path / "nowhere.bvh")
    with pytest.raises(FileFormatError, match=f"{tmp_path.name}: is a folder, not a BVH file"):
        read_bvh(tmp_path)


def test_special_files_are_refused_without_reading_them(tmp_path):
    link = tmp_path / "zero.bvh"
    link.symlink_to("/dev/zero")
    with pytest.raises(FileFormatError, match=r"zero\.bvh: is a device, pipe or socket, not a BVH file"):
        read_bvh(link)
    fifo = tmp_path / "pipe.bvh"
    os.mkfifo(fifo)
    with pytest.raises(FileFormatError, match=r"pipe\.bvh: is a device, pipe or socket"):
        read_bvh(fifo)


def test_files_over_the_input_limit_are_refused(tmp_path, monkeypatch):
    path = tmp_path / "big.bvh"
    path.write_text("HIERARCHY\n" + " " * 200)
    monkeypatch.setenv("DEIK_MAX_INPUT_BYTES", "100")
    with pytest.raises(FileFormatError, match=r"big\.bvh: is 210 bytes, more than the 100 .* DEIK_MAX_INPUT_BYTES"):
        read_bvh(path)


@pytest.mark.shared_data
def test_joint_names_with_spaces_read_write_and_clean_as_plain_names(tmp_path):
    """3ds Max's Biped writes "Bip01 L Thigh": a name is the rest of its line (runs of blanks as
    one space). The shared walk with every joint so named reads, round-trips and cleans to the
    same frames as with its own names (a name changes nothing but itself)."""
    text = shared_path("humanoid", "humanoid3d_walk.bvh").read_text()
    plain = parse_bvh(text, "walk.bvh")
    renamed = text
    for name in sorted(plain.skeleton.joint_names, key=len, reverse=True):
        renamed = renamed.replace(f" {name}\n", f" Bip01  {name[:-2]} {name[-2:]}\n")
    spaced = parse_bvh(renamed, "walk_biped.bvh")
    first = plain.skeleton.joint_names[1]
    assert spaced.skeleton.joint_names[1] == f"Bip01 {first[:-2]} {first[-2:]}"
    path = tmp_path / "biped.bvh"
    write_bvh(path, spaced)
    again = read_bvh(path)
    assert again.skeleton.joint_names == spaced.skeleton.joint_names
    np.testing.assert_allclose(again.frames, spaced.frames, atol=1e-6)
    fixed = [deik.clean_clip(clip, deik.CleanOptions()).clip.frames for clip in (plain, spaced)]
    np.testing.assert_allclose(fixed[0], fixed[1], atol=1e-9)

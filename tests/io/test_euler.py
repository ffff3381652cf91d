"""Continuous Euler channels: hand-made motions whose decomposed channels jump (a wrap past 180
degrees, a middle angle crossing 90 degrees, an exact gimbal lock) come out with small
per-frame steps and the very same rotations."""

import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from deik.io.bvh import Clip, format_bvh, parse_bvh, read_bvh
from deik.io.euler import continuous_frames
from deik.model.build import build_skeleton
from deik.model.joints import ROTATE, Dof, Joint, Site, euler, hinge
from deik.model.kinematics import forward_kinematics
from helpers import shared_path

FRAMES = 25


def rig():
    """A ZXY root, an arm whose YXZ channels turn about -Y, X and Z, and a one-hinge wrist."""
    arm = (
        Dof(ROTATE, (0.0, -1.0, 0.0), name="Yrotation"),
        Dof(ROTATE, (1.0, 0.0, 0.0), name="Xrotation"),
        Dof(ROTATE, (0.0, 0.0, 1.0), name="Zrotation"),
    )
    joints = [
        Joint("root", None, dofs=euler("ZXY")),
        Joint("arm", "root", (0.0, 1.0, 0.0), dofs=arm),
        Joint("wrist", "arm", (1.0, 0.0, 0.0), dofs=hinge((1, 0, 0))),
    ]
    return build_skeleton(joints, [Site("hand", "wrist", (0.3, 0.1, 0.2))])


def decomposed(root_angles, arm_angles, wrist):
    """(N, 7) DOF values as a decomposition into principal values gives them: scipy's
    intrinsic Euler angles (middle angle within +-90 degrees, the others within +-180) and the
    hinge wrapped into [-180, 180)."""
    root = Rotation.from_euler("ZXY", root_angles).as_euler("ZXY")
    arm = Rotation.from_euler("YXZ", arm_angles * [-1, 1, 1]).as_euler("YXZ") * [-1, 1, 1]
    return np.column_stack([root, arm, (np.asarray(wrist) + np.pi) % (2 * np.pi) - np.pi])


def rotations(sk, frames):
    return forward_kinematics(sk, frames).R_world_frame


def steps(frames):
    return np.degrees(np.abs(np.diff(frames, axis=0))).max()


def ramp(start, stop):
    return np.radians(np.linspace(start, stop, FRAMES))


def test_a_wrap_past_180_degrees_and_a_middle_angle_past_90_come_out_as_performed():
    sk = rig()
    # the root turns from 150 to 210 degrees about Z; the arm's X angle from 71 to 107
    # degrees (not locked in any frame); the wrist from 160 to 220: no channel moves more than 2.5
    # degrees a frame
    root = np.column_stack([ramp(150, 210), ramp(10, 20), ramp(-30, -20)])
    arm = np.column_stack([ramp(20, 40), ramp(71, 107), ramp(-5, 5)])
    wrist = ramp(160, 220)
    performed = np.column_stack([root, arm, wrist])
    frames = decomposed(root, arm, wrist)
    assert steps(frames) > 170  # the decomposition jumps: a turn, and a flip of the arm's triple
    out = continuous_frames(sk, frames)
    np.testing.assert_allclose(out, performed, atol=1e-9)
    np.testing.assert_allclose(rotations(sk, out), rotations(sk, frames), atol=1e-12)


def test_an_exact_gimbal_lock_trades_the_outer_angles_and_keeps_the_rotation():
    sk = rig()
    root = np.column_stack([ramp(-40, 40), ramp(60, 120), ramp(30, -30)])
    root[FRAMES // 2, 1] = np.pi / 2  # the middle frame is locked exactly
    arm = np.column_stack([ramp(0, 30), ramp(-120, -60), ramp(10, 40)])
    arm[FRAMES // 2, 1] = -np.pi / 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # scipy: "Gimbal lock detected"
        frames = decomposed(root, arm, np.zeros(FRAMES))
    assert steps(frames) > 25  # at the lock scipy puts the whole turn into one outer angle
    out = continuous_frames(sk, frames)
    np.testing.assert_allclose(rotations(sk, out), rotations(sk, frames), atol=1e-9)
    # the performed angles move at most 3.33 degrees a frame; at the lock the outer angles keep
    # their difference from the frame before, so the step after it is at most twice that
    assert steps(out) < 2 * 3.34


def test_near_the_lock_the_flipped_triple_is_chosen_only_when_nearer():
    sk = rig()
    # the root's middle angle stays just short of 90 degrees while its outer angles swing (a
    # performance near gimbal lock): no flip is nearer, the frames stay as they are
    root = np.column_stack([ramp(0, 60), np.full(FRAMES, np.radians(89.0)), ramp(0, -60)])
    frames = decomposed(root, np.zeros((FRAMES, 3)), np.zeros(FRAMES))
    np.testing.assert_allclose(continuous_frames(sk, frames), frames, atol=1e-12)


def test_many_turns_away_the_first_frame_sets_the_values():
    sk = rig()
    frames = np.zeros((4, sk.n_dofs))
    frames[:, 0] = np.radians([-660.0, -655.0, 50.0, -645.0])  # frame 2 is the same angle as -670
    out = continuous_frames(sk, frames)
    np.testing.assert_allclose(np.degrees(out[:, 0]), [-660.0, -655.0, -670.0, -645.0], atol=1e-9)


def test_clip_channels_written_continuous_read_back_continuous():
    sk = rig()
    root = np.column_stack([ramp(150, 210), ramp(71, 107), np.zeros(FRAMES)])
    clip = Clip.from_poses(sk, decomposed(root, np.zeros((FRAMES, 3)), ramp(-170, -190)), 1 / 30)
    fixed = clip.with_continuous_channels()
    back = parse_bvh(format_bvh(fixed))
    rotation = np.abs(back.channel_scale) > 1
    assert np.abs(np.diff(back.channel_values()[:, rotation], axis=0)).max() < 2.6
    np.testing.assert_allclose(rotations(sk, back.frames), rotations(sk, clip.frames), atol=1e-7)


@pytest.mark.shared_data
@pytest.mark.parametrize("name", ["walk", "run", "jump", "dance_a", "punch"])
def test_captured_clips_keep_their_rotations_and_never_step_further(name):
    clip = read_bvh(shared_path("humanoid", f"humanoid3d_{name}.bvh"))
    out = continuous_frames(clip.skeleton, clip.frames)
    rotation = clip.skeleton.dof_kind == ROTATE
    assert steps(out[:, rotation]) <= steps(clip.frames[:, rotation]) + 1e-9
    np.testing.assert_allclose(rotations(clip.skeleton, out), rotations(clip.skeleton, clip.frames), atol=1e-9)

"""The BVH view of a skeleton moves every joint and site where the skeleton's own FK puts them."""

import numpy as np

import deik
from deik.io.bvh import format_bvh, parse_bvh
from deik.io.bvh.preview import view_clip
from deik.model.rotations import euler_angles, euler_matrix
from helpers import random_poses, robot_arm


def test_the_view_of_a_robot_arm_follows_its_forward_kinematics():
    arm = robot_arm()
    poses = random_poses(arm, 7, seed=3)
    clip = view_clip(arm, poses, 0.04)
    ours = deik.forward_kinematics(arm, poses)
    view = deik.forward_kinematics(clip.skeleton, clip.poses())
    for name in arm.frame_names:  # the prismatic "slide" included
        assert np.abs(view.position(name) - ours.position(name)).max() < 1e-9, name
    read = parse_bvh(format_bvh(clip), "view.bvh")  # through the file (End Sites come back as JOINT_end)
    through = deik.forward_kinematics(read.skeleton, read.poses())
    for name in arm.joint_names:
        assert np.abs(through.position(name) - ours.position(name)).max() < 1e-5, name


def test_euler_angles_invert_euler_matrix_for_every_order():
    angles = np.random.default_rng(0).uniform(-1.5, 1.5, (50, 3))
    for order in ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"):
        assert np.allclose(euler_angles(order, euler_matrix(order, angles)), angles)

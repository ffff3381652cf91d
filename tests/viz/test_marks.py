"""What pictures mark: the tree's bones, root and tips, the labels kept apart, the length unit,
and the goals' target points, checked against the skeletons' own definitions."""

import dataclasses

import numpy as np
import pytest

import deik
from deik.viz.marks import bones, frame_parents, goal_targets, length_unit, roots, spread_out, tips
from helpers import random_poses, robot_arm


def test_bones_and_root_follow_the_skeleton_tree():
    arm = robot_arm()
    parents = frame_parents(arm)
    assert len(parents) == arm.n_frames and list(roots(parents)) == [0]
    pairs = {tuple(p) for p in bones(parents)}
    assert len(pairs) == arm.n_frames - 1
    for name in ("tool", "fingertip"):
        site = arm.frame_index(name)
        assert parents[site] == arm.site_joint[site - arm.n_joints] and (parents[site], site) in pairs
    for joint in range(1, arm.n_joints):
        assert (arm.parents[joint], joint) in pairs


def test_tips_are_the_ends_of_every_chain_at_any_pose():
    arm = robot_arm()
    for pose in random_poses(arm, 3, seed=4):
        points = deik.forward_kinematics(arm, pose).p_world_frame
        named = {arm.frame_names[k] for k in tips(frame_parents(arm), points)}
        assert named == {"tool", "fingertip", "foot0", "foot1", "foot2"}
    walk_like = deik.chain(4, dims=3)
    points = deik.forward_kinematics(walk_like, walk_like.reference).p_world_frame
    assert [walk_like.frame_names[k] for k in tips(frame_parents(walk_like), points)] == ["tip"]


def test_a_fixed_link_on_the_way_to_the_tool_frame_is_no_tip():
    joints = [deik.Joint("base", None), deik.Joint("link", "base", (0, 0, 1), deik.hinge((0, 1, 0)))]
    sites = [deik.Site("flange", "link", (0, 0, 0.5)), deik.Site("tool", "link", (0, 0, 0.8))]
    sk = deik.build_skeleton(joints, sites=sites, up=(0, 0, 1))
    points = deik.forward_kinematics(sk, [0.7]).p_world_frame
    assert [sk.frame_names[k] for k in tips(frame_parents(sk), points)] == ["tool"]
    sideways = deik.build_skeleton(joints, sites=[sites[0], deik.Site("tool", "link", (0.3, 0, 0.8))], up=(0, 0, 1))
    points = deik.forward_kinematics(sideways, [0.7]).p_world_frame
    assert len(tips(frame_parents(sideways), points)) == 2


def test_spread_out_keeps_labels_apart():
    points = np.array([[0.0, 0, 0], [0.01, 0, 0], [1, 0, 0], [1, 0.02, 0], [0.5, 0.5, 0]])
    assert spread_out(points, [0, 1, 2, 3, 4]) == [0, 2, 4]
    assert spread_out(points, [1, 0]) == [1]


def test_length_units_by_source():
    assert length_unit(deik.humanoid(), "builtin") == ("m", "built-in")
    assert length_unit(deik.chain(3))[0] == "link lengths"
    assert length_unit(robot_arm(), "urdf") == ("m", "URDF")
    assert length_unit(robot_arm())[0] == "length units"
    assert length_unit(deik.humanoid(), "bvh")[0] == "m"  # 1.75 m tall: guessed as metres
    assert length_unit(deik.humanoid(), "bvh", given="cm") == ("cm", "given")
    h, scale = deik.humanoid(), 0.45 / 0.0254  # metres to the CMU database's unit
    cmu = dataclasses.replace(h, offsets=h.offsets * scale, site_offset=h.site_offset * scale)
    unit, source = length_unit(cmu, "bvh")
    assert unit == "cmu" and "the CMU database's 1/0.45 inch" in source


def test_goal_targets_are_the_goals_points():
    human = deik.humanoid()
    batch = np.array([[0.4, 1.2, 0.3], [0.1, 1.0, 0.2]])
    problem = deik.Problem(
        human,
        [
            deik.Position("left_hand", batch),
            deik.ComOverSupport((0.0, 0.0, 0.1)),
            deik.Obstacle((0.3, 1.0, 0.3), 0.1),
            deik.Orientation("head_top", np.eye(3)),
            deik.Comfort(),
        ],
    )
    records = goal_targets(problem)
    assert [r["kind"] for r in records] == ["target", "support", "obstacle"]
    assert records[0]["goal"] == "position left_hand" and np.allclose(records[0]["position"], batch)
    assert records[1]["position"] == [0.0, 0.0, 0.1]
    assert records[2]["centre"] == [0.3, 1.0, 0.3] and records[2]["radius"] == pytest.approx(0.1)


def test_a_marker_on_a_bone_is_a_site_but_no_tip():
    joints = [deik.Joint("root", None, dofs=deik.euler("ZXY")), deik.Joint("a", "root", (0, 0.5, 0), deik.euler("ZXY"))]
    joints.append(deik.Joint("b", "a", (0.4, 0, 0), deik.hinge((0, 0, 1))))
    sites = [deik.Site("marker", "a", (0.2, 0, 0)), deik.Site("end", "b", (0.3, 0, 0))]
    sk = deik.build_skeleton(joints, sites=sites)
    for pose in random_poses(sk, 3, seed=1):
        points = deik.forward_kinematics(sk, pose).p_world_frame
        assert [sk.frame_names[k] for k in tips(frame_parents(sk), points)] == ["end"]

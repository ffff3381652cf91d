"""deik.retarget against known answers: the same skeleton reproduces the clip, longer legs keep
the feet on the floor with little sliding, and a shared clip onto the URDF human stays within
its joint limits with bounded key-point errors. Positions are checked by the NumPy FK."""

import numpy as np
import pytest

import deik
from deik.retargeting.maps import read_map
from deik.retargeting.measures import limit_violations
from deik.retargeting.skeletons import scaled_bones
from helpers import shared_path

WALK = ("humanoid", "humanoid3d_walk.bvh")


@pytest.mark.shared_data
def test_the_same_skeleton_reproduces_the_clip():
    clip = deik.read_bvh(shared_path(*WALK))
    result = deik.retarget(clip, scale={"LeftHip": 1.0}, frames=(0, 12))
    before = deik.forward_kinematics(clip.skeleton, clip.poses()[:12])
    after = deik.forward_kinematics(result.clip.skeleton, result.clip.poses())
    for site in ("LeftElbow_end", "RightElbow_end", "Neck_end"):  # followed: within the reach tolerance
        assert np.linalg.norm(after.position(site) - before.position(site), axis=-1).max() < 0.0055, site
    # only the planting of the capture's sliding feet moves the rest, by millimetres on average
    assert np.median(np.linalg.norm(after.p_world_frame - before.p_world_frame, axis=-1)) < 0.005
    assert result.report["summary"]["leg_ratio"] == 1.0


@pytest.mark.shared_data
def test_longer_legs_keep_the_contacts_on_the_floor():
    clip = deik.read_bvh(shared_path(*WALK))
    result = deik.retarget(clip, scale={"LeftHip": 1.1, "RightHip": 1.1})
    contacts, floor = result.contacts, result.report["floor"]["height"]  # the source's resting points and floor
    assert {"LeftAnkle_end", "RightAnkle_end"} <= set(contacts.sites)
    sk = result.clip.skeleton
    knee = sk.joint_names.index("LeftKnee")
    assert np.allclose(sk.offsets[knee], 1.1 * clip.skeleton.offsets[knee])
    kin = deik.forward_kinematics(sk, result.clip.poses())
    source = deik.forward_kinematics(clip.skeleton, clip.poses())
    for s, site in enumerate(contacts.sites):
        for a, b in contacts.intervals(s):
            height = kin.position(site)[a:b] @ sk.up - floor
            # planted at the source's median height in the contact times the leg ratio, or on the
            # floor when that is within the snap distance of it (deik.cleanup.plants)
            plant = 1.1 * np.median(source.position(site)[a:b] @ sk.up - floor)
            gap = np.minimum(np.abs(height - plant), np.abs(height))
            assert gap.max() < 0.003, (site, a, b)
            steps = np.linalg.norm(np.diff(kin.position(site)[a:b], axis=0), axis=-1)
            assert steps.max() < 0.002, (site, a, b)  # metres per frame: planted
    naive = deik.forward_kinematics(sk, clip.poses())  # the angles alone: the feet sink
    assert (naive.p_world_frame @ sk.up).min() - floor < -0.07
    assert result.report["summary"]["joint_angle_deviation_mean_deg"] < 5.0


@pytest.mark.shared_data
def test_a_shared_clip_onto_the_urdf_human_keeps_its_limits():
    result = deik.retarget(
        shared_path(*WALK),
        shared_path("robots", "human.urdf"),
        joint_map="examples/maps/shared_bvh_to_human_urdf.toml",
        frames=(0, 10),
    )
    motion = result.motion
    assert motion.frames.shape == (10, 42)
    assert not limit_violations(motion.skeleton, motion.frames).any()
    assert result.report["summary"]["limit_violations_count"] == 0
    kin = deik.forward_kinematics(motion.skeleton, motion.poses())
    errors = [np.linalg.norm(kin.position(n) - result.targets[:, k], axis=-1) for k, n in enumerate(result.keypoints)]
    assert np.mean(errors) < 0.12 and np.max(errors) < 0.45  # metres: the rigs' proportions differ
    view = deik.forward_kinematics(result.clip.skeleton, result.clip.poses())
    for name in ("left_hand", "right_foot", "middle_head"):  # the BVH view moves as the robot does
        assert np.abs(view.position(name) - kin.position(name)).max() < 1e-5


def test_scaled_bones_lengthen_the_bones_below_a_joint_only():
    h = deik.humanoid()
    longer = scaled_bones(h, {"left_hip": 2.0})
    k = h.joint_names.index("left_knee")
    assert np.allclose(longer.offsets[k], 2 * h.offsets[k])
    assert np.allclose(longer.offsets[h.joint_names.index("left_hip")], h.offsets[h.joint_names.index("left_hip")])
    with pytest.raises(ValueError, match="no joint 'left_hp'.*left_hip"):
        scaled_bones(h, {"left_hp": 1.1})
    for factor in (1e9, 0.0, -1.0, float("nan")):  # 1e9 once failed later, naming an offsets row and no flag
        with pytest.raises(ValueError, match=r"--scale left_hip=.*: a factor must be a number from 0.01 to 100"):
            scaled_bones(h, {"left_hip": factor})


def test_a_map_with_an_unknown_key_names_the_file_and_the_key(tmp_path):
    path = tmp_path / "map.toml"
    path.write_text('scael = 1.0\n[points]\nHips = "pelvis"\n')
    with pytest.raises(ValueError, match=r"map.toml: scael: unknown key; did you mean 'scale'"):
        read_map(path)


def test_a_map_pulling_one_target_point_from_two_sources_names_both_keys(tmp_path):
    """A copy-paste slip (the left knee mapped onto the right one) pulled the target two ways;
    two sources on one target frame at different offsets are two points and stand."""
    path = tmp_path / "map.toml"
    path.write_text('[points]\nHips = "pelvis"\nLeftKnee = "right_knee"\nRightKnee = "right_knee"\n')
    with pytest.raises(ValueError, match=r"points.LeftKnee and points.RightKnee both map onto 'right_knee'"):
        read_map(path)
    path.write_text(
        '[points]\nLeftToe = { target = "left_ankle", offset = [0.1, 0, 0] }\n'
        'LeftHeel = { target = "left_ankle", offset = [-0.05, 0, 0] }\n'
    )
    assert [p.source for p in read_map(path).points] == ["LeftToe", "LeftHeel"]


def test_a_joint_scaled_twice_on_the_command_line_is_refused(tmp_path, capsys):
    from deik.cli.app import main

    out = tmp_path / "o.bvh"
    assert main(["retarget", "humanoid", "--scale", "left_hip=1.1,left_hip=0.5", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert (
        err.strip()
        == "deik: error: --scale 'left_hip=1.1,left_hip=0.5': left_hip is given twice; give each joint one factor"
    )
    assert not out.exists()

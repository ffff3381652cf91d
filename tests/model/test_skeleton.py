"""Skeleton construction: every validation error names its cause; lookups, reach, immutability
and the topological sort of build_skeleton."""

import dataclasses
import math

import numpy as np
import pytest

import deik
from deik import Joint, Segment, Site, build_skeleton, euler, hinge, translation
from deik.model.joints import ROTATE, Dof


def tree_joints():
    """A small branching tree: root -> a -> a2, root -> b (b carries a ball joint)."""
    return [
        Joint("root", None, (0.0, 0.5, 0.0), translation("XYZ", -1.0, 1.0) + euler("ZXY")),
        Joint("a", "root", (0.3, 0.0, 0.0), hinge((0, 0, 1)), mass=1.0),
        Joint("a2", "a", (0.0, 0.4, 0.1), euler("XZ"), mass=2.0),
        Joint("b", "root", (-0.2, 0.1, 0.0), euler("ZY"), mass=0.5),
    ]


def tree_sites():
    return [Site("a_tip", "a2", (0.1, 0.2, 0.0)), Site("b_tip", "b", (0.0, 0.0, 0.3))]


# --- errors from build_skeleton -------------------------------------------------------------


def test_cycle_is_reported_with_its_path():
    joints = [Joint("root", None), Joint("b", "c"), Joint("c", "b"), Joint("d", "root")]
    with pytest.raises(ValueError, match=r"cycle: b -> c -> b"):
        build_skeleton(joints)


def test_self_parent_is_a_cycle():
    with pytest.raises(ValueError, match=r"cycle: x -> x"):
        build_skeleton([Joint("root", None), Joint("x", "x")])


def test_cycle_reached_through_a_dangling_branch_names_only_the_loop():
    joints = [Joint("root", None), Joint("tail", "p"), Joint("p", "q"), Joint("q", "p")]
    with pytest.raises(ValueError, match=r"cycle: p -> q -> p$"):
        build_skeleton(joints)


def test_unknown_parent_name():
    with pytest.raises(ValueError, match=r"joint 'b' names unknown parent 'nope'"):
        build_skeleton([Joint("root", None), Joint("b", "nope")])


def test_two_roots():
    with pytest.raises(ValueError, match=r"exactly one root.*\['r1', 'r2'\]"):
        build_skeleton([Joint("r1", None), Joint("r2", None)])


def test_no_root():
    with pytest.raises(ValueError, match=r"exactly one root.*\[\]"):
        build_skeleton([Joint("a", "b"), Joint("b", "a")])


def test_duplicate_joint_names():
    with pytest.raises(ValueError, match=r"duplicate joint name 'a'"):
        build_skeleton([Joint("root", None), Joint("a", "root"), Joint("a", "root")])


def test_duplicate_joint_and_site_names():
    with pytest.raises(ValueError, match=r"duplicate joint/site names \['a'\]"):
        build_skeleton([Joint("root", None), Joint("a", "root")], sites=[Site("a", "root")])


def test_duplicate_site_names():
    with pytest.raises(ValueError, match=r"duplicate joint/site names \['s'\]"):
        build_skeleton([Joint("root", None)], sites=[Site("s", "root"), Site("s", "root")])


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_joint_offset(bad):
    joints = [Joint("root", None), Joint("a", "root", (1.0, bad, 0.0))]
    with pytest.raises(ValueError, match=r"offsets row 1 is not finite"):
        build_skeleton(joints)


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_site_and_mass_offsets(bad):
    with pytest.raises(ValueError, match=r"site_offset row 0 is not finite"):
        build_skeleton([Joint("root", None)], sites=[Site("s", "root", (0.0, 0.0, bad))])
    with pytest.raises(ValueError, match=r"mass_offset row 0 is not finite"):
        build_skeleton([Joint("root", None)], segments=[Segment("root", 1.0, (bad, 0.0, 0.0))])


def test_inverted_limits_name_the_dof():
    joints = [Joint("root", None), Joint("elbow", "root", (1, 0, 0), hinge((0, 0, 1), 1.0, -1.0, label="flexion"))]
    with pytest.raises(ValueError, match=r"DOF 'elbow\.flexion' has inverted limits: lower 1 > upper -1"):
        build_skeleton(joints)


def test_inverted_limits_on_one_euler_channel_name_that_channel():
    dofs = euler("ZXY", lower=(-1.0, 0.5, -1.0), upper=(1.0, 0.2, 1.0))
    with pytest.raises(ValueError, match=r"'shoulder\.Xrotation' has inverted limits"):
        build_skeleton([Joint("root", None), Joint("shoulder", "root", (0, 1, 0), dofs)])


def test_nan_limits():
    with pytest.raises(ValueError, match=r"limits must not be NaN"):
        build_skeleton([Joint("root", None, dofs=hinge((1, 0, 0), math.nan, 1.0))])


def test_negative_joint_mass_names_the_joint():
    with pytest.raises(ValueError, match=r"mass .*-2\.0.* kg on joint 'a' must lie between 0 and 1e\+12 kg"):
        build_skeleton([Joint("root", None, mass=1.0), Joint("a", "root", (1, 0, 0), mass=-2.0)])


def test_negative_mass_message_shows_a_plain_number():
    with pytest.raises(ValueError, match=r"^mass -2(\.0)? kg on joint 'a'"):
        build_skeleton([Joint("root", None, mass=1.0), Joint("a", "root", (1, 0, 0), mass=-2.0)])


def test_negative_segment_mass_and_nan_mass():
    with pytest.raises(ValueError, match=r"kg on joint 'root' must lie between 0 and"):
        build_skeleton([Joint("root", None)], segments=[Segment("root", -0.1)])
    with pytest.raises(ValueError, match=r"nan.* kg on joint 'root' must lie between 0 and"):
        build_skeleton([Joint("root", None, mass=math.nan)])


def test_unknown_joint_in_site_and_segment():
    with pytest.raises(ValueError, match=r"site 's' names unknown joint 'ghost'"):
        build_skeleton([Joint("root", None)], sites=[Site("s", "ghost")])
    with pytest.raises(ValueError, match=r"segment 'thigh' names unknown joint 'ghost'"):
        build_skeleton([Joint("root", None)], segments=[Segment("ghost", 1.0, name="thigh")])


@pytest.mark.parametrize("axis", [(0, 0, 0), (0.0, 1e-15, 0.0), (math.nan, 1, 0), (1, 0)])
def test_zero_or_bad_hinge_axis(axis):
    with pytest.raises(ValueError, match=r"hinge axis must be a finite non-zero 3-vector"):
        hinge(axis)


def test_hinge_axis_is_normalised():
    (dof,) = hinge((0, 3.0, 4.0))
    np.testing.assert_allclose(dof.axis, (0.0, 0.6, 0.8), rtol=0, atol=1e-15)


def test_non_unit_dof_axis_given_directly():
    dof = Dof(ROTATE, (0.0, 0.0, 2.0))
    with pytest.raises(ValueError, match=r"every DOF axis must be a unit vector"):
        build_skeleton([Joint("root", None, dofs=(dof,))])


@pytest.mark.parametrize("order", ["XQ", "", "X Y", "XYW"])
def test_bad_euler_letters(order):
    with pytest.raises(ValueError, match=r"must use only the letters X, Y and Z"):
        euler(order)


def test_lower_case_euler_order_is_accepted():
    assert [d.axis for d in euler("zxy")] == [(0, 0, 1), (1, 0, 0), (0, 1, 0)]


def test_bad_translation_letters():
    with pytest.raises(ValueError, match=r"X, Y and Z"):
        translation("XQ")


@pytest.mark.parametrize(
    "rotation, why",
    [
        (np.diag([1.0, 1.0, -1.0]), "reflection"),
        (np.diag([2.0, 1.0, 1.0]), "scaled"),
        (np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "sheared"),
        (np.full((3, 3), math.nan), "nan"),
    ],
)
def test_site_rotation_must_be_a_proper_rotation(rotation, why):
    site = Site("tool", "root", (0, 0, 0), tuple(map(tuple, rotation)))
    with pytest.raises(ValueError, match=r"site 'tool' rotation is not a proper rotation matrix"):
        build_skeleton([Joint("root", None)], sites=[site])


def test_bad_up_vector():
    with pytest.raises(ValueError, match=r"up must be a unit vector"):
        build_skeleton([Joint("root", None)], up=(0.0, 2.0, 0.0))


# --- errors from direct Skeleton construction ---------------------------------------------


def test_direct_construction_with_later_parent_index():
    sk = deik.chain(3)
    with pytest.raises(ValueError, match=r"joint 1 \('link1'\) has parent index 2: parents must be earlier"):
        dataclasses.replace(sk, parents=np.array([-1, 2, 1], np.int32))


def test_direct_construction_with_self_parent_index():
    sk = deik.chain(3)
    with pytest.raises(ValueError, match=r"joint 2 \('link2'\) has parent index 2"):
        dataclasses.replace(sk, parents=np.array([-1, 0, 2], np.int32))


def test_direct_construction_with_non_root_first_joint():
    sk = deik.chain(3)
    with pytest.raises(ValueError, match=r"joint 0 \('link0'\) must be the root with parent -1, got 0"):
        dataclasses.replace(sk, parents=np.array([0, 0, 1], np.int32))


def test_direct_construction_with_wrong_dof_pointer():
    sk = deik.chain(3)
    with pytest.raises(ValueError, match=r"joint_dof_start must be \(4,\) ending at the DOF count 3"):
        dataclasses.replace(sk, joint_dof_start=np.array([0, 1, 2, 2], np.int32))


def test_direct_construction_with_nan_reference():
    sk = deik.chain(3)
    with pytest.raises(ValueError, match=r"reference \(comfort\) pose must be finite"):
        dataclasses.replace(sk, reference=np.array([0.0, math.nan, 0.0]))


def test_empty_skeleton():
    sk = deik.chain(1)
    with pytest.raises(ValueError, match=r"at least one joint"):
        dataclasses.replace(sk, joint_names=(), site_names=())


# --- lookups, reach, immutability, sort ------------------------------------------------------


def test_frame_index_and_did_you_mean():
    sk = build_skeleton(tree_joints(), tree_sites())
    assert sk.frame_names[sk.frame_index("a2")] == "a2"
    assert sk.frame_index("b_tip") == sk.n_joints + 1
    with pytest.raises(KeyError, match=r"'a_tp' not found in skeleton 'skeleton'; did you mean 'a_tip'"):
        sk.frame_index("a_tp")
    with pytest.raises(KeyError) as info:
        sk.frame_index("zzzzzz")
    assert "did you mean" not in str(info.value)


def test_humanoid_did_you_mean():
    sk = deik.humanoid()
    with pytest.raises(KeyError, match=r"did you mean 'left_hand'"):
        sk.frame_index("left_hnad")


def test_joint_dofs_slices_and_site_error():
    sk = build_skeleton(tree_joints(), tree_sites())
    root = sk.joint_dofs("root")
    assert root.stop - root.start == 6
    assert [sk.dof_names[d] for d in range(*sk.joint_dofs("a2").indices(sk.n_dofs))] == ["a2.Xrotation", "a2.Zrotation"]
    with pytest.raises(KeyError, match=r"'a_tip' is a site, not a joint"):
        sk.joint_dofs("a_tip")
    with pytest.raises(KeyError, match=r"'rooot' not found.*did you mean 'root'"):
        sk.joint_dofs("rooot")


@pytest.mark.parametrize("n, dims, length", [(1, 2, 1.0), (4, 2, 0.5), (7, 3, 1.3), (10, 2, 1.0)])
def test_chain_reach_is_total_length(n, dims, length):
    sk = deik.chain(n, dims=dims, link_length=length)
    assert sk.reach == pytest.approx(n * length, rel=1e-12)
    assert sk.path_length(sk.frame_index("tip")) == pytest.approx(n * length, rel=1e-12)
    assert sk.n_dofs == n * (dims - 1)
    # the reach really is attained: a straight chain puts the tip at distance n * length
    tip = deik.forward_kinematics(sk, np.zeros(sk.n_dofs)).position("tip")
    assert np.linalg.norm(tip) == pytest.approx(sk.reach, rel=1e-12)


def test_arrays_are_read_only_and_fields_frozen():
    sk = build_skeleton(tree_joints(), tree_sites(), segments=[Segment("b", 1.0, (0, 0, 0.1))])
    arrays = {k: v for k, v in vars(sk).items() if isinstance(v, np.ndarray)}
    assert {"parents", "offsets", "lower", "upper", "reference", "site_rotation", "mass_value", "up"} <= set(arrays)
    for name, arr in arrays.items():
        assert not arr.flags.writeable, name
        if arr.size:
            with pytest.raises(ValueError, match="read-only"):
                arr.reshape(-1)[0] = arr.reshape(-1)[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        sk.offsets = np.zeros((sk.n_joints, 3))


def test_build_skeleton_sorts_joints_given_in_any_order():
    joints = tree_joints()
    reference = build_skeleton(joints, tree_sites())
    rng = np.random.default_rng(5)
    pose_by_dof = {n: rng.uniform(-1.0, 1.0) for n in reference.dof_names}
    expected = deik.forward_kinematics(reference, [pose_by_dof[n] for n in reference.dof_names])
    for _ in range(6):
        order = rng.permutation(len(joints))
        sk = build_skeleton([joints[k] for k in order], tree_sites())
        assert sk.parents[0] == -1
        assert all(0 <= sk.parents[k] < k for k in range(1, sk.n_joints))
        for k in range(1, sk.n_joints):
            spec = next(j for j in joints if j.name == sk.joint_names[k])
            assert sk.joint_names[sk.parents[k]] == spec.parent
        # DOFs follow their joints: same frames for the same pose expressed by DOF name
        assert sorted(sk.dof_names) == sorted(reference.dof_names)
        kin = deik.forward_kinematics(sk, [pose_by_dof[n] for n in sk.dof_names])
        for name in reference.frame_names:
            np.testing.assert_allclose(kin.position(name), expected.position(name), atol=1e-12)
            np.testing.assert_allclose(kin.rotation(name), expected.rotation(name), atol=1e-12)
        assert sk.total_mass == pytest.approx(3.5)
        np.testing.assert_allclose(kin.p_world_com, expected.p_world_com, atol=1e-12)


def test_angles_by_joint_round_trip():
    sk = build_skeleton(tree_joints(), tree_sites())
    pose = np.arange(sk.n_dofs, dtype=float) / 10
    split = sk.angles_by_joint(pose)
    assert list(split) == [n for n in sk.joint_names]
    np.testing.assert_array_equal(np.concatenate(list(split.values())), pose)

"""Forward kinematics and centre of mass against independent computations: scipy's Rotation,
hand-computed planar chains, loops over batches, and the compiled kernel FK."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import deik
from deik import Joint, Segment, Site, build_skeleton, euler, hinge, translation
from deik.backends.pack import pack_skeleton
from deik.backends.targets import cpu
from deik.model.rotations import axis_angle_matrix, euler_matrix, rotation_angle

TAIT_BRYAN = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"]
PROPER = ["ZXZ", "XYX", "XZX", "YXY", "YZY", "ZYZ"]
ALL_ORDERS = TAIT_BRYAN + PROPER


@pytest.mark.parametrize("order", ALL_ORDERS)
def test_euler_matrix_matches_scipy_intrinsic(order):
    rng = np.random.default_rng([ord(c) for c in order])
    angles = rng.uniform(-math.pi, math.pi, (16, 3))
    ours = euler_matrix(order, angles)
    theirs = Rotation.from_euler(order.upper(), angles).as_matrix()
    np.testing.assert_allclose(ours, theirs, atol=1e-12)
    # lower case order means the same (intrinsic) to deik
    np.testing.assert_allclose(euler_matrix(order.lower(), angles), theirs, atol=1e-12)


@pytest.mark.parametrize("order", ["X", "Y", "Z", "ZY", "XZ"])
def test_short_euler_orders_match_scipy(order):
    angles = np.random.default_rng(1).uniform(-3, 3, (5, len(order)))
    np.testing.assert_allclose(euler_matrix(order, angles), Rotation.from_euler(order, angles).as_matrix(), atol=1e-12)


def test_euler_matrix_wrong_angle_count():
    with pytest.raises(ValueError, match=r"euler order 'ZXY' needs 3 angles, got 2"):
        euler_matrix("ZXY", np.zeros(2))


def test_axis_angle_matrix_matches_scipy_rotvec():
    rng = np.random.default_rng(2)
    for _ in range(10):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = rng.uniform(-4, 4)
        np.testing.assert_allclose(
            axis_angle_matrix(axis, angle), Rotation.from_rotvec(axis * angle).as_matrix(), atol=1e-12
        )


def test_rotation_angle_matches_scipy_magnitude():
    rng = np.random.default_rng(3)
    a, b = Rotation.random(50, random_state=rng), Rotation.random(50, random_state=rng)
    ours = rotation_angle(a.as_matrix(), b.as_matrix())
    np.testing.assert_allclose(ours, (a.inv() * b).magnitude(), atol=1e-10)
    # tiny angles stay accurate (atan2 form)
    small = Rotation.from_rotvec([1e-9, 0, 0])
    assert rotation_angle(np.eye(3), small.as_matrix()) == pytest.approx(1e-9, rel=1e-6)


@pytest.mark.parametrize("order", ALL_ORDERS)
def test_two_joint_skeleton_with_euler_joint_matches_scipy(order):
    o0, o1, s_off = np.array([0.2, -0.1, 0.5]), np.array([0.0, 0.7, 0.3]), np.array([0.4, 0.1, -0.2])
    sk = build_skeleton(
        [Joint("root", None, tuple(o0), euler(order)), Joint("child", "root", tuple(o1), euler(order))],
        sites=[Site("end", "child", tuple(s_off))],
    )
    rng = np.random.default_rng(len(order) + sum(map(ord, order)))
    for _ in range(5):
        q = rng.uniform(-math.pi, math.pi, 6)
        R0 = Rotation.from_euler(order, q[:3])
        R1 = R0 * Rotation.from_euler(order, q[3:])
        p0 = o0
        p1 = p0 + R0.apply(o1)
        p_end = p1 + R1.apply(s_off)
        kin = deik.forward_kinematics(sk, q)
        np.testing.assert_allclose(kin.position("root"), p0, atol=1e-12)
        np.testing.assert_allclose(kin.position("child"), p1, atol=1e-12)
        np.testing.assert_allclose(kin.position("end"), p_end, atol=1e-12)
        np.testing.assert_allclose(kin.rotation("root"), R0.as_matrix(), atol=1e-12)
        np.testing.assert_allclose(kin.rotation("child"), R1.as_matrix(), atol=1e-12)
        np.testing.assert_allclose(kin.rotation("end"), R1.as_matrix(), atol=1e-12)


def test_planar_three_link_chain_by_hand():
    lengths = [0.7, 1.1, 0.4]
    joints = [Joint("j0", None, (0, 0, 0), hinge((0, 0, 1)))]
    joints += [Joint(f"j{k}", f"j{k - 1}", (lengths[k - 1], 0, 0), hinge((0, 0, 1))) for k in (1, 2)]
    sk = build_skeleton(joints, sites=[Site("tip", "j2", (lengths[2], 0, 0))])
    rng = np.random.default_rng(4)
    for _ in range(10):
        q = rng.uniform(-math.pi, math.pi, 3)
        cum = np.cumsum(q)
        x = np.concatenate([[0.0], np.cumsum(np.array(lengths) * np.cos(cum))])
        y = np.concatenate([[0.0], np.cumsum(np.array(lengths) * np.sin(cum))])
        kin = deik.forward_kinematics(sk, q)
        for k, name in enumerate(["j0", "j1", "j2", "tip"]):
            np.testing.assert_allclose(kin.position(name), [x[k], y[k], 0.0], atol=1e-12)
        c, s = math.cos(cum[-1]), math.sin(cum[-1])
        np.testing.assert_allclose(kin.rotation("tip"), [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=1e-12)


def test_builder_chain_matches_hand_computation_and_point_mass_com():
    sk = deik.chain(5, link_length=0.8)
    q = np.random.default_rng(5).uniform(sk.lower, sk.upper)
    cum = np.cumsum(q)
    xy = np.cumsum(0.8 * np.stack([np.cos(cum), np.sin(cum)], axis=1), axis=0)
    kin = deik.forward_kinematics(sk, q)
    np.testing.assert_allclose(kin.position("tip")[:2], xy[-1], atol=1e-12)
    # unit point masses at the joints: COM is the mean joint position (joint 0 at the origin)
    joints_xy = np.vstack([[0.0, 0.0], xy[:-1]])
    np.testing.assert_allclose(kin.p_world_com[:2], joints_xy.mean(axis=0), atol=1e-12)
    assert kin.p_world_com[2] == pytest.approx(0.0, abs=1e-15)


def test_root_translation_moves_everything():
    sk = build_skeleton(
        [
            Joint("root", None, (0.1, 0.2, 0.3), translation("XYZ", -2, 2) + euler("ZXY")),
            Joint("a", "root", (0, 1, 0), euler("XZ"), mass=1.0),
            Joint("b", "a", (0, 1, 0), hinge((1, 0, 0)), mass=2.0),
        ],
        sites=[Site("tip", "b", (0, 0.5, 0.2))],
    )
    rng = np.random.default_rng(6)
    q = rng.uniform(-1, 1, sk.n_dofs)
    shift = np.array([0.3, -1.2, 0.7])
    moved = q.copy()
    moved[:3] += shift
    k0, k1 = deik.forward_kinematics(sk, q), deik.forward_kinematics(sk, moved)
    np.testing.assert_allclose(k1.p_world_frame, k0.p_world_frame + shift, atol=1e-12)
    np.testing.assert_allclose(k1.R_world_frame, k0.R_world_frame, atol=1e-12)
    np.testing.assert_allclose(k1.p_world_com, k0.p_world_com + shift, atol=1e-12)
    np.testing.assert_allclose(k0.position("root"), np.array([0.1, 0.2, 0.3]) + q[:3], atol=1e-12)


def test_translation_after_rotation_slides_along_the_rotated_axis():
    sk = build_skeleton(
        [Joint("base", None, (1.0, 0, 0), euler("Z") + translation("X", -1, 1)), Joint("arm", "base", (0, 0.5, 0))],
    )
    for angle, slide in [(0.3, 0.4), (-2.0, 0.9), (1.5, -0.6)]:
        R = Rotation.from_euler("Z", angle)
        kin = deik.forward_kinematics(sk, [angle, slide])
        base = np.array([1.0, 0, 0]) + R.apply([slide, 0, 0])
        np.testing.assert_allclose(kin.position("base"), base, atol=1e-12)
        np.testing.assert_allclose(kin.position("arm"), base + R.apply([0, 0.5, 0]), atol=1e-12)


def test_site_offsets_and_rotations():
    R_site = Rotation.from_euler("XYZ", [0.3, -0.5, 1.1])
    sk = build_skeleton(
        [Joint("root", None, (0, 0, 0), euler("YXZ")), Joint("hand", "root", (0.2, 0.6, 0), euler("ZY"))],
        sites=[
            Site("tool", "hand", (0.1, -0.3, 0.25), tuple(map(tuple, R_site.as_matrix()))),
            Site("plain", "root", (0.0, 0.0, 1.0)),
        ],
    )
    q = np.random.default_rng(7).uniform(-2, 2, sk.n_dofs)
    R0 = Rotation.from_euler("YXZ", q[:3])
    R1 = R0 * Rotation.from_euler("ZY", q[3:])
    p1 = R0.apply([0.2, 0.6, 0])
    kin = deik.forward_kinematics(sk, q)
    np.testing.assert_allclose(kin.position("tool"), p1 + R1.apply([0.1, -0.3, 0.25]), atol=1e-12)
    np.testing.assert_allclose(kin.rotation("tool"), (R1 * R_site).as_matrix(), atol=1e-12)
    np.testing.assert_allclose(kin.position("plain"), R0.apply([0, 0, 1.0]), atol=1e-12)
    np.testing.assert_allclose(kin.rotation("plain"), R0.as_matrix(), atol=1e-12)


def test_batch_shapes_equal_a_loop():
    sk = deik.humanoid()
    rng = np.random.default_rng(8)
    q = rng.uniform(sk.lower, sk.upper, (2, 3, sk.n_dofs))
    kin = deik.forward_kinematics(sk, q)
    F = sk.n_frames
    assert kin.p_world_frame.shape == (2, 3, F, 3)
    assert kin.R_world_frame.shape == (2, 3, F, 3, 3)
    assert kin.p_world_com.shape == (2, 3, 3)
    assert kin.position("left_hand").shape == (2, 3, 3)
    assert kin.rotation("head").shape == (2, 3, 3, 3)
    for i in range(2):
        for j in range(3):
            one = deik.forward_kinematics(sk, q[i, j])
            assert one.p_world_frame.shape == (F, 3)
            np.testing.assert_allclose(kin.p_world_frame[i, j], one.p_world_frame, atol=1e-13)
            np.testing.assert_allclose(kin.R_world_frame[i, j], one.R_world_frame, atol=1e-13)
            np.testing.assert_allclose(kin.p_world_com[i, j], one.p_world_com, atol=1e-13)


def test_humanoid_com_is_mass_weighted_average_of_segment_centres():
    sk = deik.humanoid(mass=81.0)
    rng = np.random.default_rng(9)
    poses = rng.uniform(sk.lower, sk.upper, (4, sk.n_dofs))
    kin = deik.forward_kinematics(sk, poses)
    for n in range(len(poses)):
        weighted, total = np.zeros(3), 0.0
        for joint, offset, mass in zip(sk.mass_joint, sk.mass_offset, sk.mass_value):
            name = sk.joint_names[joint]
            point = kin.position(name)[n] + kin.rotation(name)[n] @ offset
            weighted += mass * point
            total += mass
        assert total == pytest.approx(81.0)
        np.testing.assert_allclose(kin.p_world_com[n], weighted / total, atol=1e-12)


def test_massless_skeleton_com_is_nan():
    kin = deik.forward_kinematics(deik.chain(3, mass=0.0), np.zeros(3))
    assert np.isnan(kin.p_world_com).all()


def test_segment_com_offset_rotates_with_its_joint():
    sk = build_skeleton([Joint("root", None, (0, 0, 0), euler("Z"))], segments=[Segment("root", 2.0, (1.0, 0.0, 0.0))])
    kin = deik.forward_kinematics(sk, [math.pi / 2])
    np.testing.assert_allclose(kin.p_world_com, [0.0, 1.0, 0.0], atol=1e-12)


def _kernel_fk(sk, poses, dtype):
    skel = pack_skeleton(sk, dtype)
    N, F = len(poses), sk.n_frames
    R, p = np.empty((N, F * 9), dtype), np.empty((N, F * 3), dtype)
    cpu.forward_kinematics_batch(np.ascontiguousarray(poses, dtype), skel, R, p)
    return R.reshape(N, F, 3, 3), p.reshape(N, F, 3)


def test_kernel_fk_float64_equals_numpy_fk_on_humanoid():
    sk = deik.humanoid()
    poses = np.random.default_rng(10).uniform(sk.lower, sk.upper, (32, sk.n_dofs))
    R, p = _kernel_fk(sk, poses, np.float64)
    kin = deik.forward_kinematics(sk, poses)
    np.testing.assert_allclose(p, kin.p_world_frame, rtol=0, atol=1e-10)
    np.testing.assert_allclose(R, kin.R_world_frame, rtol=0, atol=1e-10)


def test_kernel_fk_float32_is_close_to_numpy_fk():
    sk = deik.humanoid()
    poses = np.random.default_rng(11).uniform(sk.lower, sk.upper, (32, sk.n_dofs))
    R, p = _kernel_fk(sk, poses, np.float32)
    assert p.dtype == np.float32
    kin = deik.forward_kinematics(sk, poses.astype(np.float32).astype(np.float64))
    err = np.abs(p - kin.p_world_frame).max()
    assert err < 1e-5 * sk.reach
    assert np.abs(R - kin.R_world_frame).max() < 1e-5


def test_kernel_fk_on_chain_with_sites_rotations_and_translations():
    R_site = Rotation.from_euler("ZYX", [0.4, 0.2, -0.9]).as_matrix()
    sk = build_skeleton(
        [
            Joint("root", None, (0.1, 0.2, 0.3), translation("XZ", -1, 1) + euler("ZXY") + translation("Y", -1, 1)),
            Joint("a", "root", (0, 1, 0), hinge((1, 1, 0))),
        ],
        sites=[Site("tool", "a", (0.2, 0.1, 0.0), tuple(map(tuple, R_site)))],
    )
    poses = np.random.default_rng(12).uniform(-1, 1, (8, sk.n_dofs))
    R, p = _kernel_fk(sk, poses, np.float64)
    kin = deik.forward_kinematics(sk, poses)
    np.testing.assert_allclose(p, kin.p_world_frame, atol=1e-12)
    np.testing.assert_allclose(R, kin.R_world_frame, atol=1e-12)


@pytest.mark.parametrize("shape", [(4,), (2, 7), ()])
def test_wrong_shape_angles(shape):
    sk = deik.chain(3, dims=3)
    with pytest.raises(ValueError, match=r"angles must have shape \(\.\.\., 6\) for skeleton 'chain3d:3'"):
        deik.forward_kinematics(sk, np.zeros(shape))


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_angles(bad):
    sk = deik.chain(3)
    q = np.zeros((2, 3))
    q[1, 2] = bad
    with pytest.raises(ValueError, match=r"angles contain NaN or infinite values"):
        deik.forward_kinematics(sk, q)

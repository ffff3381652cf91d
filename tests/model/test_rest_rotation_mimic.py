"""Fixed joint rotations (URDF origin rpy) and mimic DOFs: NumPy FK and the kernel FK against
an independent 4x4 homogeneous-matrix computation; validation of bad mimic specs."""

import dataclasses
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import deik
from deik import Joint, Site, build_skeleton
from deik.backends.pack import pack_skeleton
from deik.backends.targets import cpu
from deik.model.joints import ROTATE, TRANSLATE, Dof

R_A = Rotation.from_euler("xyz", [0.3, -0.7, 1.1]).as_matrix()
R_B = Rotation.from_euler("xyz", [-1.2, 0.4, 0.2]).as_matrix()
R_TOOL = Rotation.from_euler("xyz", [0.0, math.pi / 2, 0.0]).as_matrix()


def _rows(R):
    return tuple(map(tuple, R))


def _robot():
    """base -> a (rotated hinge) -> b (prismatic, rotated) -> c (mimics a) -> tool site."""
    return build_skeleton(
        [
            Joint("base", None),
            Joint(
                "a", "base", (0.1, 0.0, 0.3), (Dof(ROTATE, (0.0, 0.0, 1.0), -2, 2, name="j_a"),), rotation=_rows(R_A)
            ),
            Joint(
                "b",
                "a",
                (0.0, 0.2, 0.0),
                (Dof(TRANSLATE, (1.0, 0.0, 0.0), -0.1, 0.4, name="j_b"),),
                rotation=_rows(R_B),
            ),
            Joint("c", "b", (0.0, 0.0, 0.15), (Dof(ROTATE, (0.0, 1.0, 0.0), name="j_c", mimic=("j_a", -0.5, 0.25)),)),
        ],
        sites=[Site("tool", "c", (0.05, 0.0, 0.1), _rows(R_TOOL))],
        up=(0.0, 0.0, 1.0),
    )


def _homogeneous(R=None, p=(0, 0, 0)):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = np.eye(3) if R is None else R, p
    return T


def _expected_tool(q):
    """World 4x4 of the tool, written out joint by joint."""
    qa, qb = q
    qc = -0.5 * qa + 0.25
    T = _homogeneous(p=(0.1, 0.0, 0.3)) @ _homogeneous(R_A) @ _homogeneous(Rotation.from_rotvec([0, 0, qa]).as_matrix())
    T = T @ _homogeneous(p=(0.0, 0.2, 0.0)) @ _homogeneous(R_B) @ _homogeneous(p=(qb, 0.0, 0.0))
    T = T @ _homogeneous(p=(0.0, 0.0, 0.15)) @ _homogeneous(Rotation.from_rotvec([0, qc, 0]).as_matrix())
    return T @ _homogeneous(R_TOOL, (0.05, 0.0, 0.1))


def test_mimic_dof_is_not_a_variable():
    sk = _robot()
    assert sk.dof_names == ("j_a", "j_b")
    assert sk.mimic_names == ("j_c",)
    assert sk.mimic_source.tolist() == [0]


def test_numpy_fk_with_rest_rotations_and_mimic_matches_homogeneous_matrices():
    sk = _robot()
    poses = np.random.default_rng(0).uniform(sk.lower, sk.upper, (20, 2))
    kin = deik.forward_kinematics(sk, poses)
    for q, R, p in zip(poses, kin.rotation("tool"), kin.position("tool")):
        T = _expected_tool(q)
        np.testing.assert_allclose(p, T[:3, 3], atol=1e-12)
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-12)


@pytest.mark.parametrize("dtype,atol", [(np.float64, 1e-12), (np.float32, 2e-6)])
def test_kernel_fk_with_rest_rotations_and_mimic_matches_numpy(dtype, atol):
    sk = _robot()
    poses = np.random.default_rng(1).uniform(sk.lower, sk.upper, (16, 2))
    F = sk.n_frames
    R, p = np.empty((16, F * 9), dtype), np.empty((16, F * 3), dtype)
    cpu.forward_kinematics_batch(np.ascontiguousarray(poses, dtype), pack_skeleton(sk, dtype), R, p)
    kin = deik.forward_kinematics(sk, poses.astype(dtype).astype(np.float64))
    np.testing.assert_allclose(p.reshape(16, F, 3), kin.p_world_frame, atol=atol)
    np.testing.assert_allclose(R.reshape(16, F, 3, 3), kin.R_world_frame, atol=atol)


def test_reach_counts_a_mimic_slide():
    sk = build_skeleton(
        [
            Joint("base", None),
            Joint("slider", "base", (1.0, 0.0, 0.0), (Dof(TRANSLATE, (1.0, 0.0, 0.0), 0.0, 0.5, name="s"),)),
            Joint(
                "follower",
                "slider",
                (1.0, 0.0, 0.0),
                (Dof(TRANSLATE, (1.0, 0.0, 0.0), name="f", mimic=("s", 2.0, 0.1)),),
            ),
        ]
    )
    assert sk.reach == pytest.approx(1.0 + 0.5 + 1.0 + 2.0 * 0.5 + 0.1)


def test_mimic_of_unknown_dof_is_refused():
    with pytest.raises(ValueError, match="mimics unknown DOF 'nope'"):
        build_skeleton([Joint("base", None), Joint("a", "base", dofs=(Dof(ROTATE, (0, 0, 1), mimic=("nope", 1, 0)),))])


def test_mimic_before_a_free_dof_of_its_joint_is_refused():
    dofs = (Dof(ROTATE, (0, 0, 1), name="m", mimic=("x", 1, 0)), Dof(ROTATE, (1, 0, 0), name="x"))
    with pytest.raises(ValueError, match="mimic DOFs must come after its free DOFs"):
        build_skeleton([Joint("base", None, dofs=dofs)])


def test_improper_joint_rotation_is_refused():
    mirror = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, -1.0))
    with pytest.raises(ValueError, match="joint 'a' rotation is not a proper rotation matrix"):
        build_skeleton([Joint("base", None), Joint("a", "base", rotation=mirror)])


def test_non_finite_mimic_multiplier_is_refused():
    sk = _robot()
    with pytest.raises(ValueError, match="mimic DOF 'j_c' needs a finite unit axis"):
        dataclasses.replace(sk, mimic_scale=np.array([np.nan]))


def test_root_box_follows_a_rotated_root_slide():
    quarter = _rows(Rotation.from_rotvec([0, 0, math.pi / 2]).as_matrix())
    sk = build_skeleton([Joint("base", None, dofs=(Dof(TRANSLATE, (1.0, 0.0, 0.0), 0.0, 2.0),), rotation=quarter)])
    lo, hi = sk.root_box()
    np.testing.assert_allclose(lo, [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(hi, [0, 2, 0], atol=1e-12)

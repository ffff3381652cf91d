"""The built-in humanoid: rest pose on the floor, anthropometric mass, symmetry, joint senses."""

import math

import numpy as np
import pytest

from deik.model.humanoid import humanoid
from deik.model.joints import ROTATE
from deik.model.kinematics import forward_kinematics

FOOT_SITES = ("heel", "toe_inner", "toe_outer", "toe_tip")


def rest(skeleton):
    return forward_kinematics(skeleton, np.zeros(skeleton.n_dofs))


def bent(skeleton, dof_name, angle):
    pose = np.zeros(skeleton.n_dofs)
    pose[skeleton.dof_names.index(dof_name)] = angle
    return forward_kinematics(skeleton, pose)


def test_rest_pose_stands_on_the_floor_at_full_height():
    sk = humanoid(height=1.8)
    fk = rest(sk)
    for side in ("left", "right"):
        for site in FOOT_SITES:
            assert abs(fk.position(f"{side}_{site}")[1]) < 1e-12
    assert fk.position("head_top")[1] == pytest.approx(1.8, rel=0.03)


def test_total_mass_and_centre_of_mass():
    sk = humanoid(height=1.75, mass=82.5)
    assert sk.total_mass == pytest.approx(82.5, rel=1e-12)
    fk = rest(sk)
    feet = np.array([fk.position(f"{side}_{site}") for side in ("left", "right") for site in FOOT_SITES])
    com = fk.p_world_com
    assert feet[:, 0].min() < com[0] < feet[:, 0].max()
    assert feet[:, 2].min() < com[2] < feet[:, 2].max()
    assert 0.50 * 1.75 < com[1] < 0.60 * 1.75


def test_rest_pose_is_mirror_symmetric():
    sk = humanoid()
    fk = rest(sk)
    mirror = np.array([-1.0, 1.0, 1.0])
    for name in sk.frame_names:
        if name.startswith("left_"):
            right = fk.position("right_" + name.removeprefix("left_"))
            np.testing.assert_allclose(right, fk.position(name) * mirror, atol=1e-12)
        elif not name.startswith("right_"):
            assert abs(fk.position(name)[0]) < 1e-12, name


def test_mirrored_pose_gives_mirrored_body():
    """The right side's limits and sign conventions mirror the left's (rotations about Y and Z
    flip sign under the x -> -x mirror, those about X do not)."""
    sk = humanoid()
    flips = np.abs(sk.dof_axis[:, 0]) < 0.5
    rng = np.random.default_rng(0)
    left_pose = np.zeros(sk.n_dofs)
    right_pose = np.zeros(sk.n_dofs)
    for k, name in enumerate(sk.dof_names):
        if name.startswith("left_"):
            j = sk.dof_names.index("right_" + name.removeprefix("left_"))
            sign = -1.0 if flips[k] else 1.0
            lo, hi = sorted((sign * sk.lower[k], sign * sk.upper[k]))
            assert (sk.lower[j], sk.upper[j]) == pytest.approx((lo, hi))
            left_pose[k] = rng.uniform(sk.lower[k], sk.upper[k])
            right_pose[j] = sign * left_pose[k]
    left, right = forward_kinematics(sk, left_pose), forward_kinematics(sk, right_pose)
    for name in sk.frame_names:
        if name.startswith("left_"):
            mirrored = right.position("right_" + name.removeprefix("left_")) * [-1.0, 1.0, 1.0]
            np.testing.assert_allclose(mirrored, left.position(name), atol=1e-12)


def test_every_limit_is_finite_and_contains_the_rest_pose():
    sk = humanoid()
    assert np.isfinite(sk.lower).all() and np.isfinite(sk.upper).all()
    assert (sk.lower <= 0).all() and (sk.upper >= 0).all()
    assert (sk.reference == 0).all()
    rotations = sk.dof_kind == ROTATE
    assert (sk.upper[rotations] - sk.lower[rotations] <= 2 * math.pi).all()


def test_knee_bends_the_shin_backwards_and_elbow_brings_the_hand_forward():
    sk = humanoid()
    ankle_rest = rest(sk).position("left_ankle")
    ankle_bent = bent(sk, "left_knee.flexion", 1.0).position("left_ankle")
    assert ankle_bent[2] < ankle_rest[2] - 0.1 and ankle_bent[1] > ankle_rest[1] + 0.05
    hand_rest = rest(sk).position("left_hand")
    hand_bent = bent(sk, "left_elbow.flexion", 1.0).position("left_hand")
    assert hand_bent[2] > hand_rest[2] + 0.1 and hand_bent[1] > hand_rest[1] + 0.05


def test_positions_scale_linearly_with_height():
    small, tall = rest(humanoid(height=1.0)), rest(humanoid(height=2.0))
    np.testing.assert_allclose(tall.p_world_frame, 2.0 * small.p_world_frame, atol=1e-12)
    np.testing.assert_allclose(tall.p_world_com, 2.0 * small.p_world_com, atol=1e-12)


@pytest.mark.parametrize("argument", ["height", "mass"])
@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, math.inf, "tall"])
def test_bad_height_or_mass_is_refused_by_name(argument, value):
    with pytest.raises(ValueError, match=argument):
        humanoid(**{argument: value})

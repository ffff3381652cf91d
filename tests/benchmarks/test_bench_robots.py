"""The robot IK benchmark's targets, its scorer and the chain export the DE peers evaluate.

Runs in the deik venv alone: nothing here needs the peers venv (.venv-peers).
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import deik
from benchmarks.peers.chain_fk import load_chain, tip_errors, tip_pose
from benchmarks.peers.chain_urdf import cut_urdf
from benchmarks.peers.common import load_targets
from benchmarks.robot_targets import (
    CASES,
    export_chain,
    load_case,
    make_targets,
    pose_errors,
    save_targets,
)
from benchmarks.robots import score
from helpers import robot_arm, shared_path


@pytest.fixture(scope="module")
def robots(shared_data):
    return shared_data / "robots"


def test_targets_are_reproducible_from_the_seed(robots, tmp_path):
    a, b = make_targets("panda", 6, seed=3, robots=robots), make_targets("panda", 6, seed=3, robots=robots)
    other = make_targets("panda", 6, seed=4, robots=robots)
    for key in ("q_true", "positions", "rotations", "start"):
        np.testing.assert_array_equal(a[key], b[key])
    assert not np.allclose(a["q_true"], other["q_true"])
    assert ((a["q_true"] >= a["lower"]) & (a["q_true"] <= a["upper"])).all()
    np.testing.assert_allclose(a["start"], (a["lower"] + a["upper"]) / 2)
    save_targets(a, tmp_path / "t.npz")
    back = load_targets(tmp_path / "t.npz")
    assert back["tip"] == "panda_hand_tcp" and back["seed"] == 3
    np.testing.assert_array_equal(back["rotations"], a["rotations"])
    assert list(back["dof_names"]) == [f"panda_joint{k}" for k in range(1, 8)]


@pytest.mark.parametrize("case", list(CASES))
def test_pose_errors_vanish_at_the_true_poses(case, robots):
    t = make_targets(case, 20, seed=1, robots=robots)
    skeleton = load_case(case, robots)[0]
    pos, rot, inside = pose_errors(skeleton, t["tip"], t["q_true"], t["positions"], t["rotations"])
    assert pos.max() < 1e-12 and rot.max() < 1e-12 and inside.all()
    assert score(skeleton, t, t["q_true"], np.full(20, 1e-3))["success_strict"] == 1.0


@pytest.mark.parametrize("case", ["panda", "human"])
def test_pose_errors_match_yourdfpy(case, robots):
    yourdfpy = pytest.importorskip("yourdfpy")
    t = make_targets(case, 8, seed=2, robots=robots)
    skeleton = load_case(case, robots)[0]
    rng = np.random.default_rng(5)
    Q = t["q_true"] + rng.normal(0, 0.05, t["q_true"].shape)
    Q[0, 0] = t["upper"][0] + 0.1  # one joint outside its limit
    pos, rot, inside = pose_errors(skeleton, t["tip"], Q, t["positions"], t["rotations"])
    robot = yourdfpy.URDF.load(t["urdf"], load_meshes=False, build_collision_scene_graph=False)
    for k, q in enumerate(Q):
        robot.update_cfg(dict(zip(t["dof_names"], q)))
        T = robot.get_transform(frame_to=t["tip"], frame_from=t["base"])
        assert pos[k] == pytest.approx(np.linalg.norm(T[:3, 3] - t["positions"][k]), abs=1e-9)
        angle = Rotation.from_matrix(t["rotations"][k].T @ T[:3, :3]).magnitude()
        assert rot[k] == pytest.approx(angle, abs=1e-9)
    np.testing.assert_array_equal(inside, ((Q >= t["lower"]) & (Q <= t["upper"])).all(axis=1))
    assert not inside[0]
    assert (pos > 1e-4).all()


def test_pose_errors_reject_non_finite_rows(robots):
    t = make_targets("iiwa", 3, robots=robots)
    Q = t["q_true"].copy()
    Q[1, 2] = np.nan
    pos, rot, inside = pose_errors(load_case("iiwa", robots)[0], t["tip"], Q, t["positions"], t["rotations"])
    assert np.isinf(pos[1]) and np.isinf(rot[1]) and not inside[1] and inside[[0, 2]].all()


def robot_chain(name: str):
    """A URDF skeleton and tip; together they cover sites, rest rotations, slides and mimics."""
    robots = shared_path("robots")
    if name == "fingers":
        tips = ["panda_leftfinger", "panda_rightfinger"]
        return deik.read_urdf(robots / "panda.urdf", "panda_link0", tips), "panda_rightfinger"
    return load_case(name, robots)[0], CASES[name].tip


CHAINS = {
    "panda": lambda: robot_chain("panda"),
    "human": lambda: robot_chain("human"),
    "fingers": lambda: robot_chain("fingers"),
    "chain20": lambda: (deik.chain(20), "tip"),
    "chain3d": lambda: (deik.chain(6, dims=3), "tip"),
    "robot_arm": lambda: (robot_arm(), "fingertip"),  # built in code: the URDF features without shared/
}
ON_SHARED_ROBOTS = {"panda", "human", "fingers"}


@pytest.mark.parametrize(
    "name", [pytest.param(n, marks=pytest.mark.shared_data) if n in ON_SHARED_ROBOTS else n for n in CHAINS]
)
def test_exported_chain_fk_matches_deik(name, tmp_path):
    skeleton, tip = CHAINS[name]()
    Q = np.random.default_rng(0).uniform(skeleton.lower, skeleton.upper, (40, skeleton.n_dofs))
    kin = deik.forward_kinematics(skeleton, Q)
    np.savez(tmp_path / "chain.npz", **export_chain(skeleton, tip))
    chain = load_chain(tmp_path / "chain.npz")
    R, p = tip_pose(chain, Q)
    np.testing.assert_allclose(p, kin.position(tip), atol=1e-9)
    np.testing.assert_allclose(R, kin.rotation(tip), atol=1e-9)
    pos, rot = tip_errors(chain, Q, kin.position(tip)[0], kin.rotation(tip)[0])
    assert pos[0] < 1e-12 and rot[0] < 1e-7 and pos[1:].min() > 0


@pytest.mark.parametrize("case", list(CASES))
def test_cut_urdf_keeps_deiks_dofs(case, robots, tmp_path):
    skeleton, spec, path = load_case(case, robots)
    joints = cut_urdf(path, spec.base, spec.tip, tmp_path / "cut.urdf")
    assert joints == list(skeleton.dof_names)
    cut = deik.read_urdf(tmp_path / "cut.urdf", spec.base, spec.tip)
    Q = np.random.default_rng(0).uniform(skeleton.lower, skeleton.upper, (5, skeleton.n_dofs))
    np.testing.assert_allclose(
        deik.forward_kinematics(cut, Q).position(spec.tip),
        deik.forward_kinematics(skeleton, Q).position(spec.tip),
        atol=1e-12,
    )


def test_generated_robots_keep_the_kinematics_they_are_made_from(shared_data):
    # the UR5-type arm at zero: the tool lies at the published link lengths' sums (a2 + a3 along
    # x, d4 + d6 across, d1 - d5 up); the continuous Panda moves like the Panda wherever both can
    ur5 = load_case("ur5_wide")[0]
    assert ur5.n_dofs == 6 and np.allclose(ur5.lower, -2 * np.pi) and np.allclose(ur5.upper, 2 * np.pi)
    tool = deik.forward_kinematics(ur5, np.zeros(6)).position("tool0")
    np.testing.assert_allclose(tool, [0.425 + 0.39225, 0.10915 + 0.0823, 0.089159 - 0.09465], atol=1e-9)
    panda, free = load_case("panda")[0], load_case("panda_continuous")[0]
    assert free.dof_names == panda.dof_names and np.allclose(free.upper, np.pi) and np.allclose(free.lower, -np.pi)
    q = np.random.default_rng(2).uniform(panda.lower, panda.upper, (20, panda.n_dofs))
    a, b = deik.forward_kinematics(panda, q), deik.forward_kinematics(free, q)
    np.testing.assert_allclose(a.position("panda_hand_tcp"), b.position("panda_hand_tcp"), atol=1e-12)
    np.testing.assert_allclose(a.rotation("panda_hand_tcp"), b.rotation("panda_hand_tcp"), atol=1e-12)

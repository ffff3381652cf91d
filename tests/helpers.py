"""Helpers shared by the test modules: where the real data is, the compiled evaluation and
Jacobian rows called the way the solver calls them, and built-in skeletons that stand in for the
real files.

Test modules import from here (pyproject puts tests/ on the path), never from each other.
"""

import math
import os
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import deik
from benchmarks.data import shared_data
from deik import Dof, Joint, Site, hinge, translation
from deik.backends.pack import pack_skeleton, pack_terms
from deik.backends.targets import cpu
from deik.model.joints import ROTATE

ROOT = Path(__file__).resolve().parents[1]  # the checkout

# The real BVH clips and URDF robots: shared/data beside the checkout, or $DEIK_SHARED_DATA
# (benchmarks.data, the one lookup of benchmarks and tests); DEIK_SHARED_DATA=/nonexistent runs
# the suite as a clone without them would.
SHARED_DATA = shared_data()
SHARED_DATA_REASON = f"the real test data is not at {SHARED_DATA} (clone beside shared/ or set DEIK_SHARED_DATA)"


class _Running:
    """The test being run, set by conftest: shared_path checks that it carries the shared_data
    marker, so `-m "not shared_data"` never selects a test that reads the real data."""

    test = None
    marked = False


def shared_data_present() -> bool:
    return SHARED_DATA.is_dir()


def shared_path(*parts: str) -> Path:
    """A path inside the real data folder; the calling test skips when the folder is absent.
    Only tests marked `shared_data` (or using the `shared_data` fixture) may call it."""
    if _Running.test is not None and not _Running.marked:
        pytest.fail(f"{_Running.test} reads the real data: mark it @pytest.mark.shared_data or use the fixture")
    if not shared_data_present():
        pytest.skip(SHARED_DATA_REASON)
    return SHARED_DATA.joinpath(*parts)


# --- the compiled kernels, called as the solver calls them ------------------------------------


def kernel_fitness(problem, poses, problem_index=None, dtype=np.float64):
    """(levels (N, L), total (N,), raw (N, T)) from the compiled CPU evaluation."""
    poses = np.ascontiguousarray(np.atleast_2d(poses), dtype)
    N = len(poses)
    idx = np.zeros(N, np.int64) if problem_index is None else np.asarray(problem_index, np.int64)
    table = problem.table
    skel = pack_skeleton(problem.skeleton, dtype)
    terms = pack_terms(table, problem.reference, dtype)
    levels = np.empty((N, table.n_levels), dtype)
    total = np.empty(N, dtype)
    raw = np.empty((N, table.n_terms), dtype)
    cpu.evaluate_poses(poses, idx, skel, terms, levels, total, raw, 3, 2)  # 3 chunks: the parallel path
    return levels, total, raw


def finite_difference_check(sk, goals, poses, step=1e-6):
    """The LM polish's analytic Jacobian rows of every term against central differences of the
    term's residual; every term must have non-zero rows (goals the polish handles only)."""
    problem = deik.Problem(sk, goals)
    skel, terms = pack_skeleton(sk, np.float64), pack_terms(problem.table, problem.reference, np.float64)
    poses = np.ascontiguousarray(poses, np.float64)
    index = np.zeros(len(poses), np.int64)
    for t in range(problem.table.n_terms):
        _, analytic = cpu.residual_rows(poses, index, t, skel, terms)
        numeric = np.zeros_like(analytic)
        for d in range(sk.n_dofs):
            up, down = poses.copy(), poses.copy()
            up[:, d] += step
            down[:, d] -= step
            numeric[:, :, d] = (
                cpu.residual_rows(up, index, t, skel, terms)[0] - cpu.residual_rows(down, index, t, skel, terms)[0]
            ) / (2 * step)
        scale = np.abs(numeric).max()
        assert scale > 0, problem.table.labels[t]
        np.testing.assert_allclose(analytic, numeric, atol=1e-6 * scale, err_msg=problem.table.labels[t])


# --- built-in skeletons that stand in for the real files ---------------------------------------


def _rows(R):
    return tuple(map(tuple, np.asarray(R, float)))


def rpy(roll, pitch, yaw):
    """A URDF origin's rpy as a rotation matrix (fixed axes x, then y, then z)."""
    return _rows(Rotation.from_euler("xyz", [roll, pitch, yaw]).as_matrix())


def robot_arm():
    """A six-DOF arm built in code with what the URDF robots bring: rest rotations on the joint
    origins (rpy), hinges about each joint's z axis and one about an oblique axis, asymmetric
    limits, a prismatic joint, a mimic DOF (no variable of its own), fixed frames on the base (a
    footprint) and a fixed tool frame rotated from its link; z up, a mass on every link."""
    half = math.pi / 2
    joints = [
        Joint("base", None, mass=4.0),
        Joint("shoulder", "base", (0.0, 0.0, 0.33), hinge((0, 0, 1), -2.9, 2.9, label="yaw"), mass=3.0),
        Joint(
            "upper_arm",
            "shoulder",
            (0.0, 0.0, 0.0),
            hinge((0, 0, 1), -1.8, 1.8, label="pitch"),
            mass=2.5,
            rotation=rpy(-half, 0.0, 0.0),
        ),
        Joint(
            "elbow",
            "upper_arm",
            (0.0, -0.32, 0.0),
            hinge((0, 0, 1), -3.0, -0.07, label="pitch"),
            mass=2.0,
            rotation=rpy(half, 0.0, 0.0),
        ),
        Joint("slide", "elbow", (0.08, 0.0, 0.1), translation("Z", 0.0, 0.2), mass=1.0, rotation=rpy(0.3, -0.2, 0.5)),
        Joint(
            "wrist",
            "slide",
            (0.0, 0.0, 0.1),
            hinge((0.0, 0.6, 0.8), -2.9, 2.9, label="roll"),
            mass=1.0,
            rotation=rpy(half, 0.0, 0.0),
        ),
        Joint("flange", "wrist", (0.09, 0.0, 0.0), hinge((0, 0, 1), -0.5, 3.8, label="turn"), mass=0.6),
        Joint(
            "finger",
            "flange",
            (0.0, 0.02, 0.06),
            (Dof(ROTATE, (1.0, 0.0, 0.0), name="finger_joint", mimic=("wrist.roll", -0.5, 0.1)),),
            mass=0.2,
        ),
    ]
    sites = [
        Site("tool", "flange", (0.0, 0.0, 0.11), rpy(0.0, -half, math.pi / 4)),
        Site("fingertip", "finger", (0.0, 0.0, 0.04)),
        *(Site(f"foot{k}", "base", (0.2 * math.cos(a), 0.2 * math.sin(a), 0.0)) for k, a in enumerate((0.0, 2.1, 4.2))),
    ]
    return deik.build_skeleton(joints, sites=sites, up=(0.0, 0.0, 1.0), name="robot_arm")


BUILTIN_SKELETONS = {
    "humanoid": deik.humanoid,
    "chain": lambda: deik.chain(6, dims=3),
    "robot_arm": robot_arm,
}
# Per built-in skeleton: an end frame, a second frame (on the arm: behind the mimic DOF), and sites
# that form a support.
BUILTIN_FRAMES = {
    "humanoid": ("left_hand", "right_knee", ("left_heel", "left_toe_inner", "left_toe_outer", "right_heel")),
    "chain": ("tip", "link3", ("tip",)),
    "robot_arm": ("tool", "fingertip", ("foot0", "foot1", "foot2")),
}


def random_poses(sk, n, seed):
    """n poses drawn uniformly inside the joint limits."""
    return np.random.default_rng(seed).uniform(sk.lower, sk.upper, (n, sk.n_dofs))


FEET = tuple(f"{side}_{site}" for side in ("left", "right") for site in ("heel", "toe_inner", "toe_outer"))


def every_goal_problem(batch=False):
    """The humanoid with one goal of every kind (two comforts), batched over two problems when `batch`."""
    h = deik.humanoid()
    kin = deik.forward_kinematics(h, h.reference)
    shin = 0.5 * (kin.position("left_knee") + kin.position("left_ankle"))
    hand = kin.position("left_hand") + [0.1, 0.2, 0.1]
    ref = None
    if batch:
        hand = np.stack([hand, kin.position("right_hand") + [-0.1, 0.3, 0.2]])
        ref = np.stack([h.reference, np.full(h.n_dofs, 0.05)])
    goals = [
        deik.Position("left_hand", hand, tolerance=0.02),
        deik.Orientation("head", Rotation.from_euler("XYZ", [0.2, -0.3, 0.4]).as_matrix(), level=1, tolerance=0.05),
        deik.Aim("head", kin.position("head") + [0.3, 0.1, 1.0], axis=(0, 0, 2.0), weight=0.5, mu=2.0),
        deik.CentreOfMass(kin.p_world_com + [0.0, -0.1, 0.05]),
        deik.ComOverSupport(kin.position("right_heel"), level=1, tolerance=0.02),
        deik.ComInPolygon(FEET, weight=0.8),
        deik.Comfort("sum", joint_weights="start", level=2, reference=ref),
        deik.Comfort("max", joint_weights={"left_shoulder": 2.0, "spine": 0.5}, weight=-0.3, level=2),
        deik.Obstacle(shin, 0.05, bone_radius=0.02, level=1),
        deik.SelfCollision(level=1),
        deik.Floor(kin.position("left_knee")[1], level=1),
    ]
    return deik.Problem(h, goals, limits="penalty")


# --- README commands -------------------------------------------------------------------------


def readme_commands(markdown: str, language: str = "bash") -> list[str]:
    """The `deik ...` lines of the ```language blocks of `markdown`, continuation lines joined and
    comments dropped, in order."""
    commands = []
    for block in re.findall(rf"```{language}\n(.*?)```", markdown, flags=re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split("  #")[0].strip()
            if line.startswith("deik "):
                commands.append(line)
    return commands


# --- a library task the library tests control ---------------------------------------------


def library_task(payload, progress):
    """A deik.library task for the tests (it runs in the library's worker processes, which import
    this module by name): writes payload["text"] to each of payload["outputs"] atomically and
    returns {"frames": 2}; with payload["mode"] "fail" it fails with a reason, with "hang" it
    opens a progress bar, writes its process id to payload["pid_file"] and waits until it is
    killed."""
    import time

    from deik.io.atomic import write_text_atomically
    from deik.library.jobs import JobFailed

    progress(0, 2)
    if payload.get("mode") == "fail":
        raise JobFailed("this clip is broken on purpose")
    if payload.get("mode") == "hang":
        from tqdm import tqdm

        tqdm(total=1, disable=True)  # a clip's progress bar, whose lock a killed worker once leaked
        write_text_atomically(payload["pid_file"], str(os.getpid()))
        while True:
            time.sleep(0.05)
    for path in payload["outputs"]:
        write_text_atomically(path, payload["text"])
    progress(2, 2)
    return {"frames": 2, "metrics": {"pid": os.getpid()}}


def kill_when_ready(process, ready, timeout: float = 600) -> None:
    """SIGKILL subprocess `process` as soon as the file `ready` (a Path) exists; the process
    must still be running then (it is killed in any case)."""
    import signal
    import time

    try:
        deadline = time.monotonic() + timeout
        while not ready.exists():
            assert process.poll() is None and time.monotonic() < deadline, "the process ended before it was killed"
            time.sleep(0.02)
        process.send_signal(signal.SIGKILL)
        assert process.wait(timeout=60) == -signal.SIGKILL
    finally:
        process.kill()


MESH_ROBOT = """<robot name="arm">
  <material name="grey"><color rgba="0.5 0.5 0.5 1"/></material>
  <link name="base"><visual><geometry><mesh filename="package://arm_description/meshes/base.stl"/></geometry>
    <material name="grey"/></visual></link>
  <link name="upper"><visual><origin xyz="0 0 0.2"/><geometry><mesh filename="../meshes/upper.obj"/></geometry>
    </visual></link>
  <link name="fore"><visual><origin xyz="0 0 0.15" rpy="0.3 0 0"/><geometry><box size="0.08 0.06 0.3"/></geometry>
    <material name="red"><color rgba="1 0 0 1"/></material></visual></link>
  <link name="hand">
    <visual><geometry><mesh filename="package://arm_description/meshes/hand.dae" scale="2 2 2"/></geometry></visual>
    <visual><geometry><mesh filename="package://arm_description/meshes/missing.stl"/></geometry></visual>
  </link>
  <link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="upper"/><origin xyz="0 0 0.05"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3"/></joint>
  <joint name="j2" type="revolute"><parent link="upper"/><child link="fore"/><origin xyz="0 0 0.4" rpy="0 0.5 0"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2"/></joint>
  <joint name="j3" type="revolute"><parent link="fore"/><child link="hand"/><origin xyz="0 0 0.3"/>
    <axis xyz="1 0 0"/><limit lower="-2" upper="2"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="hand"/><child link="tool"/><origin xyz="0 0 0.1"/></joint>
</robot>
"""


def mesh_robot(folder: Path) -> Path:
    """MESH_ROBOT, a four-link arm with a tool frame, written to folder/arm_description/urdf,
    its meshes written by trimesh to .../meshes: the base an STL box, the upper arm an OBJ
    cylinder, the hand a DAE sphere (its second mesh missing); the forearm is a box primitive."""
    import trimesh

    meshes, urdf = folder / "arm_description" / "meshes", folder / "arm_description" / "urdf"
    meshes.mkdir(parents=True)
    urdf.mkdir()
    trimesh.creation.box(extents=(0.2, 0.2, 0.1)).export(meshes / "base.stl")
    trimesh.creation.cylinder(radius=0.05, height=0.4).export(meshes / "upper.obj")
    trimesh.creation.icosphere(radius=0.03).export(meshes / "hand.dae")
    (urdf / "arm.urdf").write_text(MESH_ROBOT)
    return urdf / "arm.urdf"


# --- subprocesses in the CUDA simulator ------------------------------------------------------


def simulator_env(**extra: str) -> dict[str, str]:
    """The environment of a subprocess that runs deik's CUDA kernels in Numba's simulator: this
    checkout's src and root on PYTHONPATH, NUMBA_ENABLE_CUDASIM=1, and tests/simulator, whose
    sitecustomize shortens the GIL switch interval the simulator's threads wait on."""
    path = os.pathsep.join(str(p) for p in (ROOT / "src", ROOT, ROOT / "tests" / "simulator"))
    return {**os.environ, "PYTHONPATH": path, "NUMBA_ENABLE_CUDASIM": "1", **extra}

"""The peer IK libraries, one adapter class each, as benchmarks/peers/README.md describes them.

An adapter is `Peer(urdf, base, tip, dof_names)` on the cut URDF (benchmarks.peers.chain_urdf),
with PACKAGE (its distribution, for the version), `settings` (a dict of what it uses), `fk(q)` ->
tip position (3,) m and rotation (3, 3) for q (D,) in deik's DOF order, and `solve(position,
rotation, start, budget)` -> q (D,): one local attempt from `start` that stops after `budget`
seconds where the library allows. RESTARTS = False: the library restarts by itself (TRAC-IK);
every other adapter runs through common.solve_with_restarts. The loop adapters (PlaCo, Pink,
mink, pybullet) step until the tip is within tolerance, the budget is spent, 500 steps were
made or they stall (common.iterate); their fk is `_set(q)` then `_pose()`.
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET

import numpy as np

from benchmarks.peers.common import BUDGET_S, MAX_ITERATIONS, POS_TOL, ROT_TOL, index_map, iterate, pose_gap

DT, DAMPING, QP_SOLVER = 1.0, 1e-6, "daqp"  # Pink and mink: one full damped Gauss-Newton step


def homogeneous(rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    """The 4x4 transform of a rotation (3, 3) and a position (3,)."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = rotation, position
    return T


def split(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(position (3,), rotation (3, 3)) of a 4x4 transform, copied."""
    return T[:3, 3].copy(), T[:3, :3].copy()


class Loop:
    """An adapter whose library holds the joint state: fk sets it and reads the tip's pose."""

    def fk(self, q: np.ndarray):
        self._set(q)
        return self._pose()

    def loop(self, step, position: np.ndarray, rotation: np.ndarray, budget: float) -> None:
        """Call step() until common.iterate stops it."""
        iterate(step, lambda: pose_gap(self._pose(), position, rotation), budget)


class Ikpy:
    """IKPy: scipy.optimize.least_squares (trust region, joint bounds), no wall-clock budget."""

    PACKAGE = "ikpy"

    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        from ikpy.chain import Chain

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the first read warns that fixed links are active
            links = Chain.from_urdf_file(urdf, base_elements=[base]).links
            mask = [link.joint_type != "fixed" for link in links]
            self.chain = Chain.from_urdf_file(urdf, base_elements=[base], active_links_mask=mask)
        self.idx = index_map([link.name for link in self.chain.links], dof_names)
        self.settings = {
            "call": "inverse_kinematics_frame, orientation_mode='all'",
            "optimizer": "least_squares (IKPy default), SciPy default tolerances and evaluation cap",
            "backend": "numpy, symbolic=True",
            "budget_s": None,
        }

    def _full(self, q: np.ndarray) -> np.ndarray:
        full = np.zeros(len(self.chain.links))
        full[self.idx] = q
        return full

    def fk(self, q: np.ndarray):
        return split(self.chain.forward_kinematics(self._full(q)))

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        T = homogeneous(rotation, position)
        full = self.chain.inverse_kinematics_frame(T, initial_position=self._full(start), orientation_mode="all")
        return np.asarray(full)[self.idx]


class PytorchKinematics:
    """pytorch-kinematics' PseudoInverseIK: a batch of retries (the start and RETRIES - 1 fixed
    in-limit poses) to the strict tolerances, the first converged retry (else the nearest)."""

    PACKAGE = "pytorch-kinematics"
    RETRIES, MAX_ITERATIONS = 10, 50
    RETRY_SEED = 2718  # not 0: the targets are drawn with default_rng(0) and would be among the retries

    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import pytorch_kinematics as pk
        import torch

        torch.set_num_threads(1)
        self.torch, self.pk = torch, pk
        with open(urdf, "rb") as f:
            self.chain = pk.build_serial_chain_from_urdf(f.read(), tip, base).to(dtype=torch.float64)
        order = index_map(self.chain.get_joint_parameter_names(), dof_names)
        self.to_pk, self.to_deik = np.argsort(order), order  # q_pk = q[to_pk]; q = q_pk[to_deik]
        lower, upper = self.chain.low.numpy()[order], self.chain.high.numpy()[order]
        rng = np.random.default_rng(self.RETRY_SEED)
        self.retries = rng.uniform(lower, upper, (self.RETRIES - 1, len(dof_names)))
        self.settings = {
            "solver": "PseudoInverseIK",
            "retries": f"start + {self.RETRIES - 1} uniform in limits (seed {self.RETRY_SEED})",
            "max_iterations": self.MAX_ITERATIONS,
            "early_stopping_any_converged": True,
            "dtype": "float64",
            "torch_threads": 1,
            "budget_s": None,
        }

    def _pk(self, q: np.ndarray):
        return self.torch.as_tensor(np.asarray(q)[..., self.to_pk])

    def fk(self, q: np.ndarray):
        return split(self.chain.forward_kinematics(self._pk(q)[None]).get_matrix()[0].numpy())

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        ik = self.pk.PseudoInverseIK(
            self.chain,
            retry_configs=self._pk(np.vstack([start[None], self.retries])),
            max_iterations=self.MAX_ITERATIONS,
            pos_tolerance=POS_TOL,
            rot_tolerance=ROT_TOL,
            early_stopping_any_converged=True,
        )
        target = self.torch.as_tensor(homogeneous(rotation, position)[None])
        solution = ik.solve(self.pk.Transform3d(matrix=target))
        converged = solution.converged[0].numpy()
        error = (solution.err_pos[0] + solution.err_rot[0]).numpy()
        best = int(np.argmax(converged)) if converged.any() else int(np.argmin(error))
        return solution.solutions[0, best].numpy()[self.to_deik]


class Placo(Loop):
    """PlaCo's KinematicsSolver (QP over joint steps, joint limits on), one soft frame task; the
    floating base it adds masked (fixed at the base link's frame)."""

    PACKAGE = "placo"

    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import placo

        self.robot = placo.RobotWrapper(urdf, placo.Flags.ignore_collisions)
        index_map(list(self.robot.joint_names()), dof_names)
        self.names, self.tip = list(dof_names), tip
        self.solver = placo.KinematicsSolver(self.robot)
        self.solver.mask_fbase(True)
        self.task = self.solver.add_frame_task(tip, np.eye(4))
        self.task.configure(tip, "soft", 1.0, 1.0)
        self.settings = {
            "task": "frame task, soft, position and orientation weight 1",
            "joint limits": "on (PlaCo default)",
            "budget_s": BUDGET_S,
            "max_iterations": MAX_ITERATIONS,
        }

    def _set(self, q: np.ndarray) -> None:
        for name, value in zip(self.names, q):
            self.robot.set_joint(name, float(value))
        self.robot.update_kinematics()

    def _pose(self):
        return split(self.robot.get_T_world_frame(self.tip))

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        self.task.T_world_frame = homogeneous(rotation, position)
        self._set(start)

        def step():
            self.solver.solve(True)
            self.robot.update_kinematics()

        self.loop(step, position, rotation, budget)
        return np.array([self.robot.get_joint(n) for n in self.names])


class QpLoop(Loop):
    """Pink's and mink's loop: `solve_ik` (a FrameTask as a QP with ConfigurationLimit, daqp,
    damping 1e-6: with Pink's default 1e-12 daqp found no solution on a few Panda and iiwa
    targets) then `integrate_inplace`."""

    def _settings(self, task: str) -> dict:
        return {"task": task, "limits": "ConfigurationLimit", "qp_solver": QP_SOLVER, "damping": DAMPING}

    def _solve(self, library, target, start: np.ndarray, position, rotation, budget: float, **options) -> np.ndarray:
        self.task.set_target(target)
        self._set(start)
        configuration = self.configuration

        def step():
            try:
                velocity = library.solve_ik(
                    configuration, [self.task], DT, solver=QP_SOLVER, damping=DAMPING, limits=self.limits, **options
                )
            except self.no_solution:
                raise StopIteration from None
            configuration.integrate_inplace(velocity, DT)

        self.loop(step, position, rotation, budget)
        return configuration.q[self.idx].copy()


class Pink(QpLoop):
    """Pink (Pinocchio) differential IK."""

    PACKAGE = "pin-pink"

    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import pink
        import pinocchio as pin
        from pink.limits import ConfigurationLimit
        from pink.tasks import FrameTask

        self.pin, self.pink, self.no_solution = pin, pink, pink.exceptions.NoSolutionFound
        model = pin.buildModelFromUrdf(urdf)
        index_map(list(model.names), dof_names)
        self.model, self.tip = model, tip
        self.idx = np.array([model.idx_qs[model.getJointId(n)] for n in dof_names])
        self.configuration = pink.Configuration(model, model.createData(), pin.neutral(model))
        self.task = FrameTask(tip, position_cost=1.0, orientation_cost=1.0)
        self.limits = [ConfigurationLimit(model)]
        self.settings = self._settings("FrameTask, position and orientation cost 1")
        self.settings |= {"dt": DT, "budget_s": BUDGET_S, "max_iterations": MAX_ITERATIONS}

    def _set(self, q: np.ndarray) -> None:
        full = self.pin.neutral(self.model)
        full[self.idx] = q
        self.configuration.update(full)

    def _pose(self):
        T = self.configuration.get_transform_frame_to_world(self.tip)
        return T.translation.copy(), T.rotation.copy()

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        target = self.pin.SE3(rotation, position)
        return self._solve(self.pink, target, start, position, rotation, budget, safety_break=False)


def mujoco_xml(urdf: str) -> str:
    """The URDF text with a <mujoco> compiler block that keeps fixed-joint links as bodies (the
    tool frame) and 1 g of mass on massless links (MuJoCo refuses massless moving bodies)."""
    root = ET.parse(urdf).getroot()
    ET.SubElement(ET.SubElement(root, "mujoco"), "compiler", fusestatic="false", discardvisual="true")
    for link in root.findall("link"):
        if link.find("inertial") is None:
            inertial = ET.SubElement(link, "inertial")
            ET.SubElement(inertial, "mass", value="1e-3")
            ET.SubElement(inertial, "inertia", ixx="1e-6", iyy="1e-6", izz="1e-6", ixy="0", ixz="0", iyz="0")
    return ET.tostring(root, encoding="unicode")


class Mink(QpLoop):
    """mink (MuJoCo) differential IK on the cut URDF as MuJoCo reads it (mujoco_xml)."""

    PACKAGE = "mink"

    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import mink
        import mujoco

        self.mink, self.no_solution = mink, mink.NoSolutionFound
        model = mujoco.MjModel.from_xml_string(mujoco_xml(urdf))
        index_map([model.joint(j).name for j in range(model.njnt)], dof_names)
        self.idx = np.array([model.jnt_qposadr[model.joint(n).id] for n in dof_names])
        self.nq, self.tip = model.nq, tip
        self.configuration = mink.Configuration(model)
        self.task = mink.FrameTask(tip, "body", position_cost=1.0, orientation_cost=1.0)
        self.limits = [mink.ConfigurationLimit(model)]
        self.settings = self._settings("FrameTask (body), position and orientation cost 1")
        self.settings |= {"dt": DT, "budget_s": BUDGET_S, "max_iterations": MAX_ITERATIONS}

    def _set(self, q: np.ndarray) -> None:
        full = np.zeros(self.nq)
        full[self.idx] = q
        self.configuration.update(full)

    def _pose(self):
        T = self.configuration.get_transform_frame_to_world(self.tip, "body")
        return T.translation().copy(), T.rotation().as_matrix()

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        mink = self.mink
        target = mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rotation), position)
        return self._solve(mink, target, start, position, rotation, budget)


class Pybullet(Loop):
    """pybullet's calculateInverseKinematics (damped least squares, INNER_ITERATIONS a call) from
    the simulation's joint state, the answer written back and the call repeated; no limits (with
    them pybullet's null-space variant reached 1e-5 m on none of 100 Panda targets)."""

    PACKAGE = "pybullet"
    INNER_ITERATIONS, RESIDUAL = 200, 1e-10

    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import pybullet
        from scipy.spatial.transform import Rotation

        self.pb, self.rotation = pybullet, Rotation
        self.client = pybullet.connect(pybullet.DIRECT)
        self.body = pybullet.loadURDF(urdf, useFixedBase=True, physicsClientId=self.client)
        infos = [
            pybullet.getJointInfo(self.body, j, physicsClientId=self.client)
            for j in range(pybullet.getNumJoints(self.body, physicsClientId=self.client))
        ]
        movable = [i for i in infos if i[2] != pybullet.JOINT_FIXED]
        self.order = index_map([i[1].decode() for i in movable], dof_names)
        self.joints = [movable[k][0] for k in self.order]
        self.tip = next(i[0] for i in infos if i[12].decode() == tip)
        self.settings = {
            "solver": "calculateInverseKinematics (DLS), no null space",
            "maxNumIterations": self.INNER_ITERATIONS,
            "residualThreshold": self.RESIDUAL,
            "outer loop": "write back and call again",
            "budget_s": BUDGET_S,
        }

    def _set(self, q: np.ndarray) -> None:
        for j, v in zip(self.joints, q):
            self.pb.resetJointState(self.body, j, float(v), physicsClientId=self.client)

    def _pose(self):
        state = self.pb.getLinkState(self.body, self.tip, computeForwardKinematics=True, physicsClientId=self.client)
        return np.array(state[4]), self.rotation.from_quat(state[5]).as_matrix()

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        quat = self.rotation.from_matrix(rotation).as_quat()  # x, y, z, w as pybullet wants
        q = np.array(start, dtype=float)
        self._set(q)

        def step():
            out = self.pb.calculateInverseKinematics(
                self.body,
                self.tip,
                position.tolist(),
                quat.tolist(),
                maxNumIterations=self.INNER_ITERATIONS,
                residualThreshold=self.RESIDUAL,
                physicsClientId=self.client,
            )
            q[:] = np.asarray(out)[self.order]
            self._set(q)

        self.loop(step, position, rotation, budget)
        return q


class RoboticsToolbox:
    """The Robotics Toolbox's `ik_LM` (its C++ Levenberg-Marquardt) on the base-to-tip ETS: one
    search per call (slimit 1: the shared restarts do what its own searches would); tol bounds
    E = 0.5 |e|^2, and 5e-11 makes |e| <= 1e-5, which implies the strict level."""

    PACKAGE = "roboticstoolbox-python"
    ILIMIT, SLIMIT, TOL = 30, 1, 5e-11

    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import roboticstoolbox as rtb
        from roboticstoolbox.models.URDF.URDFRobot import URDF_file

        links, name, _ = URDF_file(urdf)
        robot = rtb.Robot(links, name=name)
        joints = sorted((link.jindex, link._joint_name) for link in robot.links if link.isjoint)
        self.idx = index_map([n for _, n in joints], dof_names)  # q_rtb[idx] is q in deik's order
        self.ets = robot.ets(start=base, end=tip)
        self.settings = {
            "call": "ETS(base, tip).ik_LM",
            "ilimit": self.ILIMIT,
            "slimit": self.SLIMIT,
            "tol": f"{self.TOL} on E = 0.5 |e|^2",
            "joint_limits": True,
            "method": "chan, k = 1 (defaults)",
        }

    def _rtb(self, q: np.ndarray) -> np.ndarray:
        full = np.zeros(len(self.idx))
        full[self.idx] = q
        return full

    def fk(self, q: np.ndarray):
        return split(self.ets.fkine(self._rtb(q)).A)

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        T = homogeneous(rotation, position)
        options = {"ilimit": self.ILIMIT, "slimit": self.SLIMIT, "tol": self.TOL, "joint_limits": True}
        return np.asarray(self.ets.ik_LM(T, q0=self._rtb(start), **options).q, dtype=float)[self.idx]


def without_safety_controllers(urdf: str) -> str:
    """The URDF text with every <safety_controller> removed: pytracik 0.0.3 takes their soft
    limits, read as zero, for the joint limits."""
    root = ET.parse(urdf).getroot()
    for joint in root.findall("joint"):
        for element in joint.findall("safety_controller"):
            joint.remove(element)
    return ET.tostring(root, encoding="unicode")


class TracIk:
    """TRAC-IK through pytracik: KDL's Newton solver and an SQP solver racing, with its own
    random restarts within its 5 ms timeout. EPSILON bounds each twist component, so 1e-5 /
    sqrt(3) keeps the position within the strict 1e-5 m. The quaternion comes from SciPy:
    pytracik's own helper fails under numpy 2."""

    PACKAGE = "pytracik"
    RESTARTS = False
    EPSILON, SOLVE_TYPE = POS_TOL / np.sqrt(3), "Speed"

    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import pytracik
        from scipy.spatial.transform import Rotation

        self.pytracik, self.rotation = pytracik, Rotation
        solve_type = getattr(pytracik.SolveType, self.SOLVE_TYPE)
        self.solver = pytracik.TRAC_IK(base, tip, without_safety_controllers(urdf), BUDGET_S, self.EPSILON, solve_type)
        if pytracik.get_num_joints(self.solver) != len(dof_names):
            raise ValueError(f"TRAC-IK's chain has {pytracik.get_num_joints(self.solver)} joints, not {len(dof_names)}")
        self.settings = {
            "solve_type": self.SOLVE_TYPE,
            "timeout_s": BUDGET_S,
            "epsilon": self.EPSILON,
            "restarts": "TRAC-IK's own, random, within the timeout",
            "urdf": "cut, <safety_controller> removed",
        }

    def fk(self, q: np.ndarray):
        return split(np.asarray(self.pytracik.fk(self.solver, np.asarray(q, dtype=float))))

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        x, y, z, w = self.rotation.from_matrix(rotation).as_quat()
        out = self.pytracik.ik(self.solver, np.asarray(start, dtype=float), *map(float, position), x, y, z, w)
        return np.asarray(out[1:], dtype=float)  # out[0] < 0: no solution; the scorer judges the rest


PEERS = {
    "ikpy": Ikpy,
    "pk": PytorchKinematics,
    "placo": Placo,
    "pink": Pink,
    "mink": Mink,
    "pybullet": Pybullet,
    "rtb": RoboticsToolbox,
    "tracik": TracIk,
}

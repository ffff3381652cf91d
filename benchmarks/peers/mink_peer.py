"""mink (MuJoCo) differential IK: a FrameTask solved as a QP with configuration limits.

MuJoCo reads the cut URDF itself, told to keep fixed-joint links as bodies (fusestatic off)
so the tool frame exists; links without <inertial> get 1 g of mass (MuJoCo refuses massless
moving bodies; mass plays no part in IK). The loop is mink's: `solve_ik` then
`integrate_inplace`, until the tip is within tolerance, the 5 ms budget is spent or 500 steps
were made; dt = 1 s (one full damped Gauss-Newton step per iteration), daqp, damping 1e-6.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from benchmarks.peers.common import BUDGET_S, MAX_ITERATIONS, index_map, iterate, pose_gap

PACKAGE = "mink"
DT, DAMPING, QP_SOLVER = 1.0, 1e-6, "daqp"


def mujoco_xml(urdf: str) -> str:
    """The URDF text with a <mujoco> compiler block and a tiny inertial on massless links."""
    root = ET.parse(urdf).getroot()
    ET.SubElement(ET.SubElement(root, "mujoco"), "compiler", fusestatic="false", discardvisual="true")
    for link in root.findall("link"):
        if link.find("inertial") is None:
            inertial = ET.SubElement(link, "inertial")
            ET.SubElement(inertial, "mass", value="1e-3")
            ET.SubElement(inertial, "inertia", ixx="1e-6", iyy="1e-6", izz="1e-6", ixy="0", ixz="0", iyz="0")
    return ET.tostring(root, encoding="unicode")


class Peer:
    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import mink
        import mujoco

        self.mink = mink
        model = mujoco.MjModel.from_xml_string(mujoco_xml(urdf))
        index_map([model.joint(j).name for j in range(model.njnt)], dof_names)
        self.idx = np.array([model.jnt_qposadr[model.joint(n).id] for n in dof_names])
        self.nq, self.tip = model.nq, tip
        self.configuration = mink.Configuration(model)
        self.task = mink.FrameTask(tip, "body", position_cost=1.0, orientation_cost=1.0)
        self.limits = [mink.ConfigurationLimit(model)]
        self.settings = {
            "task": "FrameTask (body), position and orientation cost 1",
            "limits": "ConfigurationLimit",
            "qp_solver": QP_SOLVER,
            "damping": DAMPING,
            "dt": DT,
            "budget_s": BUDGET_S,
            "max_iterations": MAX_ITERATIONS,
        }

    def _set(self, q: np.ndarray) -> None:
        full = np.zeros(self.nq)
        full[self.idx] = q
        self.configuration.update(full)

    def _pose(self):
        T = self.configuration.get_transform_frame_to_world(self.tip, "body")
        return T.translation().copy(), T.rotation().as_matrix()

    def fk(self, q: np.ndarray):
        self._set(q)
        return self._pose()

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        mink = self.mink
        self.task.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rotation), position))
        self._set(start)
        configuration = self.configuration

        def step():
            try:
                velocity = mink.solve_ik(
                    configuration, [self.task], DT, solver=QP_SOLVER, damping=DAMPING, limits=self.limits
                )
            except mink.NoSolutionFound:
                raise StopIteration from None
            configuration.integrate_inplace(velocity, DT)

        iterate(step, lambda: pose_gap(self._pose(), position, rotation), budget)
        return configuration.q[self.idx].copy()

"""TRAC-IK through pytracik: KDL's Newton solver and an SQP solver racing, with random restarts.

`pytracik.TRAC_IK(base, tip, urdf, timeout=0.005, epsilon, Speed)` and `pytracik.ik(solver, start,
x, y, z, qx, qy, qz, qw)`: TRAC-IK restarts from random poses by itself until success or its
5 ms timeout, so it is not wrapped in the benchmark's restarts (RESTARTS = False). epsilon bounds
each of the six twist components, so 1e-5 / sqrt(3) keeps the position error within the strict
1e-5 m (and the rotation far within 1e-4 rad). The URDF it reads has its `<safety_controller>`
elements removed: pytracik 0.0.3 takes their soft limits, read as zero, for the joint limits.
The quaternion is computed here (scipy): pytracik's own helper fails under numpy 2.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
from scipy.spatial.transform import Rotation

from benchmarks.peers.common import BUDGET_S, POS_TOL

PACKAGE = "pytracik"
RESTARTS = False
EPSILON, SOLVE_TYPE = POS_TOL / np.sqrt(3), "Speed"


def without_safety_controllers(urdf: str) -> str:
    """The URDF text with every <safety_controller> removed."""
    root = ET.parse(urdf).getroot()
    for joint in root.findall("joint"):
        for element in joint.findall("safety_controller"):
            joint.remove(element)
    return ET.tostring(root, encoding="unicode")


class Peer:
    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import pytracik

        self.pytracik = pytracik
        self.solver = pytracik.TRAC_IK(
            base, tip, without_safety_controllers(urdf), BUDGET_S, EPSILON, getattr(pytracik.SolveType, SOLVE_TYPE)
        )
        if pytracik.get_num_joints(self.solver) != len(dof_names):
            raise ValueError(f"TRAC-IK's chain has {pytracik.get_num_joints(self.solver)} joints, not {len(dof_names)}")
        self.limits = (
            np.array(pytracik.get_joint_lower_bounds(self.solver)),
            np.array(pytracik.get_joint_upper_bounds(self.solver)),
        )
        self.settings = {
            "solve_type": SOLVE_TYPE,
            "timeout_s": BUDGET_S,
            "epsilon": EPSILON,
            "restarts": "TRAC-IK's own, random, within the timeout",
            "urdf": "cut, <safety_controller> removed",
        }

    def fk(self, q: np.ndarray):
        T = np.asarray(self.pytracik.fk(self.solver, np.asarray(q, dtype=float)))
        return T[:3, 3].copy(), T[:3, :3].copy()

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        x, y, z, w = Rotation.from_matrix(rotation).as_quat()
        out = self.pytracik.ik(self.solver, np.asarray(start, dtype=float), *map(float, position), x, y, z, w)
        return np.asarray(out[1:], dtype=float)  # out[0] < 0: no solution; the scorer judges the rest

"""Robotics Toolbox for Python: `ik_LM`, its C++ Levenberg-Marquardt solver, on the base-to-tip ETS.

The cut URDF is read by the toolbox's URDF reader (`URDF_file`, what the deprecated
`Robot.URDF` calls) into a `Robot`; `robot.ets(start=base, end=tip).ik_LM(T, q0=start,
ilimit=30, slimit=1, tol=5e-11, joint_limits=True)` with its defaults otherwise (Chan's damping,
k = 1, no mask). slimit = 1: one search per call, so the benchmark's shared restarts
(common.solve_with_restarts) do what the toolbox's own random searches would. tol is on
E = 0.5 e^T e (e: position error in m and rotation error in rad): 5e-11 makes |e| <= 1e-5, which
implies the strict 1e-5 m and 1e-4 rad. joint_limits = True rejects an answer outside the limits
(it returns it, marked failed). ik_LM has no wall-clock budget; 30 iterations take ~0.1 ms.
"""

from __future__ import annotations

import numpy as np

from benchmarks.peers.common import BUDGET_S, index_map

PACKAGE = "roboticstoolbox-python"
ILIMIT, SLIMIT, TOL = 30, 1, 5e-11


class Peer:
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
            "ilimit": ILIMIT,
            "slimit": SLIMIT,
            "tol": f"{TOL} on E = 0.5 |e|^2",
            "joint_limits": True,
            "method": "chan, k = 1 (defaults)",
        }

    def _rtb(self, q: np.ndarray) -> np.ndarray:
        full = np.zeros(len(self.idx))
        full[self.idx] = q
        return full

    def fk(self, q: np.ndarray):
        T = self.ets.fkine(self._rtb(q)).A
        return T[:3, 3].copy(), T[:3, :3].copy()

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        target = np.eye(4)
        target[:3, :3], target[:3, 3] = rotation, position
        solution = self.ets.ik_LM(target, q0=self._rtb(start), ilimit=ILIMIT, slimit=SLIMIT, tol=TOL, joint_limits=True)
        return np.asarray(solution.q, dtype=float)[self.idx]

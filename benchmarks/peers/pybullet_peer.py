"""pybullet's calculateInverseKinematics (damped least squares), looped as in its examples.

One call runs up to 200 internal DLS iterations from the joint state held by the simulation;
the loop then writes the answer back into the simulation and calls again until the tip is
within tolerance or the 5 ms budget is spent. Joint limits are not passed: pybullet's
null-space variant (used when limits are given) pulls towards a rest pose and did not reach
1e-5 m on any of 100 Panda targets in our trial, so the plain solver is used and limits are
only checked by the scorer.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from benchmarks.peers.common import BUDGET_S, index_map, iterate, pose_gap

PACKAGE = "pybullet"
INNER_ITERATIONS, RESIDUAL = 200, 1e-10


class Peer:
    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import pybullet

        self.pb = pybullet
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
            "maxNumIterations": INNER_ITERATIONS,
            "residualThreshold": RESIDUAL,
            "outer loop": "write back and call again",
            "budget_s": BUDGET_S,
        }

    def _set(self, q: np.ndarray) -> None:
        for j, v in zip(self.joints, q):
            self.pb.resetJointState(self.body, j, float(v), physicsClientId=self.client)

    def _pose(self):
        state = self.pb.getLinkState(self.body, self.tip, computeForwardKinematics=True, physicsClientId=self.client)
        return np.array(state[4]), Rotation.from_quat(state[5]).as_matrix()

    def fk(self, q: np.ndarray):
        self._set(q)
        return self._pose()

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        quat = Rotation.from_matrix(rotation).as_quat()  # x, y, z, w as pybullet wants
        q = np.array(start, dtype=float)
        self._set(q)

        def step():
            out = self.pb.calculateInverseKinematics(
                self.body,
                self.tip,
                position.tolist(),
                quat.tolist(),
                maxNumIterations=INNER_ITERATIONS,
                residualThreshold=RESIDUAL,
                physicsClientId=self.client,
            )
            q[:] = np.asarray(out)[self.order]
            self._set(q)

        iterate(step, lambda: pose_gap(self._pose(), position, rotation), budget)
        return q

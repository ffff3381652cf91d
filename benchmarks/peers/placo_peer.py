"""PlaCo's KinematicsSolver (QP over joint steps, joint limits on) with one soft frame task.

The loop is PlaCo's documented one: `solver.solve(True)` then `robot.update_kinematics()`,
repeated until the tip is within tolerance, the 5 ms budget is spent or 500 steps were made.
The floating base PlaCo adds is masked (fixed at the identity, the base link's frame).
"""

from __future__ import annotations

import numpy as np

from benchmarks.peers.common import BUDGET_S, MAX_ITERATIONS, index_map, iterate, pose_gap

PACKAGE = "placo"


class Peer:
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
        T = self.robot.get_T_world_frame(self.tip)
        return T[:3, 3].copy(), T[:3, :3].copy()

    def fk(self, q: np.ndarray):
        self._set(q)
        return self._pose()

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        target = np.eye(4)
        target[:3, :3], target[:3, 3] = rotation, position
        self.task.T_world_frame = target
        self._set(start)

        def step():
            self.solver.solve(True)
            self.robot.update_kinematics()

        iterate(step, lambda: pose_gap(self._pose(), position, rotation), budget)
        return np.array([self.robot.get_joint(n) for n in self.names])

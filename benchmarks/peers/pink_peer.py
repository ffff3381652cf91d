"""Pink (Pinocchio) differential IK: a FrameTask solved as a QP with configuration limits.

Its documented loop: `solve_ik` gives a velocity, `integrate_inplace` applies it; repeated until
the tip is within tolerance, the 5 ms budget is spent or 500 steps were made. dt = 1 s makes
each step one full (damped) Gauss-Newton step (the task gain is 1); no velocity limit is used.
QP solver daqp; Tikhonov damping 1e-6 (with pink's default 1e-12, daqp reported no solution on
a few Panda and iiwa targets).
"""

from __future__ import annotations

import numpy as np

from benchmarks.peers.common import BUDGET_S, MAX_ITERATIONS, index_map, iterate, pose_gap

PACKAGE = "pin-pink"
DT, DAMPING, QP_SOLVER = 1.0, 1e-6, "daqp"


class Peer:
    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import pink
        import pinocchio as pin
        from pink.limits import ConfigurationLimit
        from pink.tasks import FrameTask

        self.pin, self.pink = pin, pink
        model = pin.buildModelFromUrdf(urdf)
        index_map(list(model.names), dof_names)
        self.model, self.tip = model, tip
        self.idx = np.array([model.idx_qs[model.getJointId(n)] for n in dof_names])
        self.configuration = pink.Configuration(model, model.createData(), pin.neutral(model))
        self.task = FrameTask(tip, position_cost=1.0, orientation_cost=1.0)
        self.limits = [ConfigurationLimit(model)]
        self.settings = {
            "task": "FrameTask, position and orientation cost 1",
            "limits": "ConfigurationLimit",
            "qp_solver": QP_SOLVER,
            "damping": DAMPING,
            "dt": DT,
            "budget_s": BUDGET_S,
            "max_iterations": MAX_ITERATIONS,
        }

    def _set(self, q: np.ndarray) -> None:
        full = self.pin.neutral(self.model)
        full[self.idx] = q
        self.configuration.update(full)

    def _pose(self):
        T = self.configuration.get_transform_frame_to_world(self.tip)
        return T.translation.copy(), T.rotation.copy()

    def fk(self, q: np.ndarray):
        self._set(q)
        return self._pose()

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        self.task.set_target(self.pin.SE3(rotation, position))
        self._set(start)
        configuration = self.configuration

        def step():
            try:
                velocity = self.pink.solve_ik(
                    configuration,
                    [self.task],
                    DT,
                    solver=QP_SOLVER,
                    damping=DAMPING,
                    limits=self.limits,
                    safety_break=False,
                )
            except self.pink.exceptions.NoSolutionFound:
                raise StopIteration from None
            configuration.integrate_inplace(velocity, DT)

        iterate(step, lambda: pose_gap(self._pose(), position, rotation), budget)
        return configuration.q[self.idx].copy()

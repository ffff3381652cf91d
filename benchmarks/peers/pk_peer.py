"""pytorch-kinematics: PseudoInverseIK (batched damped least squares, retries) on the CPU.

Used as its README shows: a batch of retry configurations solved together, here the start pose
plus 9 in-limit configurations drawn once (seed 2718); at most 50 iterations (its default), pose
tolerances 1e-5 m / 1e-4 rad, stop as soon as any retry converged, joint limits enforced
(its default). float64, one torch thread. The returned pose is the first converged retry, else
the one with the smallest position + rotation error. No wall-clock budget.
"""

from __future__ import annotations

import numpy as np

from benchmarks.peers.common import BUDGET_S, POS_TOL, ROT_TOL, index_map

PACKAGE = "pytorch-kinematics"
RETRIES, MAX_ITERATIONS = 10, 50
RETRY_SEED = 2718  # not 0: the targets are drawn with default_rng(0) and would be among the retries


class Peer:
    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import pytorch_kinematics as pk
        import torch

        torch.set_num_threads(1)
        self.torch, self.pk = torch, pk
        with open(urdf, "rb") as f:
            self.chain = pk.build_serial_chain_from_urdf(f.read(), tip, base).to(dtype=torch.float64)
        order = index_map(self.chain.get_joint_parameter_names(), dof_names)
        self.to_pk, self.to_deik = np.argsort(order), order  # q_pk = q[to_pk]; q = q_pk[to_deik]
        lower = self.chain.low.numpy()[order]
        upper = self.chain.high.numpy()[order]
        self.retries = np.random.default_rng(RETRY_SEED).uniform(lower, upper, (RETRIES - 1, len(dof_names)))
        self.settings = {
            "solver": "PseudoInverseIK",
            "retries": f"start + {RETRIES - 1} uniform in limits (seed {RETRY_SEED})",
            "max_iterations": MAX_ITERATIONS,
            "early_stopping_any_converged": True,
            "dtype": "float64",
            "torch_threads": 1,
            "budget_s": None,
        }

    def _pk(self, q: np.ndarray):
        return self.torch.as_tensor(np.asarray(q)[..., self.to_pk])

    def fk(self, q: np.ndarray):
        T = self.chain.forward_kinematics(self._pk(q)[None]).get_matrix()[0].numpy()
        return T[:3, 3].copy(), T[:3, :3].copy()

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        configs = self._pk(np.vstack([start[None], self.retries]))
        ik = self.pk.PseudoInverseIK(
            self.chain,
            retry_configs=configs,
            max_iterations=MAX_ITERATIONS,
            pos_tolerance=POS_TOL,
            rot_tolerance=ROT_TOL,
            early_stopping_any_converged=True,
        )
        target = np.eye(4)
        target[:3, :3], target[:3, 3] = rotation, position
        solution = ik.solve(self.pk.Transform3d(matrix=self.torch.as_tensor(target[None])))
        converged = solution.converged[0].numpy()
        error = (solution.err_pos[0] + solution.err_rot[0]).numpy()
        best = int(np.argmax(converged)) if converged.any() else int(np.argmin(error))
        return solution.solutions[0, best].numpy()[self.to_deik]

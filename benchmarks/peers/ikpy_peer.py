"""IKPy: scipy.optimize.least_squares (trust region, joint bounds) on position and rotation.

`inverse_kinematics_frame(T, initial_position=start, orientation_mode="all")` with IKPy's
defaults: numpy backend, symbolic link matrices, SciPy's default stopping (ftol = xtol = 1e-8,
at most 100 x D residual evaluations). IKPy has no wall-clock budget, so a solve takes what it
takes. Fixed joints are inactive links.
"""

from __future__ import annotations

import warnings

import numpy as np

from benchmarks.peers.common import BUDGET_S, index_map

PACKAGE = "ikpy"


class Peer:
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
        T = self.chain.forward_kinematics(self._full(q))
        return T[:3, 3].copy(), T[:3, :3].copy()

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = BUDGET_S):
        target = np.eye(4)
        target[:3, :3], target[:3, 3] = rotation, position
        full = self.chain.inverse_kinematics_frame(target, initial_position=self._full(start), orientation_mode="all")
        return np.asarray(full)[self.idx]

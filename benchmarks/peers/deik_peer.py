"""deik itself as a peer process: a reused `deik.Solver` with benchmarks.robots' settings.

Run by benchmarks.robots --before TREE with the main venv's Python and TREE/src first on the
path, so an older deik (a checkout of an earlier commit) takes turns with the current one and
the peers on the same chunks of targets: before and after, measured side by side in one run.
deik restarts by itself (RESTARTS = False); target k is solved with seed k, as in robots.py.
"""

from __future__ import annotations

import numpy as np

PACKAGE = "deik"
RESTARTS = False
SETTINGS = {"population": 32, "polish_count": 32, "generations": 2000, "patience": 50, "dtype": "float64"}
STRICT = (1e-5, 1e-4)  # m, rad: the tolerances robots.py scores


class Peer:
    def __init__(self, urdf: str, base: str, tip: str, dof_names: list[str]):
        import deik

        self.deik, self.tip = deik, tip
        self.skeleton = deik.read_urdf(urdf, base, tip)
        if list(self.skeleton.dof_names) != list(dof_names):
            raise ValueError(f"deik reads DOFs {list(self.skeleton.dof_names)}, the targets have {dof_names}")
        at_rest = deik.forward_kinematics(self.skeleton, self.skeleton.reference)
        goals = [
            deik.Position(tip, at_rest.position(tip), tolerance=STRICT[0]),
            deik.Orientation(tip, at_rest.rotation(tip), tolerance=STRICT[1]),
        ]
        self.solver = deik.Solver(deik.Problem(self.skeleton, goals), **SETTINGS)
        self.labels = self.solver.problem.table.labels
        self.count = 0
        self.settings = {"call": "deik.Solver(problem, **settings).solve(targets, initial, seed)", **SETTINGS}

    def fk(self, q: np.ndarray):
        kin = self.deik.forward_kinematics(self.skeleton, q)
        return kin.position(self.tip), kin.rotation(self.tip)

    def solve(self, position: np.ndarray, rotation: np.ndarray, start: np.ndarray, budget: float = 0.0):
        targets = {self.labels[0]: position, self.labels[1]: rotation}
        result = self.solver.solve(targets, initial=np.asarray(start, dtype=float)[None], seed=self.count)
        self.count += 1
        return result.angles

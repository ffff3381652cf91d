"""Solve 6-D targets of a 7-joint arm twice with one Solver on the device in argv[1] (float64) and
print, as JSON, the answers and, on the GPU, what the second solve moved between host and device.

Used by tests/backends/test_cuda.py in subprocesses (the CUDA simulator needs its own process).
"""

import json
import sys

import numpy as np

import deik

arm = deik.chain(7, dims=3)
rng = np.random.default_rng(4)
kin = deik.forward_kinematics(arm, rng.uniform(-0.4, 0.4, (2, 3, arm.n_dofs)))
positions, rotations = kin.position("tip"), kin.rotation("tip")
problem = deik.Problem(
    arm,
    [
        deik.Position("tip", positions[0], tolerance=1e-4),
        deik.Orientation("tip", rotations[0], tolerance=1e-3),
    ],
)
solver = deik.Solver(problem, population=16, dtype="float64", device=sys.argv[1], seed=3)
start = np.zeros(arm.n_dofs)  # the arm's rest pose, near every target: the first polish meets them all
first = solver.solve(initial=start)
backend = solver._engine.backend
before = dict(vars(backend.traffic)) if hasattr(backend, "traffic") else {}
second = solver.solve({"position tip": positions[1], "orientation tip": rotations[1]}, initial=start)
after = dict(vars(backend.traffic)) if hasattr(backend, "traffic") else {}
moved = {key: after[key] - before[key] for key in after}
engine = solver._engine

# a third solve whose last target the arm cannot meet (its tip at the edge of reach, turned as the
# other targets ask): the first polish meets the other two, and only that problem's rows come back
# from the launches of generations that follow
far = positions[1].copy()
far[2] = [0.0, 0.0, 6.95]
goals = [deik.Position("tip", far, tolerance=1e-4), deik.Orientation("tip", rotations[1], tolerance=1e-3)]
straggler = deik.Solver(
    deik.Problem(arm, goals),
    population=16,
    dtype="float64",
    device=sys.argv[1],
    seed=3,
    generations=6,
    patience=100,
)
straggler.solve(initial=start)
back = straggler._engine.backend
before_third = dict(vars(back.traffic)) if hasattr(back, "traffic") else {}
third = straggler.solve(initial=start)
after_third = dict(vars(back.traffic)) if hasattr(back, "traffic") else {}
print(
    json.dumps(
        {
            "converged": [bool(c) for c in first.converged] + [bool(c) for c in second.converged],
            "angles": [np.asarray(first.angles).tolist(), np.asarray(second.angles).tolist()],
            "generations": [np.asarray(first.generations).tolist(), np.asarray(second.generations).tolist()],
            "moved": moved,
            "target_bytes": int(engine.terms.params.nbytes),
            "seed_bytes": int(len(positions[1]) * arm.n_dofs * 8),
            "answer_bytes": int(getattr(backend, "host_answers", np.empty(0)).nbytes),
            "third": {
                "converged": [bool(c) for c in third.converged],
                "generations": np.asarray(third.generations).tolist(),
                "angles": np.asarray(third.angles).tolist(),
                "moved": {key: after_third[key] - before_third[key] for key in after_third},
            },
        }
    )
)

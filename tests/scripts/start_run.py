"""Run Engine.start on a small batch whose problems stop once met (the lazy first population and
the polish that converges on a copy) on the device named in argv[1], float64, and print the
state as JSON.

Used by tests/backends/test_cuda.py in subprocesses (the CUDA simulator needs its own process).
Problem 0 has nine residual rows for eight DOFs (the polish solves the normal equations),
problem 1 only the tip's three (its other goals are inactive: the m x m dual step), and problem
2's elbow target is out of reach, so it needs generations, polish rounds and a restart.
"""

import json
import sys

import numpy as np

import deik

chain = deik.chain(4, dims=3)
rng = np.random.default_rng(1)
kin = deik.forward_kinematics(chain, rng.uniform(-2, 2, (3, chain.n_dofs)))
tips, elbows, rotations = kin.position("tip"), kin.position("link2"), kin.rotation("link3")
elbows[2] = -0.5 * tips[2]
on = np.array([True, False, True])
problem = deik.Problem(
    chain,
    [
        deik.Position("tip", tips, tolerance=1e-6),
        deik.Position("link2", elbows, tolerance=1e-6, active=on),
        deik.Orientation("link3", rotations, tolerance=1e-5, active=on),
    ],
)
settings = deik.Settings(population=8, dtype="float64", device=sys.argv[1], patience=3, polish_every=2, restarts=1)
state = deik.Engine(problem, settings).start(12, initial=np.zeros(chain.n_dofs))
print(
    json.dumps(
        {
            "pop": state.pop.tolist(),
            "raw": state.raw.tolist(),
            "generations": state.generations.tolist(),
            "converged": state.converged.tolist(),
            "restarts": state.restarts.tolist(),
            "history": state.history.tolist(),
        }
    )
)

"""Run a small two-problem solve on the device named in argv[1] and print the state as JSON.

Used by tests/backends/test_cuda.py in subprocesses (the CUDA simulator needs its own process).
argv: device (cpu|gpu), dtype (float32|float64), LM polish iterations. The third problem's
target is out of reach, so it stagnates and restarts.
"""

import json
import sys

import numpy as np

import deik

device, dtype, polish = sys.argv[1], sys.argv[2], int(sys.argv[3])
chain = deik.chain(3)
rng = np.random.default_rng(0)
kin = deik.forward_kinematics(chain, rng.uniform(-2, 2, (3, 3)))
tips, elbows = kin.position("tip"), kin.position("link2")
elbows[2] = -0.5 * tips[2]  # problem 2 cannot put the elbow there and the tip at its target
problem = deik.Problem(
    chain,
    [
        deik.Position("tip", tips, tolerance=1e-3),
        deik.Position("link2", elbows, tolerance=1e-3),
        deik.Comfort(weight=0.1, level=1),
    ],
)
settings = deik.Settings(
    population=8, dtype=dtype, device=device, patience=3, polish=polish, polish_every=3, islands=2, migration=2
)
engine = deik.Engine(problem, settings)
state = engine.run(engine.init(), 24)
print(
    json.dumps(
        {
            "pop": state.pop.tolist(),
            "generation": state.generation,
            "generations": state.generations.tolist(),
            "history": state.history.tolist(),
            "best": state.best.tolist(),
            "raw": state.raw.tolist(),
            "rates": state.rates.tolist(),
            "restarts": state.restarts.tolist(),
        }
    )
)

"""Run a small two-problem solve on the device named in argv[1] and print the state as JSON.

Used by tests/test_cuda.py in subprocesses (the CUDA simulator needs its own process).
argv: device (cpu|gpu), dtype (float32|float64).
"""

import json
import sys

import numpy as np

import deik

device, dtype = sys.argv[1], sys.argv[2]
chain = deik.chain(3)
rng = np.random.default_rng(0)
targets = deik.forward_kinematics(chain, rng.uniform(-2, 2, (2, 3))).position("tip")
problem = deik.Problem(chain, [deik.Position("tip", targets), deik.Comfort(weight=0.1, level=1)])
engine = deik.Engine(problem, deik.Settings(population=8, dtype=dtype, device=device, patience=3))
state = engine.run(engine.init(), 6)
print(json.dumps({
    "pop": state.pop.tolist(), "generation": state.generation, "generations": state.generations.tolist(),
    "history": state.history.tolist(), "best": state.best.tolist(), "raw": state.raw.tolist(),
}))

"""Run a tiny humanoid solve with a SelfCollision goal on the device named in argv[1] (float64,
no polish) and print its final population and raw errors as JSON.

Used by tests/backends/test_cuda.py in subprocesses (the CUDA simulator needs its own process).
"""

import json
import sys

import deik

h = deik.humanoid()
target = deik.forward_kinematics(h, h.reference).position("chest")
problem = deik.Problem(h, [deik.SelfCollision(margin=0.01), deik.Position("left_hand", target, level=1)])
settings = deik.Settings(population=8, dtype="float64", device=sys.argv[1], polish=0, patience=50)
engine = deik.Engine(problem, settings)
state = engine.run(engine.init(), 3)
print(json.dumps({"pop": state.pop.tolist(), "raw": state.raw.tolist()}))

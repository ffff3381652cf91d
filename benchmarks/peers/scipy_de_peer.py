"""scipy.optimize.differential_evolution, vectorised, on an exported chain (NumPy FK, float64).

SciPy's defaults (best1bin, population 15 x D, mutation dithered in [0.5, 1), recombination
0.7, Latin hypercube start inside the joint limits) except: `vectorized=True` (one call
evaluates the whole population through benchmarks.peers.chain_fk; SciPy then updates
'deferred'), `polish=False`, `tol=0` (no early stop on population spread), and a callback that
stops once the best member meets the error thresholds. Evaluations are counted in the
objective (one per pose).
"""

from __future__ import annotations

import time

from benchmarks.peers.chain_fk import tip_errors

PACKAGE = "scipy"
SETTINGS = {
    "strategy": "best1bin",
    "population": "15 x D",
    "mutation": [0.5, 1.0],
    "recombination": 0.7,
    "vectorized": True,
    "updating": "deferred",
    "polish": False,
    "tol": 0,
    "dtype": "float64",
}


def make_solver(chain: dict, pose: bool, tolerances, max_generations: int):
    """solve(position (3,), rotation (3, 3), seed) -> {angles (D,), seconds, evaluations,
    generations} for one run to the thresholds (or max_generations)."""
    from scipy.optimize import differential_evolution

    pos_tol, rot_tol = tolerances
    bounds = list(zip(chain["lower"], chain["upper"]))

    def solve(position, rotation, seed: int) -> dict:
        evaluations = [0]

        def objective(X):  # X (D, S): SciPy's vectorised layout
            evaluations[0] += X.shape[1]
            pos, rot = tip_errors(chain, X.T, position, rotation)
            return pos + rot if pose else pos

        def callback(intermediate_result):
            pos, rot = tip_errors(chain, intermediate_result.x[None], position, rotation)
            return bool(pos[0] < pos_tol and (not pose or rot[0] < rot_tol))

        t0 = time.perf_counter()
        result = differential_evolution(
            objective,
            bounds,
            maxiter=max_generations,
            tol=0,
            polish=False,
            vectorized=True,
            updating="deferred",
            rng=seed,
            callback=callback,
        )
        return {
            "angles": result.x.tolist(),
            "seconds": time.perf_counter() - t0,
            "evaluations": evaluations[0],
            "generations": int(result.nit),
        }

    return solve

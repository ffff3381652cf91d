"""The DE peers on a chain exported by benchmarks.robot_targets.export_chain, its FK in
benchmarks.peers.chain_fk: `make_solver(chain, pose, tolerances, max_generations)` ->
solve(position (3,), rotation (3, 3), seed) -> {angles (D,), seconds, evaluations, generations}
for one run to the thresholds (or max_generations); SETTINGS and PACKAGE per peer in DE_PEERS.

- scipy.optimize.differential_evolution, vectorised (NumPy FK, float64): SciPy's defaults
  (best1bin, population 15 x D, mutation dithered in [0.5, 1), recombination 0.7, Latin
  hypercube start inside the joint limits) except `vectorized=True` (one call evaluates the
  whole population; SciPy then updates 'deferred'), `polish=False`, `tol=0` (no early stop on
  population spread), and a callback that stops once the best member meets the thresholds.
  Evaluations are counted in the objective (one per pose).
- evosax's DifferentialEvolution (JAX, CPU, jax.numpy FK, float32): evosax's default parameters
  (elitism: best/1/bin, crossover 0.9, differential weight 0.8), population 15 x D (SciPy's
  default size; evosax has none), the first population uniform in the joint limits, trial
  vectors clipped to the limits (evosax's DE has no bounds). The whole run, ask -> FK -> tell
  until the best member meets the thresholds or max_generations, is one jax.lax.while_loop
  under jax.jit, compiled on a warm-up run that is not timed.
"""

from __future__ import annotations

import time

from benchmarks.peers.chain_fk import tip_errors

POPULATION_PER_DOF = 15
SCIPY_SETTINGS = {
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
EVOSAX_SETTINGS = {
    "algorithm": "DifferentialEvolution",
    "population": f"{POPULATION_PER_DOF} x D",
    "params": "evosax defaults (elitism, crossover_rate 0.9, differential_weight 0.8)",
    "bounds": "clip",
    "loop": "jax.lax.while_loop under jit",
    "dtype": "float32",
}


def scipy_solver(chain: dict, pose: bool, tolerances, max_generations: int):
    """SciPy's solver (module notes)."""
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


def evosax_solver(chain: dict, pose: bool, tolerances, max_generations: int):
    """evosax's solver (module notes)."""
    import jax
    import jax.numpy as jnp
    from evosax.algorithms import DifferentialEvolution

    pos_tol, rot_tol = tolerances
    lower, upper = jnp.asarray(chain["lower"]), jnp.asarray(chain["upper"])
    dofs = len(chain["lower"])
    population = POPULATION_PER_DOF * dofs
    es = DifferentialEvolution(population_size=population, solution=jnp.zeros(dofs))
    params = es.default_params

    def fitness(X, position, rotation):
        pos, rot = tip_errors(chain, X, position, rotation, jnp)
        return pos + rot if pose else pos

    def reached(x, position, rotation):
        pos, rot = tip_errors(chain, x[None], position, rotation, jnp)
        return (pos[0] < pos_tol) & ((rot[0] < rot_tol) | (not pose))

    @jax.jit
    def run(key, position, rotation):
        key, first, init = jax.random.split(key, 3)
        X = jax.random.uniform(first, (population, dofs), minval=lower, maxval=upper)
        state = es.init(init, X, fitness(X, position, rotation), params)

        def going(carry):
            state, _, generation = carry
            return (generation < max_generations) & ~reached(state.best_solution, position, rotation)

        def step(carry):
            state, key, generation = carry
            key, ask, tell = jax.random.split(key, 3)
            X, state = es.ask(ask, state, params)
            X = jnp.clip(X, lower, upper)
            state, _ = es.tell(tell, X, fitness(X, position, rotation), state, params)
            return state, key, generation + 1

        state, _, generations = jax.lax.while_loop(going, step, (state, key, 0))
        return state.best_solution, generations

    def solve(position, rotation, seed: int) -> dict:
        t0 = time.perf_counter()
        best, generations = run(jax.random.key(seed), jnp.asarray(position), jnp.asarray(rotation))
        best.block_until_ready()
        seconds = time.perf_counter() - t0
        return {
            "angles": [float(v) for v in best],
            "seconds": seconds,
            "evaluations": population * (int(generations) + 1),
            "generations": int(generations),
        }

    return solve


DE_PEERS = {  # name: (distribution, settings, make_solver)
    "scipy_de": ("scipy", SCIPY_SETTINGS, scipy_solver),
    "evosax": ("evosax", EVOSAX_SETTINGS, evosax_solver),
}

"""For researchers: compare Differential Evolution settings on the paper's benchmark, a 20-link
planar chain whose tip reaches a point (Kenwright, Fig. 2), counted converged within 0.2 % of the
chain's reach (the paper counts 1 %; stricter, the settings differ more).

    python examples/compare_de_settings.py [TARGETS [PLOT.png]]

Each setting solves the same batch of targets (the tip positions of random poses within the
limits, so every one is reachable) in one call; every problem of a batch draws its own random
stream. The table gives the share that converged, the generations they took (median and
largest) and the wall time; PLOT.png (needs deik[viz]) draws the median best fitness per
generation. `deik experiments fig2 --out DIR` reproduces the paper's own figure.
"""

import sys

import numpy as np

import deik
from deik.viz.text import format_table

LINKS, POPULATION, GENERATIONS = 20, 100, 500
SHARE = 0.002  # of the reach: converged within 0.2 %
FLOOR = 1e-9  # the plot's lowest fitness
SETTINGS = {
    "paper: rand/1/bin, F 0.5, CR 0.5": deik.Settings.paper(population=POPULATION, generations=GENERATIONS),
    "current-to-best/1/bin, jDE, no polish": deik.Settings(
        population=POPULATION, generations=GENERATIONS, polish=0, restarts=0
    ),
    "deik's default: the same + LM polish": deik.Settings(population=POPULATION, generations=GENERATIONS),
}


def reachable_targets(chain, count: int, seed: int) -> np.ndarray:
    """(count, 3) tip positions of random poses within the chain's limits."""
    angles = np.random.default_rng(seed).uniform(chain.lower, chain.upper, (count, chain.n_dofs))
    return deik.forward_kinematics(chain, angles).position("tip")


def main(count: int, plot: str | None) -> None:
    chain = deik.chain(LINKS)
    tolerance = SHARE * LINKS
    problem = deik.Problem(chain, [deik.Position("tip", reachable_targets(chain, count, seed=0), tolerance=tolerance)])
    rows, curves = [], {}
    for name, settings in SETTINGS.items():
        result = deik.solve(problem, settings, seed=1)
        done = result.generations[result.converged]
        rows.append(
            [
                name,
                f"{result.converged.mean():.0%}",
                f"{np.median(done):.0f} / {done.max()}" if done.size else "-",
                f"{result.wall_time:.2f} s",
            ]
        )
        # each problem's best fitness per generation, kept at its last value once it stopped (NaN there);
        # a batch that met its goals before the first generation has no history: its final fitness
        best = np.fmin.accumulate(np.nan_to_num(result.history[:, :, 0], nan=np.inf), axis=1)
        generations = np.arange(1, best.shape[1] + 1)
        curves[name] = (generations, np.median(best, axis=0)) if best.size else ([0], [np.median(result.fitness)])
    print(f"{count} targets, {LINKS}-link planar chain, population {POPULATION}, at most {GENERATIONS} generations")
    print(format_table(["settings", "converged", "generations: median / max", "time"], rows))
    if plot:
        _plot(curves, plot)


def _plot(curves: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 4))
    for name, (generations, fitness) in curves.items():
        # a fitness of 0 (met exactly) cannot sit on a log axis: drawn at FLOOR
        line = np.maximum(fitness, FLOOR)
        axes.semilogy(generations, line, marker="o" if len(line) < 3 else None, label=name)
    axes.set(xlabel="generation", ylabel="median best fitness", title=f"{LINKS}-link chain: DE settings")
    axes.legend()
    figure.savefig(path, dpi=100, bbox_inches="tight")
    print(f"wrote {path}")


if __name__ == "__main__":
    arguments = sys.argv[1:]
    main(int(arguments[0]) if arguments else 16, arguments[1] if len(arguments) > 1 else None)

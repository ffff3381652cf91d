"""Fig. 7: random vs sequential target selection in the serial algorithm (Algorithm 1).

Algorithm 1 picks the individual to challenge, x, at random in each of the POP_SIZE iterations
of an epoch; "sequential" takes x = 0, 1, ..., POP_SIZE - 1 instead, so every individual is
challenged exactly once per generation (what the parallel engine does). Everything else is
`deik.experiments.serial_numpy.SerialDE` unchanged: donors, crossover, in-place replacement. The
problem is the paper's: a 20-joint planar chain, population 500, its tip to the tip of a
random in-limit pose (`deik.experiments.timing.make_problem`). We record the best and the
population-mean total fitness after each generation (the paper's "average fitness").
"""

from __future__ import annotations

import os

import numpy as np

from deik.experiments.serial_numpy import Iteration, SerialDE
from deik.experiments.shared import Section, command, describe, markdown_table, save_figure, seed_list, write_csv
from deik.experiments.timing import make_problem
from deik.viz.plot import require_matplotlib

NAME = "fig7"
SELECTIONS = ("random", "sequential")


class _FixedFirstDraw:
    """Wraps a numpy Generator so that the first `integers` call returns `value`; every other
    call goes to the wrapped generator. SerialDE.iterate draws the target x first."""

    def __init__(self, rng, value: int):
        self._rng, self._value = rng, value

    def integers(self, *args, **kwargs):
        if self._value is None:
            return self._rng.integers(*args, **kwargs)
        value, self._value = self._value, None
        return value

    def __getattr__(self, name):
        return getattr(self._rng, name)


class SequentialSerialDE(SerialDE):
    """SerialDE whose iteration k of an epoch challenges individual k (sequential selection)
    instead of a random one; donors, crossover and in-place replacement are SerialDE's."""

    _cursor = 0

    def init(self) -> SequentialSerialDE:
        self._cursor = 0
        return super().init()

    def iterate(self) -> Iteration:
        rng = self.rng
        self.rng = _FixedFirstDraw(rng, self._cursor)
        try:
            step = super().iterate()
        finally:
            self.rng = rng
        self._cursor = (self._cursor + 1) % self.population
        return step


def sizes(quick: bool) -> dict:
    """Joints, population, generations and seeds of the full or quick run."""
    if quick:
        return {"links": 6, "population": 40, "generations": 12, "seeds": seed_list(True, 0, 2)}
    return {"links": 20, "population": 500, "generations": 40, "seeds": seed_list(False, 10, 0)}


def fitness_curve(selection: str, links: int, population: int, generations: int, seed: int) -> np.ndarray:
    """(generations + 1, 2): best and mean total fitness (0 = solved) of the population before
    the first epoch and after each epoch, for one seed (problem and DE stream)."""
    cls = SequentialSerialDE if selection == "sequential" else SerialDE
    de = cls(make_problem(links, seed), population=population, F=0.5, CR=0.5, seed=seed).init()
    start = (de.best_total, float(de.total.mean()))
    de.run(generations)
    return np.vstack([start, de.history])


def run(out_dir: str, quick: bool = False, device: str = "cpu") -> Section:
    """Both selections over the fixed seeds; write fig7.{csv,png}. CSV: one row per
    (selection, seed, generation) with the best and mean total fitness."""
    cfg = sizes(quick)
    curves = {
        s: np.array(
            [fitness_curve(s, cfg["links"], cfg["population"], cfg["generations"], seed) for seed in cfg["seeds"]]
        )
        for s in SELECTIONS
    }  # (S, G + 1, 2)
    rows = [
        {
            "selection": s,
            "seed": seed,
            "generation": g,
            "best_fitness": float(c[k, g, 0]),
            "mean_fitness": float(c[k, g, 1]),
        }
        for s, c in curves.items()
        for k, seed in enumerate(cfg["seeds"])
        for g in range(c.shape[1])
    ]
    write_csv(os.path.join(out_dir, f"{NAME}.csv"), rows)
    _plot(out_dir, cfg, curves)

    G, half = cfg["generations"], cfg["generations"] // 2
    table = [
        [
            s,
            len(cfg["seeds"]),
            describe(c[:, 0, 1]),
            describe(c[:, half, 1]),
            describe(c[:, G, 1]),
            describe(c[:, G, 0]),
        ]
        for s, c in curves.items()
    ]
    end = {s: np.median(c[:, G, 1]) for s, c in curves.items()}
    ahead = sum(curves["sequential"][k, G, 1] < curves["random"][k, G, 1] for k in range(len(cfg["seeds"])))
    gap = np.max(
        np.abs(np.median(curves["sequential"][:, :, 1], axis=0) / np.median(curves["random"][:, :, 1], axis=0) - 1.0)
    )
    headline = (
        f"{cfg['links']} joints, population {cfg['population']}, {len(cfg['seeds'])} seeds, {G} generations: "
        f"median population-mean fitness at the end {end['random']:.3g} (random) vs "
        f"{end['sequential']:.3g} (sequential); sequential is lower in {ahead} of {len(cfg['seeds'])} seeds; "
        f"the median curves differ by at most {100 * gap:.1f} % at any generation."
    )
    measurement = markdown_table(
        [
            "selection",
            "seeds",
            "mean fitness, start",
            f"mean fitness, generation {half}",
            f"mean fitness, generation {G}",
            f"best fitness, generation {G}",
        ],
        table,
    ) + (
        "\n\nTotal fitness is the normalised tip error 1 - exp(-d / reach) (0 = on target); "
        "median [quartiles] over seeds."
    )
    return Section(
        name=NAME,
        title="Fig. 7: random vs sequential target selection (serial algorithm)",
        claim="Averaged over 100 runs of the serial algorithm with 20 joints and population 500, the "
        "average fitness per generation when the candidate to replace is picked at random "
        "(Algorithm 1) is compared with picking the candidates in order; the paper removes the "
        "random pick, which it needs gone for the parallel version.",
        headline=headline,
        measurement=measurement,
        differences=f"The serial algorithm is interpreted NumPy (about half a second per generation at this "
        f"size on our CPU), so we average {len(cfg['seeds'])} seeds over {G} generations, not 100 runs. "
        'The paper\'s plot caption mixes "vs population" and "vs generation"; we plot against '
        "generations. F is 0.5, not the printed FW = 2 (which diverges); CR 0.5.",
        command=command(NAME, quick),
    )


def _plot(out_dir: str, cfg: dict, curves: dict) -> None:
    plt = require_matplotlib()
    figure, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    generations = np.arange(cfg["generations"] + 1)
    for selection, c in curves.items():
        for k, (ax, what) in enumerate(zip(axes[::-1], ("best", "population-mean"))):
            q1, med, q3 = np.percentile(c[:, :, k], [25, 50, 75], axis=0)
            ax.plot(generations, med, label=f"{selection} selection")
            ax.fill_between(generations, q1, q3, alpha=0.15)
            ax.set_title(f"{what} total fitness")
    for ax in axes:
        ax.set_yscale("log")
        ax.set_xlabel("generation")
        ax.set_ylabel("fitness (0 = solved; median, quartiles)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    figure.suptitle(
        f"Fig. 7: serial DE, {cfg['links']} joints, population {cfg['population']}, {len(cfg['seeds'])} seeds"
    )
    figure.tight_layout()
    save_figure(figure, os.path.join(out_dir, f"{NAME}.png"))

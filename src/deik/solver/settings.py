"""DE settings: `Settings`, every field checked by name and type when it is made.

The strategy, limit-mode and device names map to the kernels' codes (deik.device.layout).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypedDict, Unpack

import numpy as np

from deik.device.layout import BEST_1, CLIP, CURRENT_TO_BEST_1, MAX_POLISH_COUNT, PAPER, PENALTY, RAND_1, REFLECT
from deik.errors import InputError

STRATEGIES = {"rand/1/bin": RAND_1, "best/1/bin": BEST_1, "current-to-best/1/bin": CURRENT_TO_BEST_1}
LIMIT_CODES = {"reflect": REFLECT, "clip": CLIP, "penalty": PENALTY, "paper": PAPER}
DEVICES = ("cpu", "gpu", "auto")  # auto: by the solve's size (deik.solver.routing)


@dataclass(frozen=True)
class Settings:
    """DE settings. The defaults converge on IK problems: current-to-best/1/bin with jDE
    self-adaptive F and CR (`adaptive`; F and CR are then only the starting values), an LM
    polish of up to `polish_count` individuals per problem (the best first, stopping at the
    first that meets every tolerance) with `polish` steps every `polish_every` generations
    (0 turns it off), and up to `restarts` restarts of a
    search that stagnates unconverged. `islands` > 1 splits each population into that many
    groups that breed apart and pass their leader to the next group every `migration`
    generations. `Settings.paper()` is the paper's plain rand/1/bin for
    reproducing its figures. `patience`: generations without improvement that count as
    stagnation. `stop_on_converged`: stop a problem once every goal with a tolerance is met;
    None (default) stops then unless a goal without tolerance (comfort) is left to improve,
    which runs on until stagnation. `time_limit`: seconds of wall time for `solve()`, checked
    between kernel launches and, on the CPU, inside them before every LM iteration and
    generation (deik.solver.halting), so a solve stops within about one of those past it; the
    first call in a process also loads or compiles the kernels. `device`: "cpu", "gpu" (an
    NVIDIA GPU), or "auto": the GPU when one is usable and the solve is large enough to be
    faster there (deik.solver.routing).
    `memory_limit`: bytes a solve may allocate (None: 80 % of
    the machine's memory); a larger solve is refused before anything is allocated."""

    population: int = 256
    generations: int = 2000
    strategy: str = "current-to-best/1/bin"
    F: float = 0.5
    CR: float = 0.9
    adaptive: bool = True
    polish: int = 30
    polish_every: int = 10
    polish_count: int = 16
    restarts: int = 20
    islands: int = 1
    migration: int = 25
    seed: int = 0
    patience: int = 300
    stop_on_converged: bool | None = None
    time_limit: float | None = None
    device: str = "cpu"
    dtype: str = "float32"
    memory_limit: int | None = None

    @classmethod
    def paper(cls, **changes: Unpack[SettingsChanges]) -> Settings:
        """Algorithm 1's settings: rand/1/bin, F 0.5, CR 0.5 (its FW = 2 diverges), fixed F and
        CR, no polish, no restarts."""
        return cls(
            **{
                "strategy": "rand/1/bin",
                "F": 0.5,
                "CR": 0.5,
                "population": 500,
                "adaptive": False,
                "polish": 0,
                "restarts": 0,
                **changes,
            }
        )

    def with_seed(self, seed: int) -> Settings:
        """These settings with another seed (checked; the rest is not checked again)."""
        _seed(seed)
        new = object.__new__(type(self))  # not copy.copy: its generic protocol costs a reused Solver 2 us a solve
        new.__dict__.update(vars(self), seed=seed)
        return new

    def with_device(self, device: str) -> Settings:
        """These settings on another device ("cpu", "gpu"), unchecked like with_seed."""
        _choice("device", device, DEVICES)
        new = object.__new__(type(self))
        new.__dict__.update(vars(self), device=device)
        return new

    def __post_init__(self):
        _choice("strategy", self.strategy, tuple(STRATEGIES))
        _integer("population", self.population, 4, "DE needs 3 donors")
        _integer("generations", self.generations, 1)
        _number("F", self.F, "the differential weight, in (0, 2]")
        if not 0 < self.F <= 2:
            raise InputError(f"F (differential weight) must lie in (0, 2], got {self.F!r}")
        _number("CR", self.CR, "the crossover probability, in [0, 1]")
        if not 0 <= self.CR <= 1:
            raise InputError(f"CR (crossover probability) must lie in [0, 1], got {self.CR!r}")
        _boolean("adaptive", self.adaptive)
        _seed(self.seed)
        _integer("patience", self.patience, 1)
        _integer("polish", self.polish, 0, "0 turns it off")
        _integer("restarts", self.restarts, 0, "0 turns them off")
        _integer("polish_every", self.polish_every, 1)
        _integer("polish_count", self.polish_count, 1)
        if self.polish_count > MAX_POLISH_COUNT:
            raise InputError(
                f"polish_count must be at most {MAX_POLISH_COUNT} (one GPU thread polishes each), "
                f"got {self.polish_count}"
            )
        _integer("islands", self.islands, 1)
        if self.population % self.islands or self.population // self.islands < 4:
            raise InputError(
                f"islands must divide the population into groups of at least 4 individuals, "
                f"got {self.islands!r} islands for population {self.population}"
            )
        _integer("migration", self.migration, 1)
        if self.stop_on_converged is not None:
            _boolean("stop_on_converged", self.stop_on_converged)
        if self.time_limit is not None:
            _number("time_limit", self.time_limit, "seconds, or None for no limit")
            if not self.time_limit > 0:
                raise InputError(f"time_limit must be a positive number of seconds or None, got {self.time_limit!r}")
        _choice("device", self.device, DEVICES)
        _choice("dtype", self.dtype, ("float32", "float64"))
        if self.memory_limit is not None:
            _integer("memory_limit", self.memory_limit, 1, "bytes; None: 80 % of physical memory")


class SettingsChanges(TypedDict, total=False):
    """Settings fields given by keyword (`deik.solve(problem, population=64)`, `deik.Solver`,
    `Settings.paper`): the same names and types as Settings' fields (a test keeps them equal),
    so that a type checker flags a misspelt or mistyped setting; run time checks them again."""

    population: int
    generations: int
    strategy: str
    F: float
    CR: float
    adaptive: bool
    polish: int
    polish_every: int
    polish_count: int
    restarts: int
    islands: int
    migration: int
    seed: int
    patience: int
    stop_on_converged: bool | None
    time_limit: float | None
    device: str
    dtype: str
    memory_limit: int | None


def _integer(name: str, value, minimum: int, note: str = "") -> None:
    """ValueError unless `value` is an integer (not a bool) >= minimum."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < minimum:
        hint = f" ({note})" if note else ""
        raise InputError(f"{name} must be an integer >= {minimum}{hint}, got {value!r}")


def _seed(value) -> None:
    """ValueError unless `value` is an integer in [0, 2**64) (the kernels' counter-based seed)."""
    _integer("seed", value, 0)
    if value >= 2**64:
        raise InputError(f"seed must be an integer in [0, 2**64), got {value!r}")


def _number(name: str, value, meaning: str) -> None:
    """ValueError unless `value` is a finite real number (not a bool or a string)."""
    if (
        isinstance(value, (bool, np.bool_))
        or not isinstance(value, (int, float, np.integer, np.floating))
        or not _finite(value)
    ):
        raise InputError(f"{name} must be a finite number ({meaning}), got {value!r:.60}")


def _finite(value) -> bool:
    """Whether a number is finite (an integer too large for a float, of 400 digits, is not)."""
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def _boolean(name: str, value) -> None:
    """ValueError unless `value` is True or False."""
    if not isinstance(value, (bool, np.bool_)):
        raise InputError(f"{name} must be true or false, got {value!r}")


def _choice(name: str, value, choices: tuple) -> None:
    """ValueError unless `value` is one of `choices` (strings)."""
    if not isinstance(value, str) or value not in choices:
        raise InputError(f"{name} must be one of {list(choices)}, got {value!r}")

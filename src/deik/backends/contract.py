"""The one contract between the solver and its back-ends (CPU, CUDA): what they are given and
what they must do, in one argument order.

    inputs: KernelInputs   what the kernels read and never write (one problem structure's arrays
                           and settings; the targets in terms.params may change between solves)
    work:   SolveBuffers   what they fill: two ping-pong Buffers sets, the Status, history rows
    seeds:  Seeds          poses the first population starts from

A back-end keeps whatever it likes between calls (the CUDA back-end keeps the inputs and the
population on the GPU, deik.backends.cuda); after `start` and `run` the host buffers hold at
least each problem's best individual and the Status fields `best`, `active`, `generations` and
`converged`, and after `fetch` everything.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np

from deik.device.layout import Buffers, KernelSettings, PackedSkeleton, PackedTerms, PolishSchedule, SearchRules, Status


class KernelInputs(NamedTuple):
    """The read-only inputs of every kernel launch (deik.device.layout's NamedTuples)."""

    skeleton: PackedSkeleton
    terms: PackedTerms
    evolution: KernelSettings  # DE strategy, limit mode, F, CR, seed, adaptivity, islands
    polish: PolishSchedule
    rules: SearchRules  # when problems stop, restart and migrate


class Seeds(NamedTuple):
    """Poses the first population starts from: the first `count` individuals of problem b copy
    poses[b, :count] (B, n >= count, D), in the solve's dtype; count 0: all random."""

    poses: np.ndarray
    count: int


@dataclass(eq=False)
class SolveBuffers:
    """The buffers a solve works in, in place: `current` holds the state between calls (a
    back-end that ends a launch in `spare` swaps the two), `status` the per-problem
    bookkeeping, `history` (G, B, 2) the best and mean total of each generation a launch runs
    (a launch writes its first rows)."""

    current: Buffers
    spare: Buffers
    status: Status
    history: np.ndarray


class Backend(Protocol):
    """A place to run the kernels. Every method takes the inputs first and the buffers second."""

    name: str  # "cpu" or "gpu", as Settings.device

    def initialise(self, inputs: KernelInputs, work: SolveBuffers, seeds: Seeds) -> None:
        """A random first population (seeded), evaluated, and its Status, all in the host buffers."""

    def start(self, inputs: KernelInputs, work: SolveBuffers, seeds: Seeds, n_generations: int) -> int:
        """A first population (lazy when the polish is on and met problems stop: each problem's
        individual 0 is polished first), then up to n_generations; returns the generations run."""

    def run(self, inputs: KernelInputs, work: SolveBuffers, first_generation: int, n_generations: int) -> int:
        """Up to n_generations more from generation `first_generation`; returns those run."""

    def fetch(self, work: SolveBuffers) -> None:
        """Every individual and Status field into the host buffers (a no-op where they live there)."""


def backend_for(device: str) -> Backend:
    """A new back-end for Settings.device "cpu" or "gpu" (DeviceError when the GPU cannot run)."""
    if device == "gpu":
        from deik.backends.cuda import CudaBackend

        return CudaBackend()
    from deik.backends.cpu import CpuBackend

    return CpuBackend()

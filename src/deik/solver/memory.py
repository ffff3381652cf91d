"""The memory a solve needs, estimated before anything is allocated, and the limit it must fit.

A population of a billion, or a batch far larger than the machine, would otherwise allocate
until the machine runs out. `check_memory` refuses such a solve with the estimate and the fix.
"""

from __future__ import annotations

import os

from deik.errors import SolveError

MEMORY_FRACTION = 0.8  # default limit: this share of the machine's physical memory


def physical_memory() -> int:
    """Bytes of physical memory on this machine (0 when the system does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0


def solve_bytes(
    batch: int, population: int, n_dofs: int, n_terms: int, n_levels: int, itemsize: int, generations: int
) -> int:
    """Bytes a solve allocates on the host: the population buffers (pose, levels, total, raw
    errors, F and CR per individual) three times (the state and a launch's two ping-pong
    copies) and the float64 history of best and mean fitness per problem and generation."""
    per_individual = (n_dofs + n_levels + 1 + n_terms + 2) * itemsize
    return 3 * batch * population * per_individual + 2 * batch * generations * 2 * 8


def check_memory(needed: int, limit: int | None, what: str) -> None:
    """SolveError when `needed` bytes exceed `limit` (default MEMORY_FRACTION of physical memory)."""
    if limit is None:
        limit = int(MEMORY_FRACTION * physical_memory())
    if limit > 0 and needed > limit:
        raise SolveError(
            f"{what} needs about {needed / 2**30:.3g} GiB, more than the {limit / 2**30:.3g} GiB allowed; "
            "use a smaller population, batch or generation budget, or raise the limit "
            "(Settings(memory_limit=BYTES), --memory-limit GIB)"
        )

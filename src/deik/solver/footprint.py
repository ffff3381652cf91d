"""A solve's memory footprint, estimated before anything is allocated (checked by deik.memory)."""

from __future__ import annotations


def solve_bytes(
    batch: int, population: int, n_dofs: int, n_terms: int, n_levels: int, itemsize: int, generations: int
) -> int:
    """Bytes a solve allocates on the host: the population buffers (pose, levels, total, raw
    errors, F and CR per individual) three times (the state and a launch's two ping-pong
    copies) and the float64 history of best and mean fitness per problem and generation."""
    per_individual = (n_dofs + n_levels + 1 + n_terms + 2) * itemsize
    return 3 * batch * population * per_individual + 2 * batch * generations * 2 * 8

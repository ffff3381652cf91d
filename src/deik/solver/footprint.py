"""A solve's memory footprint, estimated before anything is allocated (checked by deik.memory)."""

from __future__ import annotations

import numba


def solve_bytes(
    batch: int, population: int, n_dofs: int, n_terms: int, n_levels: int, itemsize: int, generations: int
) -> int:
    """Bytes a solve allocates on the host: the population buffers (pose, levels, total, raw
    errors, F and CR per individual) three times (the state and a launch's two ping-pong
    copies), the float64 history of best and mean fitness per problem and generation, and the
    LM polish's two D x D matrices on each CPU thread (a 100,000-link chain's are 80 GB each:
    refused here, where they once failed inside the kernel)."""
    per_individual = (n_dofs + n_levels + 1 + n_terms + 2) * itemsize
    polish = numba.get_num_threads() * 2 * n_dofs * n_dofs * itemsize
    return 3 * batch * population * per_individual + 2 * batch * generations * 2 * 8 + polish

"""Solvers in turns on chunks of targets, so that drifting load on a shared machine hits all alike.

The N targets are split into consecutive chunks; for each chunk every solver takes its turn in a
fixed order (deik's turns first, then each peer) before the next chunk begins. A runner is a
callable (start, stop) -> dict of per-target lists (or of per-chunk lists, such as a batch's wall
time); the turns' outputs are joined in target order. A runner that raises PeerFailed drops out
of the remaining turns with the reason recorded.
"""

from __future__ import annotations

import sys

import numpy as np

from benchmarks.peer_process import PeerFailed


def chunk_bounds(n: int, chunks: int) -> list[tuple[int, int]]:
    """Split range(n) into `chunks` consecutive (start, stop) pieces of sizes differing by at most 1
    (fewer when n < chunks; none of them empty)."""
    edges = np.linspace(0, n, min(chunks, n) + 1).round().astype(int) if n else [0]
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def turn_order(n: int, chunks: int, solvers: list[str]) -> list[tuple[str, int, int]]:
    """The turns (solver, start, stop): chunk by chunk, each solver once per chunk, in `solvers`' order."""
    return [(name, a, b) for a, b in chunk_bounds(n, chunks) for name in solvers]


def run_turns(runners: dict, n: int, chunks: int, label: str = "") -> dict[str, dict]:
    """Run every runner on every chunk in turn order; returns per solver its outputs joined over
    the chunks ({key: list}), or {"skipped": reason} for a runner that raised PeerFailed."""
    outputs: dict[str, dict] = {name: {} for name in runners}
    order = turn_order(n, chunks, list(runners))
    for turn, (name, start, stop) in enumerate(order):
        if "skipped" in outputs[name]:
            continue
        try:
            out = runners[name](start, stop)
        except PeerFailed as error:
            outputs[name] = {"skipped": str(error)}
            continue
        for key, values in out.items():
            outputs[name].setdefault(key, []).extend(values)
        if (turn + 1) % len(runners) == 0:
            print(f"{label} chunk {stop}/{n} done", file=sys.stderr, flush=True)
    return outputs

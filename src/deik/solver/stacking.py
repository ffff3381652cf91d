"""The merged term table of stacked problems (Problem.stack): one table for problems on one
skeleton whose goals differ only in targets, weights, comfort references and active masks."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from deik.objectives.kinds import GAIN


def merge_parts(parts) -> tuple[tuple, np.ndarray, np.ndarray]:
    """(rows (T,), params (B, T, N_PARAMS), reference (B, T, D)) of the Problems `parts`
    stacked along the batch axis, B the sum of their batch sizes. A weight that differs
    between parts becomes the largest weight times a per-problem gain, so it must keep one
    sign; raises a ValueError naming the first part that cannot share the table."""
    first = parts[0]
    for k, p in enumerate(parts[1:], 1):
        _check_stackable(first, p, k)
    weights = np.array([[r.weight for r in p.rows] for p in parts])  # (N, T)
    if ((weights > 0).any(axis=0) & (weights < 0).any(axis=0)).any():
        raise ValueError("Problem.stack: a goal has positive weights in some problems and negative in others")
    magnitude = np.abs(weights).max(axis=0)
    sign = np.where((weights < 0).any(axis=0), -1.0, 1.0)
    rows = tuple(replace(r, weight=float(s * m)) for r, s, m in zip(first.rows, sign, magnitude))
    params = []
    for p, w in zip(parts, weights):
        part = p.table.params.copy()
        part[:, :, GAIN] *= np.divide(np.abs(w), magnitude, out=np.zeros_like(w), where=magnitude > 0)
        params.append(part)
    return rows, np.concatenate(params), np.concatenate([p.reference for p in parts])


def _check_stackable(first, other, k: int) -> None:
    """Raise unless problem k can share a term table with the first one."""
    if other.skeleton is not first.skeleton:
        raise ValueError(f"Problem.stack: problem {k} has another skeleton; stacked problems share one Skeleton object")
    if other.limits != first.limits:
        raise ValueError(f"Problem.stack: problem {k} uses limits={other.limits!r}, problem 0 {first.limits!r}")
    if len(other.rows) != len(first.rows):
        raise ValueError(f"Problem.stack: problem {k} has {len(other.rows)} terms, problem 0 has {len(first.rows)}")
    for t, (a, b) in enumerate(zip(first.rows, other.rows)):
        same = (a.kind, a.label, a.frames, a.mu, a.scale, a.tolerance, a.level) == \
            (b.kind, b.label, b.frames, b.mu, b.scale, b.tolerance, b.level)
        if not same or (a.dof_weight is None) != (b.dof_weight is None) or \
                (a.dof_weight is not None and not np.array_equal(a.dof_weight, b.dof_weight)):
            raise ValueError(f"Problem.stack: goal {t} ({b.label}) of problem {k} differs from problem 0's "
                             f"({a.label}) in more than its target, weight, reference or active mask")

"""NumPy evaluation of a problem's term table: the readable oracle the kernels are tested
against, the fitness of the paper's serial Algorithm 1, and float64 error reports.

Each term's raw error comes from its kind's oracle function in the registry of goal kinds
(objectives/registry.py)."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from deik.model.geometry import ground_frame
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.objectives.kinds import (
    GAIN,
    PAIR_A,
    PAIR_B,
    PAIR_TERM,
    PRIORITY_TOLERANCE,
    TERM_FRAME_COUNT,
    TERM_FRAMES,
    TERM_LEVEL,
    WEIGHT,
)
from deik.objectives.registry import Posed, Term, kind_of
from deik.objectives.table import TermTable


class ProblemLike(Protocol):
    """What the oracle reads of a deik.Problem (the solver layer, above this one)."""

    skeleton: Skeleton
    table: TermTable
    reference: np.ndarray


def raw_errors(problem: ProblemLike, poses: np.ndarray, problem_index: np.ndarray | None = None) -> np.ndarray:
    """Raw error of every term (N, T) for poses (N, D); pose n belongs to problem
    problem_index[n] (default 0)."""
    sk, table = problem.skeleton, problem.table
    poses = sk.check_angles(poses).reshape(-1, sk.n_dofs)
    idx = np.zeros(len(poses), int) if problem_index is None else np.asarray(problem_index)
    kin = forward_kinematics(sk, poses)
    posed = Posed(
        skeleton=sk,
        poses=poses,
        R=kin.R_world_frame,
        p=kin.p_world_frame,
        com=kin.p_world_com,
        ground=ground_frame(sk.up),
    )
    out = np.zeros((len(poses), table.n_terms))
    for t, kind in enumerate(table.kinds):
        frames = table.term_int[t, TERM_FRAMES : TERM_FRAMES + table.term_int[t, TERM_FRAME_COUNT]]
        mine = table.pair_int[:, PAIR_TERM] == t
        pairs = table.pair_int[mine][:, [PAIR_A, PAIR_B]]
        term = Term(
            frames=frames,
            params=table.params[idx, t],
            dof_weight=table.dof_weight[t],
            reference=problem.reference[idx, t],
            pairs=pairs,
            pair_radius=table.pair_radius[mine],
        )
        out[:, t] = kind_of(kind).oracle(posed, term)
    return out


def fitness(
    problem: ProblemLike, poses: np.ndarray, problem_index: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(levels (N, L), total (N,), raw (N, T)) exactly as the kernels define them."""
    table = problem.table
    raw = raw_errors(problem, poses, problem_index)
    f = table.normalise(raw)
    idx = np.zeros(len(raw), int) if problem_index is None else np.asarray(problem_index)
    weight = table.term_float[:, WEIGHT] * table.params[idx, :, GAIN]
    f_tolerance = table.term_float[:, PRIORITY_TOLERANCE]
    prioritised = np.where(f_tolerance >= 0, np.maximum(f - f_tolerance, 0), f)
    levels = np.zeros((len(raw), table.n_levels))
    for t in range(table.n_terms):
        levels[:, table.term_int[t, TERM_LEVEL]] += weight[:, t] * prioritised[:, t]
    return levels, (weight * f).sum(axis=1), raw

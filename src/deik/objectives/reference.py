"""NumPy evaluation of a problem's term table: the readable oracle the kernels are tested
against, the fitness of the paper's serial Algorithm 1, and float64 error reports."""

from __future__ import annotations

import numpy as np

from deik.model.geometry import ground_frame, polygon_distance, segment_distance
from deik.model.kinematics import forward_kinematics
from deik.objectives import table as tt
from deik.model.rotations import direction_angle, rotation_angle


def raw_errors(problem, poses, problem_index=None) -> np.ndarray:
    """Raw error of every term (N, T) for poses (N, D); pose n belongs to problem
    problem_index[n] (default 0)."""
    sk, table = problem.skeleton, problem.table
    poses = sk.check_angles(poses).reshape(-1, sk.n_dofs)
    N = len(poses)
    idx = np.zeros(N, int) if problem_index is None else np.asarray(problem_index)
    kin = forward_kinematics(sk, poses)
    R, p, com = kin.R_world_frame, kin.p_world_frame, kin.p_world_com
    ground = ground_frame(sk.up)
    out = np.zeros((N, table.n_terms))
    for t in range(table.n_terms):
        kind, frames = table.term_int[t, 0], table.term_int[t, 3 : 3 + table.term_int[t, 2]]
        g = table.params[idx, t]
        f = frames[0] if len(frames) else 0
        if kind == tt.POSITION:
            out[:, t] = np.linalg.norm(p[:, f] - g[:, :3], axis=-1)
        elif kind == tt.ORIENTATION:
            out[:, t] = rotation_angle(g[:, :9].reshape(-1, 3, 3), R[:, f])
        elif kind == tt.AIM:
            axis = np.einsum("nij,nj->ni", R[:, f], g[:, :3])
            out[:, t] = direction_angle(axis, g[:, 3:6] - p[:, f])
        elif kind in (tt.COM, tt.COM_GROUND):
            d = com - g[:, :3]
            if kind == tt.COM_GROUND:
                d = d - (d @ ground[2])[:, None] * ground[2]
            out[:, t] = np.linalg.norm(d, axis=-1)
        elif kind == tt.SUPPORT_POLYGON:
            out[:, t] = polygon_distance(com @ ground[:2].T, p[:, frames] @ ground[:2].T)
        elif kind in (tt.COMFORT_SUM, tt.COMFORT_MAX):
            e = table.dof_weight[t] * np.abs(poses - problem.reference[idx, t])
            out[:, t] = e.sum(axis=1) if kind == tt.COMFORT_SUM else e.max(axis=1)
        elif kind == tt.LIMITS:
            out[:, t] = (np.maximum(sk.lower - poses, 0) + np.maximum(poses - sk.upper, 0)).sum(axis=1)
        elif kind == tt.OBSTACLE:
            starts = np.concatenate([sk.parents[1:], sk.site_joint])
            ends = np.arange(1, sk.n_frames)
            dist = segment_distance(g[:, None, :3], p[:, starts], p[:, ends])
            out[:, t] = np.maximum(g[:, None, 3] + g[:, None, 4] - dist, 0).sum(axis=1)
    return out


def fitness(problem, poses, problem_index=None):
    """(levels (N, L), total (N,), raw (N, T)) exactly as the kernels define them."""
    table = problem.table
    raw = raw_errors(problem, poses, problem_index)
    f = table.normalise(raw)
    idx = np.zeros(len(raw), int) if problem_index is None else np.asarray(problem_index)
    weight = table.term_float[:, 0] * table.params[idx, :, tt.GAIN]
    f_tolerance = table.term_float[:, 4]
    prioritised = np.where(f_tolerance >= 0, np.maximum(f - f_tolerance, 0), f)
    levels = np.zeros((len(raw), table.n_levels))
    for t in range(table.n_terms):
        levels[:, table.term_int[t, 1]] += weight[:, t] * prioritised[:, t]
    return levels, (weight * f).sum(axis=1), raw

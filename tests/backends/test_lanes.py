"""The CPU's blocked evaluation (deik.device.lanes): LANES poses at once, joint by joint.

- its forward kinematics equals the one-pose kernel FK bit for bit on every motion kind (the
  humanoid's floating root, a 3-D chain, the URDF-like arm's rest rotations, prismatic, oblique
  and mimic motions, rotated sites) in both dtypes, and the NumPy FK to rounding;
- a bred generation stores the totals and raw errors the one-pose path (device_terms.evaluate,
  which the polish uses) gives its poses, bit for bit, as does evaluate_poses (the float64
  report of a float32 solve) in any number of chunks;
- a generation and a first population are the same whatever the split into blocks and chunks,
  for a batch whose size is not a multiple of the block.
"""

import numpy as np
import pytest
from numba import njit

import deik
from deik.backends.targets import cpu
from deik.backends.targets import cpu as dev
from deik.device.layout import LANES
from helpers import BUILTIN_SKELETONS, random_poses

SKELETONS = sorted(BUILTIN_SKELETONS)


@njit
def _lanes_fk(poses, skel, R, p):
    """R (N, F*9), p (N, F*3) of poses (N, D) through forward_kinematics_lanes, LANES at a time
    (N a multiple of LANES)."""
    D, n_rows = poses.shape[1], R.shape[1]
    block = np.empty((D, LANES), poses.dtype)
    frames = np.empty((n_rows // 9 * 12, LANES), poses.dtype)
    R_lanes, p_lanes = np.empty((n_rows, LANES), poses.dtype), np.empty((p.shape[1], LANES), poses.dtype)
    for first in range(0, poses.shape[0], LANES):
        for lane in range(LANES):
            for d in range(D):
                block[d, lane] = poses[first + lane, d]
        dev.forward_kinematics_lanes(block, skel, frames, R_lanes, p_lanes)
        for lane in range(LANES):
            R[first + lane] = R_lanes[:, lane]
            p[first + lane] = p_lanes[:, lane]


@njit
def _one_pose_scores(poses, problem_index, skel, terms, n_levels):
    """(levels (N, L), total (N,), raw (N, T)) of poses (N, D) by the one-pose path
    (device_terms.evaluate: forward_kinematics, then score), pose n against problem
    problem_index[n]."""
    N, D, T = poses.shape[0], poses.shape[1], terms.term_int.shape[0]
    levels, total, raw = np.empty((N, n_levels), poses.dtype), np.empty(N, poses.dtype), np.empty((N, T), poses.dtype)
    scratch, _, _, _ = cpu.thread_scratch(skel, poses, T, n_levels, D)
    for n in range(N):
        total[n] = dev.evaluate(poses[n], problem_index[n], skel, terms, scratch, levels[n], raw[n])
    return levels, total, raw


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("name", SKELETONS)
def test_lane_fk_equals_the_one_pose_fk_bit_for_bit(name, dtype):
    sk = BUILTIN_SKELETONS[name]()
    poses = random_poses(sk, 2 * LANES, 3).astype(dtype)
    poses[0] = 0.0  # exact multiples of pi/2 and zeros go through the same quadrant logic
    skel = engine_skeleton(sk, dtype)
    F = skel.joint_int.shape[0] + skel.site_joint.shape[0]
    R, p = np.empty((len(poses), 9 * F), dtype), np.empty((len(poses), 3 * F), dtype)
    _lanes_fk(poses, skel, R, p)
    R_one, p_one = np.empty_like(R), np.empty_like(p)
    cpu.forward_kinematics_batch(poses, skel, R_one, p_one)
    np.testing.assert_array_equal(R, R_one)
    np.testing.assert_array_equal(p, p_one)
    kin = deik.forward_kinematics(sk, poses.astype(np.float64))  # NumPy, libm's sine
    tol = 1e-12 if dtype == np.float64 else 2e-5
    names = list(sk.joint_names) + list(sk.site_names)
    for f, frame in enumerate(names):
        np.testing.assert_allclose(p[:, 3 * f : 3 * f + 3], kin.position(frame), rtol=0, atol=tol * sk.reach)
        np.testing.assert_allclose(R[:, 9 * f : 9 * f + 9].reshape(-1, 3, 3), kin.rotation(frame), rtol=0, atol=tol)


def engine_skeleton(sk, dtype):
    """The packed skeleton an Engine hands the kernels."""
    problem = deik.Problem(sk, [deik.Comfort()])
    return deik.Engine(problem, deik.Settings(dtype=np.dtype(dtype).name)).skel


def _batch_engine(dtype, problems=3, population=45):
    """A chain20 batch of `problems` x `population` individuals (135: not a multiple of LANES)
    with a position and a comfort goal; returns (engine, state after 2 generations)."""
    chain = deik.chain(20)
    targets = deik.forward_kinematics(chain, random_poses(chain, problems, 7)).position("tip")
    problem = deik.Problem(chain, [deik.Position("tip", targets), deik.Comfort(weight=0.1, level=1)])
    settings = deik.Settings(population=population, dtype=dtype, polish=0, seed=11, islands=3, migration=2)
    engine = deik.Engine(problem, settings)
    return engine, engine.run(engine.init(), 2)


def _copy(buffers):
    return type(buffers)(*(a.copy() for a in buffers))


@njit
def _breed_in_blocks(sizes, cur, nxt, skel, terms, settings, status, order, gen):
    """One generation through device_lanes.breed_lanes in blocks of the given sizes, one scratch."""
    lanes = cpu.lane_scratch(skel, cur.pop, cur.raw.shape[2], cur.levels.shape[2], cur.pop.shape[2])
    first = 0
    for size in sizes:
        dev.breed_lanes(first, size, order, gen, cur, nxt, skel, terms, settings, status, lanes)
        first += size


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_a_generation_is_the_same_for_every_block_split_and_scores_like_the_one_pose_path(dtype):
    engine, state = _batch_engine(dtype)
    cur, status = state.buffers, state.status
    B, P = cur.pop.shape[:2]
    n, order = B * P, np.arange(B, dtype=np.int64)
    assert n % LANES != 0
    args = (engine.skel, engine.terms, engine.kernel_settings, status, order, np.int64(state.generation))
    results = []
    for chunks in (1, 2, 5):
        nxt = _copy(cur)
        cpu._breed(chunks, n, cur, nxt, *args)
        results.append(nxt)
    shifted = [5] + [LANES] * ((n - 5) // LANES) + [(n - 5) % LANES]  # blocks across problem boundaries
    for sizes in (shifted, [1] * n):
        nxt = _copy(cur)
        _breed_in_blocks(np.array(sizes, np.int64), cur, nxt, *args)
        results.append(nxt)
    for other in results[1:]:
        for a, b in zip(results[0], other):
            np.testing.assert_array_equal(a, b)
    bred = results[0]
    assert (bred.pop != cur.pop).any(axis=2).mean() > 0.1  # trials were kept: the comparison is not of copies
    poses, index = bred.pop.reshape(n, -1), np.repeat(order, P)
    levels, total, raw = _one_pose_scores(poses, index, engine.skel, engine.terms, bred.levels.shape[2])
    np.testing.assert_array_equal(total, bred.total.reshape(n))
    np.testing.assert_array_equal(raw, bred.raw.reshape(n, -1))
    np.testing.assert_array_equal(levels, bred.levels.reshape(n, -1))
    # evaluate_poses, split into any number of chunks
    for chunks in (1, 3):
        lane_levels, lane_total, lane_raw = (np.empty_like(a) for a in (levels, total, raw))
        cpu.evaluate_poses(poses, index, engine.skel, engine.terms, lane_levels, lane_total, lane_raw, chunks, 1)
        np.testing.assert_array_equal(lane_total, total)
        np.testing.assert_array_equal(lane_raw, raw)
        np.testing.assert_array_equal(lane_levels, levels)


def test_a_first_population_is_the_same_for_every_chunk_count_and_scores_like_the_one_pose_path():
    engine, state = _batch_engine("float64")
    buffers, status = state.buffers, state.status
    B, P, D = buffers.pop.shape
    initial = np.zeros((B, 1, D))
    results = []
    for chunks in (1, 3):
        fresh, fresh_status = _copy(buffers), _copy(status)
        cpu.initialise(fresh, fresh_status, engine.skel, engine.terms, engine.kernel_settings, initial, 0, chunks)
        results.append(fresh)
    for a, b in zip(*results):
        np.testing.assert_array_equal(a, b)
    pop = results[0].pop.reshape(B * P, D)
    n_levels = buffers.levels.shape[2]
    _, total, raw = _one_pose_scores(pop, np.repeat(np.arange(B), P), engine.skel, engine.terms, n_levels)
    np.testing.assert_array_equal(total, results[0].total.reshape(-1))
    np.testing.assert_array_equal(raw, results[0].raw.reshape(B * P, -1))

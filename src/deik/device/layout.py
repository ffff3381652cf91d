"""Names for the data the kernels read: the packed arrays, their columns, and launch sizes.

Every group of arrays or scalars a kernel takes is a NamedTuple, so device code reads fields by
name (Numba types a NamedTuple like a tuple: fields are resolved at compile time, and passing
one costs nothing at run time). Shapes: J joints, S sites, F = J + S frames, N motions, D DOFs,
M mass points, B problems, P individuals, L priority levels, T terms. Lengths are the skeleton's
units (metres), angles radians; float arrays have the engine's dtype, integer ones int32
(skeleton, terms) or int64 (status). The term kinds and term-table columns are in
deik.objectives.kinds.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from deik.model.joints import ROTATE

THREADS_PER_BLOCK = 128  # GPU threads per problem (one block each)
MAX_POLISH_COUNT = THREADS_PER_BLOCK  # individuals one polish round may refine: one GPU thread each
INIT_GENERATION = -1  # the generation the random first population draws from

# joint_int columns: parent joint (-1: root), motions [start, end), 1 if the rest rotation is the identity
PARENT, MOTION_START, MOTION_END, PLAIN_ROTATION = 0, 1, 2, 3
# joint_frame and site_frame columns: offset (3) from the parent frame, then the row-major rest rotation (9)
OFFSET, ROTATION = 0, 3
# motion_int columns: motion kind (ROTATE_MOTION or a translation), source DOF, coordinate axis (0-2, -1: general)
MOTION_KIND, SOURCE, COORDINATE_AXIS = 0, 1, 2
ROTATE_MOTION = ROTATE
# motion_float columns: unit axis (3), then scale and bias (value = scale * q[source] + bias)
AXIS, MOTION_SCALE, MOTION_BIAS = 0, 3, 4
# mass_data columns: offset (3) in the joint's frame, then the mass fraction
MASS_OFFSET, MASS_FRACTION = 0, 3
# limits columns (radians or length units; TURN: 2 pi for a rotation whose limits span a whole
# turn or more, which the polish wraps round rather than stops at, else 0) and ground rows (two
# horizontal unit axes, then up)
LOWER, UPPER, TURN = 0, 1, 2
HORIZONTAL_U, HORIZONTAL_V, UP = 0, 1, 2
# KernelSettings.strategy and .limit_mode codes
RAND_1, BEST_1, CURRENT_TO_BEST_1 = 0, 1, 2
REFLECT, CLIP, PENALTY, PAPER = 0, 1, 2, 3
# rates columns: each individual's differential weight F and crossover probability CR
RATE_F, RATE_CR = 0, 1
# history (G, B, 2) columns: the best and the mean total of a problem's population per generation
HISTORY_BEST, HISTORY_MEAN = 0, 1
WORK_SIZE = 32  # floats of Scratch.work: general-axis rotations use 18, the support polygon 2 per frame
# individuals the CPU evaluates together, joint by joint, in SIMD lanes (device/lanes.py): four
# 512-bit registers of float32, eight of float64 per row. Each loop over the lanes has a fixed
# cost (an overlap check, its set-up): on a 100-link chain in float32 the lane FK took 5.4, 3.2
# and 2.3 ns per joint and individual with 16, 32 and 64 lanes (one thread, CPU time).
LANES = 64


class PackedSkeleton(NamedTuple):
    """A Skeleton as arrays (deik.backends.pack.pack_skeleton)."""

    joint_int: np.ndarray  # (J, 4) int32: PARENT, MOTION_START, MOTION_END, PLAIN_ROTATION
    joint_frame: np.ndarray  # (J, 12): OFFSET, ROTATION (rest rotation)
    motion_int: np.ndarray  # (N, 3) int32: MOTION_KIND, SOURCE, COORDINATE_AXIS
    motion_float: np.ndarray  # (N, 5): AXIS, MOTION_SCALE, MOTION_BIAS
    site_joint: np.ndarray  # (S,) int32: the joint each site hangs from
    site_frame: np.ndarray  # (S, 12): OFFSET, ROTATION in that joint's frame
    mass_joint: np.ndarray  # (M,) int32: the joint each mass point hangs from
    mass_data: np.ndarray  # (M, 4): MASS_OFFSET, MASS_FRACTION
    limits: np.ndarray  # (D, 3): LOWER, UPPER, TURN
    bounds: np.ndarray  # (2 D,): the same limits flat, LOWER and UPPER of DOF d at 2 d and 2 d + 1
    ground: np.ndarray  # (3, 3) rows: HORIZONTAL_U, HORIZONTAL_V, UP


class PackedTerms(NamedTuple):
    """A TermTable as arrays (deik.backends.pack.pack_terms); columns in deik.objectives.kinds."""

    term_int: np.ndarray  # (T, 3 + MAX_TERM_FRAMES) int32: TERM_KIND, TERM_LEVEL, TERM_FRAME_COUNT, TERM_FRAMES
    term_float: np.ndarray  # (T, 5): WEIGHT, MU, SCALE, TOLERANCE, PRIORITY_TOLERANCE
    params: np.ndarray  # (B, T, N_PARAMS): each problem's targets, GAIN last
    dof_weight: np.ndarray  # (T, D): comfort terms' weight per DOF
    reference: np.ndarray  # (B, T, D): comfort terms' reference pose
    pair_int: np.ndarray  # (K, 3) int32: PAIR_TERM, PAIR_A, PAIR_B: the bone pairs self-collision terms test
    pair_radius: np.ndarray  # (K,): the pair's capsule radii's sum


class KernelSettings(NamedTuple):
    """DE settings as the kernels read them (device_evolution.make_trial)."""

    strategy: np.int64  # RAND_1, BEST_1 or CURRENT_TO_BEST_1 (all with binomial crossover)
    limit_mode: np.int64  # REFLECT, CLIP, PENALTY or PAPER (Algorithm 2)
    F: np.floating  # differential weight (the start value when adaptive)
    CR: np.floating  # crossover probability (the start value when adaptive)
    seed: np.uint64
    adaptive: bool  # jDE: each individual carries and redraws its own F and CR
    islands: np.int64  # groups of P // islands individuals that breed apart


class PolishSchedule(NamedTuple):
    """When and how much the LM polish refines: `iterations` steps (0: off) on up to `count`
    individuals per problem every `every` generations."""

    iterations: np.int64
    every: np.int64
    count: np.int64


class Status(NamedTuple):
    """Per-problem bookkeeping (B,) each, updated by device_evolution.update_status."""

    best: np.ndarray  # int64 index of the best individual
    active: np.ndarray  # bool: still evolving
    generations: np.ndarray  # int64 generations used
    converged: np.ndarray  # bool: the best meets every tolerance
    best_seen: np.ndarray  # float64 total of the best so far
    best_levels: np.ndarray  # (B, L) float64 levels of the best so far (stagnation is judged on them)
    last_improved: np.ndarray  # int64 generation of the last improvement
    restarts: np.ndarray  # int64 restarts used
    restarting: np.ndarray  # bool: the next generation restarts
    elite: np.ndarray  # int64 individual kept through the last restart (-1: none)
    leaders: np.ndarray  # (B, islands) int64 the best of each island but the elite
    halt: np.ndarray  # (1,) int64, set by the host (time limit, Ctrl-C): the work stops at its next check


class SearchRules(NamedTuple):
    """When a problem stops, restarts, and passes island leaders on."""

    patience: np.int64  # generations without improvement that count as stagnation
    rel_improvement: float  # the relative fall of the best total that counts as improvement
    stop_on_converged: bool
    max_restarts: np.int64
    migration: np.int64  # generations between migrations of island leaders


class Buffers(NamedTuple):
    """One ping-pong set of population buffers."""

    pop: np.ndarray  # (B, P, D) poses
    levels: np.ndarray  # (B, P, L) strict-priority levels (lower is better)
    total: np.ndarray  # (B, P) total weighted fitness
    raw: np.ndarray  # (B, P, T) raw term errors (metres or radians)
    rates: np.ndarray  # (B, P, 2): RATE_F, RATE_CR


class Scratch(NamedTuple):
    """Per-thread scratch of a fitness evaluation."""

    R: np.ndarray  # (F*9,) world rotations, flat row-major
    p: np.ndarray  # (F*3,) world positions
    work: np.ndarray  # (WORK_SIZE,)


class LaneScratch(NamedTuple):
    """Per-thread scratch of LANES individuals evaluated together (device/lanes.py): their poses
    and world frames lane-contiguous (element-major, lane-minor), so a loop over the lanes reads
    and writes consecutive floats."""

    trials: np.ndarray  # (LANES, D) the trials being bred, one row each
    poses: np.ndarray  # (D, LANES) the lanes' poses, one column each: what the FK reads
    rates: np.ndarray  # (LANES, 2) the F and CR each trial used
    frames: np.ndarray  # (F*12, LANES) the FK's working copy: per frame its rotation rows, then its position rows
    R: np.ndarray  # (F*9, LANES) world rotations, flat row-major per frame
    p: np.ndarray  # (F*3, LANES) world positions
    levels: np.ndarray  # (LANES, L)
    raw: np.ndarray  # (LANES, T)
    work: np.ndarray  # (WORK_SIZE,) the scoring's work array, shared by the lanes in turn


class LmScratch(NamedTuple):
    """Per-thread scratch of the LM polish (device/lm.py)."""

    A: np.ndarray  # (D*D,) the damped normal matrix, factorised in place
    normal: np.ndarray  # (D*D,) the undamped normal matrix J^T J, kept while the pose stands
    gradient: np.ndarray  # (D,)
    jac: np.ndarray  # (3*D,) one term's three Jacobian rows
    delta: np.ndarray  # (D,) the step
    pose: np.ndarray  # (D,) the pose being polished (device_lm.converge works on a copy)
    pose_levels: np.ndarray  # (L,) its levels
    pose_raw: np.ndarray  # (T,) its raw errors

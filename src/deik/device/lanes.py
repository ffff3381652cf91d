"""Device maths, part 7: a block of LANES individuals evaluated together, joint by joint, in SIMD
lanes (how the CPU kernels breed and initialise; the GPU runs one individual per thread).

The block's poses and frames are lane-contiguous (element-major, lane-minor: poses (D, n),
R (F*9, n), p (F*3, n) for n = LANES lanes), and every helper below is one loop over the lanes
whose body is straight-line arithmetic, which LLVM compiles to packed instructions: one 512-bit
register holds 16 float32 or 8 float64 lanes (docs/performance.md shows the assembly). What
that takes from Numba and LLVM, learnt by reading the optimisation remarks:
- the loops run to the arrays' lane count, not to the constant LANES: LLVM unrolls a short loop
  of known length into scalar code (Numba turns its straight-line vectoriser off);
- a helper takes its frame's block of rows as a view and indexes it at constant rows, so LLVM
  sees that the rows never overlap; rows computed at run time keep Numba's negative-index
  fix-up, and a loop reading one block and writing another needs an overlap check per pair of
  rows, more than LLVM allows;
- the helpers are inlined by Numba (INLINE): LLVM does not inline a helper whose vectorised loop
  makes it large, and a call inside a loop stops its vectorisation.
Each lane computes what forward_kinematics computes for its pose, operation for operation (the
same sin_cos, dot3, turn and axis_angle, in the same order), so a pose scores the same bits here
as on the one-pose path (the polish, the float64 report, evaluate_poses, the GPU);
tests/backends/test_lanes.py checks it on every motion kind. The lanes of a block may belong to
different problems of a batch (the FK reads only the skeleton); trials, scoring and selection
stay per lane. Compiled with the other deik.device modules (deik.backends.targets); `lanes` is a
layout.LaneScratch.
"""

from deik.device.driver import propose, seed_individual, select
from deik.device.layout import (
    AXIS,
    COORDINATE_AXIS,
    MOTION_BIAS,
    MOTION_END,
    MOTION_KIND,
    MOTION_SCALE,
    MOTION_START,
    OFFSET,
    PARENT,
    PLAIN_ROTATION,
    ROTATE_MOTION,
    ROTATION,
    SOURCE,
    Scratch,
)
from deik.device.maths import axis_angle, dot3, sin_cos, turn
from deik.device.terms import score

INLINE = (
    "_copy",
    "_copy_out",
    "_root",
    "_offset",
    "_move_lane",
    "_rest_rotation",
    "_times_lane",
    "_slide",
    "_turn",
    "_rotate",
)
FRAME_ROWS, POSITION_ROW = 12, 9  # a frame's block in forward_kinematics_lanes: 9 rotation rows, then 3 position


def forward_kinematics_lanes(poses, skel, frames, R, p):
    """World rotations R (F*9, n) and positions p (F*3, n) of every joint then site for the n
    poses (D, n), one per lane: forward_kinematics lane by lane, without recording axes.
    frames (F*FRAME_ROWS, n) is the working copy: each frame is built in its own block of rows,
    first a copy of its parent's block (one flat copy: a single overlap check), then changed in
    place (offset, rest rotation, motions), then copied out to R and p."""
    joint_int, joint_frame, motion_int, motion_float = (
        skel.joint_int,
        skel.joint_frame,
        skel.motion_int,
        skel.motion_float,
    )
    n, J = frames.shape[1], joint_int.shape[0]
    size = FRAME_ROWS * n
    flat = frames.reshape(frames.size)
    for k in range(J):
        parent, block = joint_int[k, PARENT], frames[FRAME_ROWS * k : FRAME_ROWS * (k + 1)]
        if parent < 0:
            _root(block, joint_frame[k])
        else:
            _copy(flat[k * size : (k + 1) * size], flat[parent * size : (parent + 1) * size])
            _offset(block, joint_frame[k])
            if joint_int[k, PLAIN_ROTATION] != 1:
                _rest_rotation(block, joint_frame[k])
        for m in range(joint_int[k, MOTION_START], joint_int[k, MOTION_END]):
            ax, ay, az = motion_float[m, AXIS], motion_float[m, AXIS + 1], motion_float[m, AXIS + 2]
            scale, bias, gene = (
                motion_float[m, MOTION_SCALE],
                motion_float[m, MOTION_BIAS],
                poses[motion_int[m, SOURCE]],
            )
            if motion_int[m, MOTION_KIND] != ROTATE_MOTION:
                _slide(block, gene, scale, bias, ax, ay, az)
            elif motion_int[m, COORDINATE_AXIS] >= 0:
                # constant columns once _turn is inlined: a column picked at run time would cost
                # an overlap check per row
                sign, axis = ax + ay + az, motion_int[m, COORDINATE_AXIS]
                if axis == 0:
                    _turn(block, 1, 2, gene, scale, bias, sign)
                elif axis == 1:
                    _turn(block, 2, 0, gene, scale, bias, sign)
                else:
                    _turn(block, 0, 1, gene, scale, bias, sign)
            else:
                _rotate(block, gene, scale, bias, ax, ay, az)
        _copy_out(flat, k, R, p)
    for s in range(skel.site_joint.shape[0]):
        f, j = J + s, skel.site_joint[s]
        block = frames[FRAME_ROWS * f : FRAME_ROWS * (f + 1)]
        _copy(flat[f * size : (f + 1) * size], flat[j * size : (j + 1) * size])
        _offset(block, skel.site_frame[s])
        _rest_rotation(block, skel.site_frame[s])
        _copy_out(flat, f, R, p)


def _copy(target, source):
    """target[:] = source (flat views of one length)."""
    for e in range(target.shape[0]):
        target[e] = source[e]


def _copy_out(flat, f, R, p):
    """Frame f's block of the flat working copy into its rows of R and p."""
    n = R.shape[1]
    start = FRAME_ROWS * n * f
    _copy(R.reshape(R.size)[9 * n * f : 9 * n * (f + 1)], flat[start : start + 9 * n])
    _copy(p.reshape(p.size)[3 * n * f : 3 * n * (f + 1)], flat[start + 9 * n : start + FRAME_ROWS * n])


def _root(block, frame):
    """A root joint's block: the frame row's rest ROTATION and OFFSET in every lane."""
    for lane in range(block.shape[1]):
        for e in range(9):
            block[e, lane] = frame[ROTATION + e]
        for e in range(3):
            block[POSITION_ROW + e, lane] = frame[OFFSET + e]


def _offset(block, frame):
    """The block's position += its rotation @ the frame row's OFFSET (rotate_point), lane by lane."""
    tx, ty, tz = frame[OFFSET], frame[OFFSET + 1], frame[OFFSET + 2]
    for lane in range(block.shape[1]):
        _move_lane(block, lane, tx, ty, tz)


def _move_lane(block, lane, x, y, z):
    """Lane `lane` of the block's position += its rotation @ (x, y, z)."""
    x0 = dot3(block[0, lane], block[1, lane], block[2, lane], x, y, z)
    y0 = dot3(block[3, lane], block[4, lane], block[5, lane], x, y, z)
    z0 = dot3(block[6, lane], block[7, lane], block[8, lane], x, y, z)
    block[9, lane], block[10, lane], block[11, lane] = block[9, lane] + x0, block[10, lane] + y0, block[11, lane] + z0


def _rest_rotation(block, frame):
    """The block's rotation = itself @ the frame row's ROTATION (matmul3), lane by lane."""
    m0, m1, m2 = frame[ROTATION], frame[ROTATION + 1], frame[ROTATION + 2]
    m3, m4, m5 = frame[ROTATION + 3], frame[ROTATION + 4], frame[ROTATION + 5]
    m6, m7, m8 = frame[ROTATION + 6], frame[ROTATION + 7], frame[ROTATION + 8]
    for lane in range(block.shape[1]):
        _times_lane(block, lane, m0, m1, m2, m3, m4, m5, m6, m7, m8)


def _times_lane(block, lane, m0, m1, m2, m3, m4, m5, m6, m7, m8):
    """Lane `lane` of the block's rotation = itself @ m (row-major m0..m8), as matmul3 rounds it."""
    for row in range(0, 9, 3):
        u, v, w = block[row, lane], block[row + 1, lane], block[row + 2, lane]
        block[row, lane] = dot3(u, v, w, m0, m3, m6)
        block[row + 1, lane] = dot3(u, v, w, m1, m4, m7)
        block[row + 2, lane] = dot3(u, v, w, m2, m5, m8)


def _slide(block, gene, scale, bias, ax, ay, az):
    """A translation along the block's axis (ax, ay, az) by scale * gene + bias, lane by lane."""
    for lane in range(block.shape[1]):
        value = scale * gene[lane] + bias
        _move_lane(block, lane, ax * value, ay * value, az * value)


def _turn(block, a, b, gene, scale, bias, sign):
    """turn_columns: columns a and b of the block's rotation, the two a rotation about the third
    coordinate axis mixes, turned by (scale * gene + bias) * sign (sign: +-1, the axis'
    direction), lane by lane."""
    for lane in range(block.shape[1]):
        s, c = sin_cos((scale * gene[lane] + bias) * sign, block)
        block[a, lane], block[b, lane] = turn(c, s, block[a, lane], block[b, lane])
        block[a + 3, lane], block[b + 3, lane] = turn(c, s, block[a + 3, lane], block[b + 3, lane])
        block[a + 6, lane], block[b + 6, lane] = turn(c, s, block[a + 6, lane], block[b + 6, lane])


def _rotate(block, gene, scale, bias, ax, ay, az):
    """The block's rotation times the rotation about the general unit axis (ax, ay, az) by scale *
    gene + bias (axis_angle, then matmul3's rounding), lane by lane."""
    one = block.dtype.type(1.0)
    for lane in range(block.shape[1]):
        s, c = sin_cos(scale * gene[lane] + bias, block)
        m0, m1, m2, m3, m4, m5, m6, m7, m8 = axis_angle(ax, ay, az, s, c, one)
        _times_lane(block, lane, m0, m1, m2, m3, m4, m5, m6, m7, m8)


def score_lane(lane, q, b, skel, terms, lanes, levels, raw):
    """device_terms.score of pose q (D,), lane `lane`'s, for problem b, reading its frames in place."""
    return score(q, b, skel, terms, Scratch(lanes.R[:, lane], lanes.p[:, lane], lanes.work), levels, raw)


def initialise_lanes(first, count, order, skip, state, skel, terms, settings, initial, n_initial, lanes):
    """device_driver.initialise_individual for the `count` (<= LANES) individuals first, first + 1,
    ... evaluated together: individual k is individual skip + k % (P - skip) of problem
    order[k // (P - skip)] (a whole first population: order 0, 1, ..., B - 1 and skip 0; the rest
    of a lazy one: the problems its polished individual 0 left unmet, skip 1)."""
    P, D = state.pop.shape[1], state.pop.shape[2]
    size = P - skip
    for lane in range(count):
        b, i = order[(first + lane) // size], skip + (first + lane) % size
        seed_individual(b, i, state, skel, settings, initial, n_initial)
        for d in range(D):
            lanes.poses[d, lane] = state.pop[b, i, d]
    forward_kinematics_lanes(lanes.poses, skel, lanes.frames, lanes.R, lanes.p)
    for lane in range(count):
        b, i = order[(first + lane) // size], skip + (first + lane) % size
        state.total[b, i] = score_lane(
            lane, state.pop[b, i], b, skel, terms, lanes, state.levels[b, i], state.raw[b, i]
        )


def breed_lanes(first, count, order, gen, cur, nxt, skel, terms, settings, status, lanes):
    """device_driver.breed_individual for the `count` (<= LANES) active individuals first,
    first + 1, ... (individual k is individual k % P of problem order[k // P]), their trials
    evaluated together. Lanes past `count` keep an earlier block's poses: computed, never read."""
    P, trials = cur.pop.shape[1], lanes.trials
    for lane in range(count):
        b, i = order[(first + lane) // P], (first + lane) % P
        propose(b, i, gen, cur, skel, settings, status, trials[lane], lanes.rates[lane])
        for d in range(trials.shape[1]):
            lanes.poses[d, lane] = trials[lane, d]
    forward_kinematics_lanes(lanes.poses, skel, lanes.frames, lanes.R, lanes.p)
    for lane in range(count):
        b, i = order[(first + lane) // P], (first + lane) % P
        lv, rw = lanes.levels[lane], lanes.raw[lane]
        tot = score_lane(lane, trials[lane], b, skel, terms, lanes, lv, rw)
        select(b, i, cur, nxt, status, trials[lane], lv, rw, tot, lanes.rates[lane])

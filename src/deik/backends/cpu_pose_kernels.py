"""CPU kernels on given poses, not a search: forward kinematics of a batch, the clip warm start's
point Jacobians and the LM polish's residual rows of one term (the tests' finite-difference
checks). Compiled into the same build namespace as deik.backends.cpu_kernels (deik.backends.
targets.cpu_build), whose scratch and chunking they share.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from deik.backends.cpu_kernels import chunk_count, polish_scratch, thread_scratch
from deik.backends.linking import linked
from deik.device import maths as device_maths
from deik.device import polish as device_polish
from deik.device.layout import WORK_SIZE


@linked(parallel=True)
def forward_kinematics_batch(poses, skel, R, p):
    """World frames of poses (N, D) -> R (N, F*9), p (N, F*3) with the kernel's own FK."""
    for n in prange(poses.shape[0]):
        work = np.empty(WORK_SIZE, poses.dtype)
        device_maths.forward_kinematics(poses[n], skel, R[n], p[n], work, work, False)


@linked(parallel=True)
def point_jacobians(poses, frames, skel, x, jacobian, n_chunks, threads):
    """World positions x (N, G, 3) of frames (G,) (joint indices, then sites after the joints;
    -1 for the centre of mass) at poses (N, D), and their analytic Jacobian (N, G, 3, D), with
    the kernels' FK and the polish's rows (device_polish.point_rows, com_rows). n_chunks and
    threads as for evaluate_poses."""
    N = poses.shape[0]
    n_chunks = max(1, min(N, n_chunks if n_chunks > 0 else chunk_count(N, 1, skel, threads)))
    if n_chunks == 1:
        _point_jacobian_chunk(0, 1, poses, frames, skel, x, jacobian)
    else:
        for c in prange(n_chunks):
            _point_jacobian_chunk(np.int64(c), n_chunks, poses, frames, skel, x, jacobian)


@linked()
def _point_jacobian_chunk(c, n_chunks, poses, frames, skel, x, jacobian):
    """Chunk c of `n_chunks` of point_jacobians' poses (one scratch allocation per chunk)."""
    N, D = poses.shape
    scratch, _, _, _ = thread_scratch(skel, poses, 1, 1, D)
    R, p = scratch.R, scratch.p
    axes, jac = np.empty(6 * skel.motion_int.shape[0], poses.dtype), np.empty(3 * D, poses.dtype)
    for n in range(c * N // n_chunks, (c + 1) * N // n_chunks):
        device_maths.forward_kinematics(poses[n], skel, R, p, scratch.work, axes, True)
        for g in range(frames.shape[0]):
            f = frames[g]
            for e in range(3 * D):
                jac[e] = 0.0
            if f < 0:
                x[n, g, 0], x[n, g, 1], x[n, g, 2] = device_maths.centre_of_mass(skel, R, p)
                device_polish.com_rows(skel, R, p, axes, 1.0, jac, D, 0, 0)
            else:
                x[n, g, 0], x[n, g, 1], x[n, g, 2] = p[3 * f], p[3 * f + 1], p[3 * f + 2]
                j = device_polish.frame_joint(f, skel)
                device_polish.point_rows(p[3 * f], p[3 * f + 1], p[3 * f + 2], j, skel, axes, 1.0, jac, D, 0, 0)
            for row in range(3):
                for d in range(D):
                    jacobian[n, g, row, d] = jac[row * D + d]


@linked()
def residual_rows(poses, problem_index, term, skel, terms):
    """The LM polish's scaled residual (N, 3) of one term and its analytic Jacobian (N, 3, D)
    at poses (N, D) (zeros for terms the polish leaves to DE)."""
    N, D = poses.shape
    residual, jacobian = np.zeros((N, 3), poses.dtype), np.zeros((N, 3, D), poses.dtype)
    scratch, _, _, _ = thread_scratch(skel, poses, 1, 1, D)
    axes, lm = polish_scratch(skel, poses, terms.term_int.shape[0], 1, D)
    R, p, jac = scratch.R, scratch.p, lm.jac
    for n in range(N):
        device_maths.forward_kinematics(poses[n], skel, R, p, scratch.work, axes, True)
        cx, cy, cz = device_maths.centre_of_mass(skel, R, p)
        residual[n, 0], residual[n, 1], residual[n, 2] = device_polish.term_rows(
            term, problem_index[n], skel, terms, R, p, cx, cy, cz, axes, jac, D, 0, 0
        )
        for row in range(3):
            for d in range(D):
                jacobian[n, row, d] = jac[row * D + d]
    return residual, jacobian

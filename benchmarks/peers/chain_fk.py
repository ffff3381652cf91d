"""Vectorised forward kinematics of a chain exported by benchmarks.robot_targets.export_chain.

One implementation for NumPy (scipy's DE) and jax.numpy (evosax's DE): pass the array module
as `xp`. Only the joints on the root-to-tip path are computed. Maths as deik's: each joint's
rest rotation, then its motions in order (rotations about their axis, slides along the current
axis), then the parent's frame. Units: metres, radians.
"""

from __future__ import annotations

import numpy as np


def _skew(axis) -> np.ndarray:
    x, y, z = (float(a) for a in axis)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _axis_rotation(axis, angle, xp):
    """Rotations (N, 3, 3) about unit `axis` (3,) by `angle` (N,) rad (Rodrigues)."""
    K = _skew(axis)
    s, c = xp.sin(angle)[:, None, None], xp.cos(angle)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def tip_pose(chain: dict, Q, xp=np):
    """Q (N, D) joint values -> tip rotation (N, 3, 3) and position (N, 3) in the root frame."""
    value = Q[:, chain["source"]] * chain["scale"] + chain["bias"]
    R_parent = p_parent = None
    for k in chain["path"]:
        R = xp.asarray(chain["joint_rotation"][k])[None]
        p = xp.asarray(chain["offsets"][k])[None]
        for m in range(chain["joint_start"][k], chain["joint_start"][k + 1]):
            if chain["rotate"][m]:
                R = R @ _axis_rotation(chain["axis"][m], value[:, m], xp)
            else:
                p = p + (R @ chain["axis"][m]) * value[:, m, None]
        if R_parent is not None:
            p = p_parent + xp.einsum("nij,nj->ni", R_parent, xp.broadcast_to(p, p_parent.shape))
            R = R_parent @ R
        R_parent, p_parent = xp.broadcast_to(R, (Q.shape[0], 3, 3)), xp.broadcast_to(p, (Q.shape[0], 3))
    p_tip = p_parent + xp.einsum("nij,j->ni", R_parent, chain["tip_offset"])
    return R_parent @ chain["tip_rotation"], p_tip


def rotation_angle(R_a, R_b, xp=np):
    """Angle (N,) rad of R_a^T R_b for rotations (N, 3, 3) or (3, 3)."""
    M = xp.swapaxes(R_a, -1, -2) @ R_b
    vee = xp.stack([M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]], -1)
    trace = M[..., 0, 0] + M[..., 1, 1] + M[..., 2, 2]
    return xp.arctan2(xp.linalg.norm(vee, axis=-1) / 2, (trace - 1) / 2)


def tip_errors(chain: dict, Q, position, rotation, xp=np):
    """Tip position error (N,) m and orientation error (N,) rad of Q (N, D) against a target
    position (3,) and rotation (3, 3)."""
    R, p = tip_pose(chain, Q, xp)
    return xp.linalg.norm(p - position, axis=-1), rotation_angle(rotation, R, xp)


def load_chain(path) -> dict:
    """An exported chain (and whatever else the file holds) from its .npz file: NumPy arrays,
    with the index lists as Python ints and bools so that jax.jit can unroll over them."""
    with np.load(path) as data:
        chain = {k: data[k] for k in data.files}
    chain["path"] = [int(k) for k in chain["path"]]
    chain["joint_start"] = [int(k) for k in chain["joint_start"]]
    chain["rotate"] = [bool(r) for r in chain["rotate"]]
    return chain

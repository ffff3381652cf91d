"""Point Jacobians for the layers above the solver (a clip's warm start, `deik warmup`): the
kernels' own float64 forward kinematics with recorded motion axes and the polish's analytic
rows, so that a clip fix, the LM polish and the finite-difference tests share one derivation."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from deik.model.skeleton import Skeleton


def point_jacobians(skeleton: Skeleton, poses: np.ndarray, frames: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """World positions (N, G, 3) of `frames` (G,) (joint or site indices; -1: the centre of
    mass) at `poses` (N, D) or (D,), and their Jacobians (N, G, 3, D) in length units per radian
    (rotations) or per length unit (translations), float64. The first call compiles (or loads)
    the kernel."""
    from deik.backends.cpu import point_jacobians as compiled  # loads Numba: `import deik` stays light
    from deik.backends.pack import pack_skeleton

    poses = np.atleast_2d(np.asarray(poses, np.float64))
    return compiled(poses, np.asarray(frames, np.int64), pack_skeleton(skeleton, np.float64))

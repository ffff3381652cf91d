"""A foot the file leaves out: a leg that ends at its ankle (a joint with channels, no End Site or
toe below it) still stands on a foot, and cleanup/soles.py gives it one from the body's
proportions, pointing ahead of the rest pose on the side the knee bends to.

- Size: the ankle lies ANKLE_HEIGHT of the stature above the sole and the foot is FOOT_LENGTH of
  it long (Drillis & Contini's segment lengths: 0.039 and 0.152 of a person's height), its heel
  HEEL_BACK of the ankle-to-toe length behind the ankle (soles.py's sole, as for a drawn foot).
- Direction: in a rig's rest pose (every rotation 0: a T- or A-pose) the feet point ahead,
  square to the leg and to the line from the pelvis to the hip, and the knee bends that way:
  in every frame the knee's offset from the line between the hip and the ankle points ahead.
  Read in the ankle's own frame (the file's ankle rotations turn the foot it left out), those
  offsets, summed (a straight leg adds nothing), tell which of the two square directions is
  ahead; where the two do not agree (the knee bends more sideways than ahead, or the hip sits on
  the pelvis), the knee's bend alone is the direction. A leg that never bends (less than BENT
  of its length, on average over the frames) tells none: no foot is drawn.
"""

from __future__ import annotations

import numpy as np

from deik.model.kinematics import Kinematics

ANKLE_HEIGHT = 0.039  # of the stature
FOOT_LENGTH = 0.152  # of the stature, heel to toe tip
BENT = 0.01  # of the leg's length: the least mean bend of the knee that tells where the foot points
ALONG = 0.5  # the least cosine between the knee's bend and the rest pose's ahead for the two to agree


def foot_direction(motion: Kinematics, rest: Kinematics, leg: tuple[int, int, int], pelvis: int) -> np.ndarray | None:
    """(3,) the unit direction, in the ankle's frame, in which the foot of `leg` (hip, knee,
    ankle frame indices) points (module notes), from the clip's kinematics `motion` and the
    rig's rest pose `rest` (one pose: body.median_pose), `pelvis` the joint the hips hang from; None when the
    knee never bends."""
    hip, knee, ankle = leg
    p, R = motion.p_world_frame, motion.R_world_frame
    line = p[:, ankle] - p[:, hip]
    length = np.linalg.norm(line, axis=-1)
    along = line / np.maximum(length, 1e-300)[:, None]
    bend = p[:, knee] - p[:, hip]
    bend = bend - np.einsum("ni,ni->n", bend, along)[:, None] * along
    total = np.einsum("nji,nj->i", R[:, ankle], bend)  # each frame's bend in the ankle's frame, summed
    if np.linalg.norm(total) < BENT * length.sum():
        return None
    q = rest.p_world_frame[0]
    ahead = np.cross(q[ankle] - q[hip], q[hip] - q[pelvis])  # square to the leg and the hips
    ahead = rest.R_world_frame[0, ankle].T @ ahead
    cosine = ahead @ total / max(np.linalg.norm(ahead) * np.linalg.norm(total), 1e-300)
    if abs(cosine) < ALONG:  # a hip on the pelvis, or a knee bending sideways: its bend alone
        return total / np.linalg.norm(total)
    return ahead * np.sign(cosine) / np.linalg.norm(ahead)


def left_out_sole(
    standing: Kinematics, ankle: int, up: np.ndarray, stature: float, direction: np.ndarray
) -> tuple[float, np.ndarray]:
    """(sole height along `up`, the foot's forward (3,): a unit direction on the ground) of the
    foot below `ankle` in the standing kinematics (one pose) of a body `stature` tall, pointing
    `direction` (3,) in the ankle's frame (foot_direction)."""
    p = standing.p_world_frame[0, ankle]
    forward = standing.R_world_frame[0, ankle] @ direction
    forward = forward - (forward @ up) * up
    return float(p @ up) - ANKLE_HEIGHT * stature, forward / max(np.linalg.norm(forward), 1e-300)

"""The feet of a clip's body and the sites on their soles that the clip fix keeps on the floor
(cleanup/body.py builds the body with them). Nothing here reads a joint's name or a length unit.

Feet: in the body's standing pose (cleanup/body.py), the ends of
the body within FOOT_END x span of its lowest point (toes, not hands), each with the chain of
joints above it that lie within FOOT_CHAIN x span of that end (an ankle, a toe joint); the
chain's top is the ankle. Sole: the ground plane through the foot's lowest point in that pose
when the chain ends in an End Site (the toe tip, on the foot's surface) or in a joint without
channels (an End Site written as a joint: it turns nothing, so it only marks the tip); when it
ends in a joint with channels (a rig written without End Sites: the toe joint, inside the foot)
TOE_HEIGHT x span below it,
where the ball of a foot carries its toe joint (about 0.9 % of stature over the floor), and its
toes reach TOE_REACH of the ankle-to-toe-joint length beyond it (the ball of the foot lies at
about 0.7 of the way from the ankle to the toe tip). A leg that ends at its ankle (a chain of
one joint with channels) stands on a foot drawn from the body's proportions (bare_ankles.py).
On it lie the foot's sole sites, fixed in the ankle's frame (the toe's in the frame carrying the
toe tip): its heel, HEEL_BACK of the ankle-to-toe length behind the ankle, its toe under the toe
tip, and each flanked by two sites SOLE_WIDTH of the foot's length to either side. A foot whose
toe joint the capture turns (by more than its noise, model.capsules.STILL_TURN) bends there, so
its ball, under the toe joint, gets three more sites in the frame of the toe joint's parent:
without them the floor held the heel and the toe tip only, and a fix that bent the toe let the
ball sink (the shared punch on a rig whose toes bend: 8.4 mm under the floor).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deik.cleanup.bare_ankles import FOOT_LENGTH, foot_direction, left_out_sole
from deik.model.capsules import body_root, bone_starts
from deik.model.kinematics import Kinematics
from deik.model.skeleton import Skeleton

FOOT_END = 0.12
FOOT_CHAIN = 0.07
HEEL_BACK = 0.33
SOLE_WIDTH = 0.25
TOE_HEIGHT = 0.007  # of the span: a toe joint's centre over the sole (1.5 cm on the shared humanoid)
TOE_REACH = 0.4  # of the ankle-to-toe-joint length: how far the toes reach beyond their joint
SOLE_SITES = ("heel", "heel_left", "heel_right", "toe", "toe_left", "toe_right", "ball", "ball_left", "ball_right")


@dataclass(frozen=True)
class Foot:
    """One foot: `ankle` (the top joint of its chain), `chain` (its joints and tip, frame names,
    top first), and the names of its sole sites in SOLE_SITES order."""

    ankle: str
    chain: tuple[str, ...]
    soles: tuple[str, ...]

    @property
    def heel(self) -> str:
        return self.soles[0]

    @property
    def toe(self) -> str:
        return self.soles[3]


def _along_ground(p: np.ndarray, a: int, b: int, up: np.ndarray) -> float:
    """The distance along the ground between frames a and b at positions p (F, 3)."""
    delta = p[b] - p[a]
    return float(np.linalg.norm(delta - (delta @ up) * up))


def body_ends(skeleton: Skeleton, part: np.ndarray) -> np.ndarray:
    """(F,) bool: the frames of the body (`part` (F,) bool) that no bone of it leaves (a hand
    whose fingers are no part of it, model.capsules.digit_joints, is an end)."""
    start = bone_starts(skeleton)
    leaves = np.ones(skeleton.n_frames, bool)
    leaves[start[(start >= 0) & part]] = False
    return leaves & part


def foot_chains(skeleton: Skeleton, p: np.ndarray, part: np.ndarray, span: float) -> list[tuple[int, ...]]:
    """Per foot, its chain (frame indices, top first, the tip last) in the standing positions p
    (F, 3) of the body `part` (F,) bool (module notes)."""
    start = bone_starts(skeleton)
    height = p @ skeleton.up
    lowest = height[part].min()
    chains = {}
    for tip in np.flatnonzero(body_ends(skeleton, part) & (height <= lowest + FOOT_END * span)):
        chain, f = [int(tip)], int(start[tip])
        while f >= 0 and part[f] and height[f] <= height[tip] + FOOT_CHAIN * span and f < skeleton.n_joints:
            chain.insert(0, f)
            f = int(start[f])
        if len(chain) < 2 and not (tip < skeleton.n_joints and tip in skeleton.dof_joint):
            continue  # one point alone is a foot only where the leg ends at its ankle (bare_ankles.py)
        ankle = chain[0]  # one foot per ankle: the tip farthest from it along the ground
        if ankle not in chains or _along_ground(p, ankle, tip, skeleton.up) > _along_ground(
            p, ankle, chains[ankle][-1], skeleton.up
        ):
            chains[ankle] = tuple(chain)
    return list(chains.values())


def _free_name(taken: set[str], name: str) -> str:
    k = 2
    out = name
    while out in taken:
        out, k = f"{name}{k}", k + 1
    taken.add(out)
    return out


def toe_joint(chain: tuple[int, ...], turning: np.ndarray) -> int | None:
    """The first joint below the ankle of the foot `chain` that the capture turns (`turning` (J,)
    bool), or None."""
    toes = [f for f in chain[1:] if f < len(turning) and turning[f]]
    return toes[0] if toes else None


def sole_sites(
    skeleton: Skeleton, chain: tuple[int, ...], kin: Kinematics, heel: np.ndarray, toe: np.ndarray, bend: int | None
) -> list:
    """Sites [(name, frame name, offset in its frame)] of the foot `chain` in the standing
    kinematics `kin` (one pose), its `heel` and `toe` (3,) on the sole (sole_points), and
    under the toe joint `bend` (None: none that turns) its ball (module notes: Sole)."""
    up = skeleton.up
    forward = toe - heel
    along = forward / max(np.linalg.norm(forward), 1e-300)
    side = np.cross(up, along) * SOLE_WIDTH * np.linalg.norm(forward)
    ankle = chain[0]
    carrier = chain[-2] if chain[-1] >= skeleton.n_joints else chain[-1]  # the joint that carries the tip
    names = skeleton.frame_names
    taken = set(names)
    spots = [
        ("heel", heel, ankle),
        ("heel_left", heel + side, ankle),
        ("heel_right", heel - side, ankle),
        ("toe", toe, carrier),
        ("toe_left", toe + side, carrier),
        ("toe_right", toe - side, carrier),
    ]
    if bend is not None:
        ball = heel + ((kin.p_world_frame[0, bend] - heel) @ along) * along
        parent = int(bone_starts(skeleton)[bend])
        spots += [("ball", ball, parent), ("ball_left", ball + side, parent), ("ball_right", ball - side, parent)]
    sites = []
    for name, point, frame in spots:
        R, origin = kin.R_world_frame[0, frame], kin.p_world_frame[0, frame]
        sites.append((_free_name(taken, f"{names[ankle]}_{name}"), names[frame], R.T @ (point - origin)))
    return sites


def sole_points(
    skeleton: Skeleton,
    chain: tuple[int, ...],
    kin: Kinematics,
    clip_kin: tuple[Kinematics, Kinematics],
    span: float,
    stature: float,
) -> tuple[float, np.ndarray, np.ndarray] | None:
    """(sole height along up, heel (3,), toe tip (3,) on the sole) of the foot `chain` (frame
    indices, top first) in the standing kinematics `kin` (module notes: Sole); a leg that ends
    at its ankle takes a foot from the body's proportions, from `clip_kin`: the clip's
    kinematics and its rest pose's (median_pose) (bare_ankles.py); None when its knee never
    bends."""
    up, p = skeleton.up, kin.p_world_frame[0]
    ankle, tip = chain[0], chain[-1]
    inside = False
    if len(chain) == 1:
        start = bone_starts(skeleton)
        knee = int(start[ankle])
        direction = foot_direction(*clip_kin, (int(start[knee]), knee, ankle), body_root(skeleton))
        if direction is None:
            return None
        sole, forward = left_out_sole(kin, ankle, up, stature, direction)
        forward = forward * FOOT_LENGTH * stature / (1.0 + HEEL_BACK)  # from the ankle to the toe tip
    else:
        # a toe joint inside the foot; a joint that turns nothing only marks the tip, as an End Site does
        inside = tip < skeleton.n_joints and tip in skeleton.dof_joint
        sole = (p[list(chain)] @ up).min() - (TOE_HEIGHT * span if inside else 0.0)
        forward = (p[tip] - p[ankle]) - ((p[tip] - p[ankle]) @ up) * up
    base = p[ankle] + (sole - p[ankle] @ up) * up  # under the ankle, on the sole
    toe = base + forward * (1.0 + (TOE_REACH if inside else 0.0))  # the toes reach beyond a toe joint
    return sole, base - HEEL_BACK * forward, toe

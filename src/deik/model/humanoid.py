"""A built-in full-body character: `humanoid(height, mass)` returns a 21-joint, 48-DOF Skeleton.

Axes: Y is up, the character faces +Z and its left is +X. Units: metres, kilograms, radians.
At rest (every DOF 0) it stands upright with straight legs, arms hanging at its sides and both
soles flat on y = 0; the rest pose is also the reference (comfort) pose.

Sources. Limb lengths, joint heights, shoulder width and foot size are fractions of stature
from Drillis & Contini (1966) as drawn in Winter, "Biomechanics and Motor Control of Human
Movement", Fig. 4.1. The trunk and head split at suprasternale, xiphion, omphalion and
mid-gonion, and the hand length to the third knuckle, come from de Leva's (1996) mean male
lengths divided by his mean stature. Segment masses and centre-of-mass positions are de Leva
(1996), "Adjustments to Zatsiorsky-Seluyanov's segment inertia parameters", J. Biomech. 29(9),
Table 4, males. Lateral offsets and foot landmarks that neither table gives are estimates,
marked where set. Ranges of motion are rounded typical active ranges of healthy adults.
"""

from __future__ import annotations

import math
import numbers

from deik.errors import InputError
from deik.model.anthropometry import DE_LEVA, DE_LEVA_TOTAL, HAND, HEAD, LOWER_TRUNK, MIDDLE_TRUNK, UPPER_TRUNK
from deik.model.build import build_skeleton
from deik.model.joints import Joint, Segment, Site, euler, hinge, translation
from deik.model.skeleton import Skeleton

SIDES = (("left", 1.0), ("right", -1.0))
ORIGIN = (0.0, 0.0, 0.0)

# Heights above the floor at rest, as fractions of stature (Drillis & Contini).
HIP_HEIGHT, KNEE_HEIGHT, ANKLE_HEIGHT, SHOULDER_HEIGHT = 0.530, 0.285, 0.039, 0.818
UPPER_ARM, FOREARM = 0.186, 0.146
SHOULDER_WIDTH, FOOT_LENGTH, FOOT_WIDTH = 0.259, 0.152, 0.055

NECK_BASE = HIP_HEIGHT + LOWER_TRUNK + MIDDLE_TRUNK + UPPER_TRUNK  # suprasternale height

# Estimates (fractions of stature unless noted).
HIP_HALF_SPAN = 0.050  # hip joint centres about 17-18 cm apart in a 1.75 m adult
STERNOCLAVICULAR_HALF_SPAN = 0.017
GRASP = 0.046  # palm centre below the wrist, about 8 cm at 1.75 m
TOE_JOINT_HEIGHT = 0.010  # metatarsophalangeal joint centre above the sole
# Along the foot, as fractions of its heel-to-toe-tip length measured from the heel.
ANKLE_ALONG_FOOT, INNER_BALL_ALONG_FOOT, OUTER_BALL_ALONG_FOOT, TOE_JOINT_ALONG_FOOT = (0.22, 0.73, 0.63, 0.70)

# Ranges of motion (lower, upper) per Euler channel, radians, written for the LEFT side.
# Signs: +X rotation bends the trunk and head forward, swings a limb backwards and points the
# foot down; +Z tips a left limb outwards (+X) and the trunk to the right; +Y turns a left limb
# outwards (left shoulder and hip: external rotation).
PELVIS_TRAVEL = {"XZ": (-0.6, 0.6), "Y": (-0.35, 0.15)}  # fractions of stature from rest
ROM = {
    "pelvis": ("ZXY", (-0.8, -0.8, -math.pi / 2), (0.8, math.pi / 2, math.pi / 2)),
    "spine": ("ZXY", (-0.35, -0.35, -0.2), (0.35, 0.9, 0.2)),
    "chest": ("ZXY", (-0.35, -0.3, -0.6), (0.35, 0.6, 0.6)),
    "neck": ("ZXY", (-0.6, -0.9, -0.9), (0.6, 0.8, 0.9)),
    "head": ("ZXY", (-0.2, -0.35, -0.4), (0.2, 0.35, 0.4)),
    "clavicle": ("ZY", (-0.15, -0.3), (0.3, 0.3)),  # positive: elevation, retraction
    # shoulder and hip, positive: abduction, extension, external rotation
    "shoulder": ("ZXY", (-0.5, -2.8, -1.2), (2.8, 0.9, 1.5)),
    "wrist": ("ZX", (-1.4, -0.35), (1.2, 0.55)),  # palm to thigh; positive: extension, ulnar
    "hip": ("ZXY", (-0.5, -2.1, -0.7), (0.8, 0.5, 0.8)),
    "ankle": ("XZ", (-0.35, -0.6), (0.85, 0.35)),  # positive: plantarflexion, eversion
}
ELBOW_FLEXION, KNEE_FLEXION, TOE_EXTENSION = (0.0, 2.6), (0.0, 2.5), (-0.35, 0.7)


def _check_positive(name: str, value, example: str) -> float:
    if isinstance(value, numbers.Real) and math.isfinite(value) and value > 0:
        return float(value)
    raise InputError(f"humanoid {name} must be a finite positive number, got {value!r}; pass e.g. {example}")


def _rom(joint: str, side_sign: float = 1.0):
    """Euler DOFs of `joint` with its ROM limits; the right side (side_sign -1) is the mirror.

    Mirroring in the x = 0 plane keeps rotations about X and reverses those about Y and Z, so
    the right side's Y and Z ranges are the left's negated, ends swapped.
    """
    order, lower, upper = ROM[joint]
    lower, upper = list(lower), list(upper)
    if side_sign < 0:
        for k, axis in enumerate(order):
            if axis in "YZ":
                lower[k], upper[k] = -upper[k], -lower[k]
    return euler(order, lower, upper)


def _scaled(h: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    return (x * h, y * h, z * h)


def _axial(h: float):
    """Pelvis to head: joints, the head_top site and the (segment, joint, ends) of each part."""
    neck_length = (1.0 - HEAD) - NECK_BASE  # suprasternale up to mid-gonion, the head's pivot
    travel_xz, travel_y = PELVIS_TRAVEL["XZ"], PELVIS_TRAVEL["Y"]
    root_dofs = (
        translation("X", travel_xz[0] * h, travel_xz[1] * h)
        + translation("Y", travel_y[0] * h, travel_y[1] * h)
        + translation("Z", travel_xz[0] * h, travel_xz[1] * h)
        + _rom("pelvis")
    )
    joints = [
        Joint("pelvis", None, _scaled(h, 0, HIP_HEIGHT, 0), root_dofs),
        Joint("spine", "pelvis", _scaled(h, 0, LOWER_TRUNK, 0), _rom("spine")),
        Joint("chest", "spine", _scaled(h, 0, MIDDLE_TRUNK, 0), _rom("chest")),
        Joint("neck", "chest", _scaled(h, 0, UPPER_TRUNK, 0), _rom("neck")),
        Joint("head", "neck", _scaled(h, 0, neck_length, 0), _rom("head")),
    ]
    sites = [Site("head_top", "head", _scaled(h, 0, HEAD, 0))]
    # Each part runs from its upper end (listed first in the table) down to the joint carrying it.
    parts = [
        ("head", "head", HEAD),
        ("upper_trunk", "chest", UPPER_TRUNK),
        ("middle_trunk", "spine", MIDDLE_TRUNK),
        ("lower_trunk", "pelvis", LOWER_TRUNK),
    ]
    ends = [(name, joint, _scaled(h, 0, length, 0), ORIGIN) for name, joint, length in parts]
    return joints, sites, ends


def _limbs(h: float, side: str, s: float):
    """One side's arm and leg (s = +1 left, -1 right): joints, sites and segment ends."""
    elbow, wrist = _scaled(h, 0, -UPPER_ARM, 0), _scaled(h, 0, -FOREARM, 0)
    knee = _scaled(h, 0, KNEE_HEIGHT - HIP_HEIGHT, 0)
    ankle = _scaled(h, 0, ANKLE_HEIGHT - KNEE_HEIGHT, 0)
    shoulder = _scaled(h, s * (SHOULDER_WIDTH / 2 - STERNOCLAVICULAR_HALF_SPAN), SHOULDER_HEIGHT - NECK_BASE, 0)

    def on_foot(x: float, y: float, fraction: float) -> tuple[float, float, float]:
        """Ankle-frame point at x, y (stature fractions), `fraction` of the foot from the heel."""
        return (x * h, y * h, (fraction - ANKLE_ALONG_FOOT) * FOOT_LENGTH * h)

    sole, ball = -ANKLE_HEIGHT, FOOT_WIDTH / 2  # the floor seen from the ankle; ball half-width
    heel, toe_tip = on_foot(0, sole, 0.0), on_foot(0, sole, 1.0)
    toe_joint = on_foot(0, TOE_JOINT_HEIGHT - ANKLE_HEIGHT, TOE_JOINT_ALONG_FOOT)
    joints = [
        Joint(
            f"{side}_clavicle", "chest", _scaled(h, s * STERNOCLAVICULAR_HALF_SPAN, UPPER_TRUNK, 0), _rom("clavicle", s)
        ),
        Joint(f"{side}_shoulder", f"{side}_clavicle", shoulder, _rom("shoulder", s)),
        Joint(f"{side}_elbow", f"{side}_shoulder", elbow, hinge((-1, 0, 0), *ELBOW_FLEXION, label="flexion")),
        Joint(f"{side}_wrist", f"{side}_elbow", wrist, _rom("wrist", s)),
        Joint(f"{side}_hip", "pelvis", _scaled(h, s * HIP_HALF_SPAN, 0, 0), _rom("hip", s)),
        Joint(f"{side}_knee", f"{side}_hip", knee, hinge((1, 0, 0), *KNEE_FLEXION, label="flexion")),
        Joint(f"{side}_ankle", f"{side}_knee", ankle, _rom("ankle", s)),
        Joint(f"{side}_toes", f"{side}_ankle", toe_joint, hinge((-1, 0, 0), *TOE_EXTENSION, label="extension")),
    ]
    sites = [
        Site(f"{side}_hand", f"{side}_wrist", _scaled(h, 0, -GRASP, 0)),
        Site(f"{side}_heel", f"{side}_ankle", heel),
        Site(f"{side}_toe_inner", f"{side}_ankle", on_foot(-s * ball, sole, INNER_BALL_ALONG_FOOT)),
        Site(f"{side}_toe_outer", f"{side}_ankle", on_foot(s * ball, sole, OUTER_BALL_ALONG_FOOT)),
        Site(f"{side}_toe_tip", f"{side}_toes", tuple(tip - joint for tip, joint in zip(toe_tip, toe_joint))),
    ]
    ends = [
        ("upper_arm", f"{side}_shoulder", ORIGIN, elbow),
        ("forearm", f"{side}_elbow", ORIGIN, wrist),
        ("hand", f"{side}_wrist", ORIGIN, _scaled(h, 0, -HAND, 0)),
        ("thigh", f"{side}_hip", ORIGIN, knee),
        ("shank", f"{side}_knee", ORIGIN, ankle),
        ("foot", f"{side}_ankle", heel, toe_tip),
    ]
    return joints, sites, [(f"{side}_{name}", *rest) for name, *rest in ends]


def humanoid(height: float = 1.75, mass: float = 70.0) -> Skeleton:
    """A standing full-body character `height` metres tall weighing `mass` kilograms.

    Joints: pelvis (root: 3 translations + ZXY), spine, chest, neck, head (ZXY each), and per
    side clavicle (ZY), shoulder (ZXY), elbow (flexion hinge), wrist (ZX), hip (ZXY), knee
    (flexion hinge), ankle (XZ), toes (extension hinge): 48 DOFs. Sites: head_top and per side
    hand (palm centre), heel, toe_inner, toe_outer (ball of the foot), toe_tip.
    """
    h = _check_positive("height", height, "height=1.75 (metres)")
    mass = _check_positive("mass", mass, "mass=70.0 (kilograms)")
    joints, sites, ends = _axial(h)
    for side, s in SIDES:
        side_joints, side_sites, side_ends = _limbs(h, side, s)
        joints, sites, ends = joints + side_joints, sites + side_sites, ends + side_ends
    segments = []
    for name, joint, first, second in ends:
        percent, com_fraction = DE_LEVA[name.removeprefix("left_").removeprefix("right_")]
        com = tuple(a + com_fraction * (b - a) for a, b in zip(first, second))
        segments.append(Segment(joint, mass * percent / DE_LEVA_TOTAL, com, name))
    return build_skeleton(joints, sites, segments, up=(0.0, 1.0, 0.0), name="humanoid")

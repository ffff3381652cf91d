"""Segment masses for BVH characters: read a JSON segment table, or estimate masses from bone
lengths with de Leva's (1996) anthropometric fractions when there is none.

A table (docs/formats.md, "Segment tables") lists {"bvh_frame" or "joint", "mass_kg",
"com_offset_m"} objects under "segments". The estimate classifies each bone by its joint name
(head, trunk, upper arm, forearm, hand, thigh, shank, foot); units: kg and the skeleton's length
unit.
"""

from __future__ import annotations

import math
import re
from collections import Counter, defaultdict
from collections.abc import Sequence

import numpy as np

from deik.errors import FileFormatError, InputError
from deik.io.files import FilePath, number_value, numbers_value, read_json
from deik.model.anthropometry import DE_LEVA, DE_LEVA_TOTAL, LOWER_TRUNK, MIDDLE_TRUNK, UPPER_TRUNK
from deik.model.capsules import carrier_joints, rider_joints, seat_anchors
from deik.model.joints import Segment
from deik.model.skeleton import MAX_LENGTH, MAX_MASS, Skeleton
from deik.suggest import did_you_mean

NOMINAL_MASS = 70.0  # kg; only mass fractions matter for the centre of mass


def _trunk() -> tuple[float, float]:
    """de Leva's three trunk parts as one segment: (percent, COM fraction from its lower end)."""
    parts = [("upper_trunk", UPPER_TRUNK), ("middle_trunk", MIDDLE_TRUNK), ("lower_trunk", LOWER_TRUNK)]
    length = sum(size for _, size in parts)
    percent, moment, top = 0.0, 0.0, 0.0  # moment: percent x COM distance below the top
    for name, size in parts:
        share, from_top = DE_LEVA[name]
        percent, moment, top = percent + share, moment + share * (top + from_top * size), top + size
    return percent, 1.0 - moment / percent / length


TRUNK_PERCENT, TRUNK_COM = _trunk()
# Class -> (mass fraction per segment, COM fraction along the bone from the joint, paired).
# de Leva gives the head's COM from the vertex; our head bones point up, hence 1 - 0.5976.
BONE_CLASSES = {
    "head": (DE_LEVA["head"][0] / DE_LEVA_TOTAL, 1.0 - DE_LEVA["head"][1], False),
    "trunk": (TRUNK_PERCENT / DE_LEVA_TOTAL, TRUNK_COM, False),
    **{
        name: (DE_LEVA[key][0] / DE_LEVA_TOTAL, DE_LEVA[key][1], True)
        for name, key in (
            ("upper_arm", "upper_arm"),
            ("forearm", "forearm"),
            ("hand", "hand"),
            ("thigh", "thigh"),
            ("shank", "shank"),
            ("foot", "foot"),
        )
    },
}
# A limb bone whose end segment has no bone of its own (a rig whose forearm ends at an End Site
# for the hand) carries that segment's mass too, at its end.
ENDS = {"forearm": "hand", "shank": "foot"}
# First match wins, so "forearm" is tested before "arm" and "upleg" before "leg".
KEYWORDS = (
    ("hand", ("hand", "wrist", "finger", "thumb")),
    ("forearm", ("forearm", "lowerarm", "elbow")),
    ("upper_arm", ("upperarm", "arm", "shoulder", "shldr", "clavicle", "collar")),
    ("foot", ("foot", "ankle", "toe")),
    ("thigh", ("thigh", "upleg", "upperleg")),
    ("shank", ("shin", "calf", "knee", "lowerleg", "leg")),
    ("head", ("head", "neck")),
    ("trunk", ("spine", "chest", "torso", "abdomen", "hips", "hip", "pelvis", "root")),
)


def bone_side(name: str) -> str:
    """ "left", "right" or "" from a joint name: Left/Right anywhere, or an L/R set off by a
    separator or a change of case (lShldr, LHip, L_Hip, hip_r, ThighL)."""
    for side in ("left", "right"):
        letters = f"[{side[0]}{side[0].upper()}]"
        pattern = (
            rf"^{letters}(?=[A-Z_.\-])|[_.\-]{letters}(?=$|[_.\-])"
            rf"|(?<=[a-z]){side[0].upper()}$"
        )
        if side in name.lower() or re.search(pattern, name):
            return side
    return ""


def bone_class(name: str) -> str | None:
    """The de Leva segment class of the bone carried by joint `name`, or None. "hip" with a side
    (LeftHip) is a thigh, without one (Hips) the pelvis."""
    lower, side = name.lower(), bone_side(name)
    if "hip" in lower and side and not any(k in lower for k in ("spine", "pelvis")):
        return "thigh"
    return next((cls for cls, words in KEYWORDS if any(w in lower for w in words)), None)


def _bone_ends(sk: Skeleton, riding: np.ndarray) -> np.ndarray:
    """(J, 3) end of each joint's bone in its frame: the mean of its children's and sites' origins
    (its own origin when it has none), the `riding` (J,) bool twist bones aside (rider_joints).
    A joint sitting at its parent's origin (seat_anchors) has no bone: its children and sites
    count for the joint it sits on, whose frame it shares at rest."""
    anchor = seat_anchors(sk)
    total, count = np.zeros((sk.n_joints, 3)), np.zeros(sk.n_joints)
    for k in range(1, sk.n_joints):
        if anchor[k] == k and not riding[k]:
            total[anchor[sk.parents[k]]] += sk.offsets[k]
            count[anchor[sk.parents[k]]] += 1
    for s, k in enumerate(sk.site_joint):
        if riding[k]:
            continue
        total[anchor[k]] += sk.site_offset[s]
        count[anchor[k]] += 1
    return total / np.maximum(count, 1)[:, None]


def estimate_segments(skeleton: Skeleton, total_mass: float = NOMINAL_MASS) -> tuple[tuple[Segment, ...], str]:
    """Estimate segment masses (kg) and COM offsets (length units) from bone lengths.

    Each joint's bone runs from its origin to the mean of its children's origins; joints that
    carry the body without being part of it (deik.model.capsules.carrier_joints) and twist
    bones riding on a limb (rider_joints) get none. Classified
    bones share de Leva's fraction for their class (per side for limbs) by length, with the
    COM at de Leva's position along the bone; a forearm or shank whose side has no hand or foot
    bone carries that end's fraction too, at the bone's end (ENDS); unclassified bones share
    the rest by length, COM at mid-bone. Returns (tuple of Segment with positive masses summing to total_mass,
    description of what was done).
    """
    if not (math.isfinite(total_mass) and total_mass > 0):
        raise InputError(f"total_mass must be a positive number of kg, got {total_mass}")
    riding = rider_joints(skeleton)
    ends = _bone_ends(skeleton, riding)
    bare = carrier_joints(skeleton) | riding  # a carrier or a twist bone is no body part
    lengths = np.where(bare, 0.0, np.linalg.norm(ends, axis=1))
    names = skeleton.joint_names
    classes = [bone_class(n) if lengths[k] > 0 else None for k, n in enumerate(names)]
    groups = defaultdict(list)  # (class, side) -> joints
    for k, cls in enumerate(classes):
        if cls is not None:
            groups[(cls, bone_side(names[k]) if BONE_CLASSES[cls][2] else "")].append(k)
    share = np.zeros(skeleton.n_joints)
    along = [BONE_CLASSES[c][1] if c else 0.5 for c in classes]  # COM fraction along each bone
    carried = {}  # limb class -> the end class it carries on some side
    for (cls, side), members in groups.items():
        fraction = BONE_CLASSES[cls][0]
        end = ENDS.get(cls)
        if end is not None and (end, side) not in groups:  # the limb's bone ends at its hand or foot
            held = BONE_CLASSES[end][0]
            for k in members:  # the end's mass at the bone's end
                along[k] = (fraction * along[k] + held) / (fraction + held)
            fraction += held
            carried[cls] = end
        share[members] = fraction * lengths[members] / lengths[members].sum()
    unclassified = [k for k, cls in enumerate(classes) if cls is None and lengths[k] > 0]
    rest = max(1.0 - share.sum(), 0.0)
    if unclassified:
        share[unclassified] = rest * lengths[unclassified] / lengths[unclassified].sum()
    if share.sum() <= 0:
        return (
            (Segment(names[0], float(total_mass), (0.0, 0.0, 0.0), "whole body"),),
            f"no bone has a length: all {total_mass:g} kg (nominal) put at the root "
            f"{names[0]!r}, so the centre of mass is the root's origin",
        )
    scale = 1.0 / share.sum()
    share *= scale
    segments = tuple(
        Segment(
            names[k],
            float(total_mass * share[k]),
            tuple(float(v) for v in ends[k] * along[k]),
            classes[k] or "unclassified",
        )
        for k in range(skeleton.n_joints)
        if share[k] > 0
    )
    counts = Counter(c for c in classes if c)
    missing = [c for c in BONE_CLASSES if not counts[c]]
    found = ", ".join(f"{counts[c]} {c}" for c in BONE_CLASSES if counts[c]) or "none"
    notes = ["estimated from bone lengths with de Leva (1996) mass fractions", f"classified bones: {found}"]
    if missing:
        notes.append(f"no {', '.join(missing)} bones")
    notes += [f"the {end}s' mass on the {limb}s" for limb, end in carried.items()]
    if unclassified:
        notes.append(
            f"{len(unclassified)} unclassified bones share the remaining {share[unclassified].sum():.1%} by length"
        )
    if abs(scale - 1.0) > 1e-9:
        notes.append(f"masses scaled by {scale:.4g} to add up to the total")
    notes.append(f"total {total_mass:g} kg nominal (only the fractions matter for the centre of mass)")
    return segments, "; ".join(notes)


def _fail(source: str, element: str, problem: str):
    raise FileFormatError(source, problem, element=element)


def _vector(source: str, element: str, value) -> tuple[float, float, float]:
    return numbers_value(value, source, element, 3, -MAX_LENGTH, MAX_LENGTH)


def read_segment_table(path: FilePath, joint_names: Sequence[str]) -> tuple[tuple[Segment, ...], str]:
    """Read a JSON segment table for a skeleton with `joint_names`.

    Top level: {"segments": [{"bvh_frame" or "joint": name, "mass_kg": kg >= 0,
    "com_offset_m": [x, y, z] in the joint's frame and the skeleton's length unit,
    optional "name" or "urdf_link"}, ...]}; other keys are ignored. Returns (segments,
    description). Malformed tables raise FileFormatError naming the file and element.
    """
    source = str(path)
    table = read_json(path, "segment table (JSON)")
    items = table.get("segments") if isinstance(table, dict) else None
    if not isinstance(items, list) or not items:
        _fail(source, "segments", 'the top level must be an object with a non-empty "segments" list')
    known = list(joint_names)
    segments = []
    for k, item in enumerate(items):
        where = f"segments[{k}]"
        if not isinstance(item, dict):
            _fail(source, where, "must be an object with bvh_frame (or joint), mass_kg and com_offset_m")
        joints = [item[key] for key in ("joint", "bvh_frame") if key in item]
        if not joints or not all(isinstance(j, str) for j in joints) or len(set(joints)) != 1:
            _fail(source, where, 'needs one joint name (a string), as "bvh_frame" or "joint"')
        joint = joints[0]
        if joint not in known:
            hint = did_you_mean(joint, known)
            key = "joint" if "joint" in item else "bvh_frame"
            _fail(source, f"{where}.{key}", f"unknown joint {joint!r:.60}{hint}")
        if "mass_kg" not in item or "com_offset_m" not in item:
            _fail(source, where, 'needs "mass_kg" and "com_offset_m"')
        mass = number_value(item["mass_kg"], source, f"{where}.mass_kg", 0.0, MAX_MASS)
        offset = _vector(source, f"{where}.com_offset_m", item["com_offset_m"])
        name = item.get("name", item.get("urdf_link", ""))
        segments.append(Segment(joint, float(mass), offset, name if isinstance(name, str) else ""))
    total = sum(s.mass for s in segments)
    if total <= 0:
        _fail(source, "segments", "the masses add up to 0 kg; at least one must be positive")
    return tuple(segments), f"segment table {source}: {len(segments)} segments, {total:.6g} kg"

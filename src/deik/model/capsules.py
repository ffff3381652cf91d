"""Bones as capsules, for self-collision: which frame each bone starts from, how many links apart
two bones are, and default capsule radii from the segment masses.

A bone ends at every frame but the root (F - 1 bones) and starts at its parent joint (a joint)
or at the joint it hangs from (a site); bone k is named by its end frame k. Its capsule is the
segment between the two frame origins, swept by a sphere of the radius of the joint it starts
from (every bone leaving a joint shares that joint's radius). Lengths are the skeleton's units.
"""

from __future__ import annotations

import weakref
from dataclasses import replace

import numpy as np

from deik.model.joints import ROTATE
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton

# Volume of the whole body over its height cubed: a 70 kg, 1.75 m adult (the humanoid's
# defaults) at a typical whole-body density of 1,060 kg/m^3. Scale-free, so it holds in any
# length unit; masses count only as fractions of the total.
BODY_VOLUME = (70.0 / 1060.0) / 1.75**3
MASSLESS_RADIUS = 0.1  # of the longest bone leaving the joint, on skeletons without masses
DIGITS, DIGIT_REACH = 3, 0.25  # branches of one joint, of the body's longest path: fingers (digit_joints)
STILL_TURN = np.radians(2.0)  # a rotation channel turning less over a clip is still: capture noise
RIDER_SPAN, RIDER_SPREAD = 0.05, 0.15  # of the bone a rider hangs on (rider_joints)


def bone_starts(skeleton: Skeleton) -> np.ndarray:
    """(F,) the frame each bone starts from: bone k runs from bone_starts[k] to frame k; -1 for
    the root, which ends no bone."""
    return np.concatenate([[-1], skeleton.parents[1:], skeleton.site_joint]).astype(np.int64)


def seat_anchors(skeleton: Skeleton) -> np.ndarray:
    """(J,) per joint the joint it sits on: itself, or for a joint at its parent's origin (a zero
    OFFSET and no translation DOF, as the CMU rigs' LHipJoint sits at the Hips) the joint its
    parent sits on. A body has no bone there: the two are one point."""
    J = skeleton.n_joints
    translates = np.zeros(J, bool)
    np.logical_or.at(translates, skeleton.dof_joint, skeleton.dof_kind != ROTATE)
    scale = max(float(np.abs(skeleton.offsets).max(initial=0.0)), 1e-300)
    seated = (np.linalg.norm(skeleton.offsets, axis=1) <= 1e-12 * scale) & ~translates
    return joined_to_parents(skeleton, seated)


def joined_to_parents(skeleton: Skeleton, joined: np.ndarray) -> np.ndarray:
    """(J,) per joint the first joint at or above it that is not `joined` (J,) bool to its
    parent (the root never is): the joint it moves with."""
    label = np.arange(skeleton.n_joints)
    for j in range(1, skeleton.n_joints):  # parents come first
        if joined[j]:
            label[j] = label[skeleton.parents[j]]
    return label


def frame_offsets(skeleton: Skeleton) -> np.ndarray:
    """(F, 3) each joint's OFFSET then each site's, in its parent's frame: the bones as the file
    draws them (a rig's translation channels aside)."""
    return np.concatenate([skeleton.offsets, skeleton.site_offset])


def bone_lengths(skeleton: Skeleton, pose: np.ndarray | None = None) -> np.ndarray:
    """(F,) each bone's length in `pose` (D,) (default the reference pose; 0 for the root)."""
    start = bone_starts(skeleton)
    p = forward_kinematics(skeleton, skeleton.reference if pose is None else pose).p_world_frame
    return np.where(start >= 0, np.linalg.norm(p - p[np.maximum(start, 0)], axis=-1), 0.0)


def carrier_joints(skeleton: Skeleton) -> np.ndarray:
    """(J,) bool: the joints above the body, which carry it but are no part of it (a `Reference`
    or `root` joint on the ground above a character's hips): the chain from the root down to
    the first joint with two or more children, when the root has no site and that joint exists.
    A body branches at its pelvis; a chain (a robot arm) has no carrier. Helper joints
    (skeleton.helpers) are no children."""
    moving = ~skeleton.helpers
    children = np.bincount(skeleton.parents[1:], weights=moving[1:], minlength=skeleton.n_joints).astype(np.int64)
    sites = np.bincount(skeleton.site_joint, minlength=skeleton.n_joints)
    out = np.zeros(skeleton.n_joints, bool)
    k = 0
    while children[k] == 1 and sites[k] == 0:
        out[k] = True
        k = int(np.flatnonzero((skeleton.parents == k) & moving)[0])
    return out if children[k] >= 2 else np.zeros(skeleton.n_joints, bool)


def on_joints(skeleton: Skeleton, joints: np.ndarray) -> np.ndarray:
    """(F,) bool: `joints` (J,) bool, and the sites on them."""
    return np.concatenate([joints, joints[skeleton.site_joint]])


def off_body(skeleton: Skeleton) -> np.ndarray:
    """(F,) bool: the joints and sites that are no part of the body: the carriers and the
    helpers (skeleton.helpers), and the sites on them."""
    return on_joints(skeleton, carrier_joints(skeleton) | skeleton.helpers)


def still_branches(skeleton: Skeleton, frames: np.ndarray, turn: float = 0.0) -> np.ndarray:
    """(J,) bool: the joints that, with every joint below them, never move against their
    parents over `frames` (N, D) (every DOF keeps one value through the clip, a rotation to
    within `turn` radians: capture noise); none when the clip has fewer than two frames."""
    frames = np.asarray(frames, float)
    J = skeleton.n_joints
    if len(frames) < 2:
        return np.zeros(J, bool)
    within = np.where(skeleton.dof_kind == ROTATE, turn, 0.0)
    fixed = np.ptp(frames, axis=0) <= np.maximum(within, 1e-9 * np.maximum(1.0, np.abs(frames).max(axis=0)))
    still = np.array([fixed[skeleton.joint_dof_start[j] : skeleton.joint_dof_start[j + 1]].all() for j in range(J)])
    for j in range(J - 1, 0, -1):  # children after parents: reversed is bottom-up
        still[skeleton.parents[j]] &= still[j]
    return still


def helper_joints(skeleton: Skeleton, frames: np.ndarray) -> np.ndarray:
    """(J,) bool: the helpers of a clip's `frames` (N, D) on `skeleton`: branches that never move
    against their parents (still_branches) hanging from the joints that carry the body
    (carrier_joints, counting such branches as no children) and starting where the carrier is
    (no offset from it), as a game rig's IK target roots do, a hand's digits (digit_joints)
    and the twist and corrective bones riding on a limb (rider_joints). (A body's own still
    branch, such as the legs of a seated clip, starts a bone away from its parent.) No helpers
    when the clip has fewer than two frames or nothing in it moves."""
    J = skeleton.n_joints
    still = still_branches(skeleton, frames)
    on_parent = np.linalg.norm(skeleton.offsets, axis=1) <= 1e-9 * max(1.0, skeleton.reach)
    tops = still & on_parent & (np.arange(J) > 0)
    if len(frames) < 2 or still[0]:
        return np.zeros(J, bool)
    out = digit_joints(skeleton) | rider_joints(skeleton)
    if tops.any():
        carriers = carrier_joints(replace(skeleton, helpers=tops))
        for j in range(1, J):
            out[j] |= out[skeleton.parents[j]] or (carriers[skeleton.parents[j]] and tops[j])
    return out


def rider_joints(skeleton: Skeleton) -> np.ndarray:
    """(J,) bool: the joints of branches that ride on a bone of their parent: hung from partway
    along it (their OFFSET within RIDER_SPREAD x the bone's length of the line from the parent
    to the bone's end, between RIDER_SPAN of its length from either end) and reaching no
    farther than RIDER_SPREAD x its length from there (bone lengths, the OFFSETs): a game rig's
    twist and corrective bones (thigh_twist_01 a third of the way down the thigh). They carry
    no weight of their own and lie inside the limb; counted as the body, each hub made the
    thigh and shin look like stubs, the knee lost its taper and a twist joint on the thigh got
    a radius of 9.7 cm: the shared crawl so rigged was left 91 mm under the floor."""
    J = skeleton.n_joints
    ends = frame_offsets(skeleton)
    bone = np.linalg.norm(ends, axis=1)
    start = bone_starts(skeleton)
    reach = np.zeros(skeleton.n_frames)  # how far each joint's branch reaches along its bones
    for f in range(skeleton.n_frames - 1, 0, -1):  # children after parents: reversed is bottom-up
        if start[f] >= 0:
            reach[start[f]] = max(reach[start[f]], reach[f] + bone[f])
    out = np.zeros(J, bool)
    for j in range(1, J):
        siblings = [f for f in np.flatnonzero(start == start[j]) if f != j and bone[f] > 0]
        for f in siblings:
            along = ends[j] @ ends[f] / bone[f] ** 2
            off = np.linalg.norm(ends[j] - along * ends[f])
            inside = RIDER_SPAN <= along <= 1.0 - RIDER_SPAN and off <= RIDER_SPREAD * bone[f]
            out[j] |= inside and reach[j] <= RIDER_SPREAD * bone[f]
    for j in range(1, J):  # a rider's branch rides with it
        out[j] |= out[skeleton.parents[j]]
    return out


def digit_joints(skeleton: Skeleton) -> np.ndarray:
    """(J,) bool: the joints of a hand's digits: DIGITS or more branches hanging from one joint,
    each at most DIGIT_REACH x the body's longest path from its root (bone lengths, the OFFSETs,
    from body_root) long from it (five fingers, whether the capture moves them or leaves them
    as a rig posed them; an arm, a leg or a head is longer). They carry no weight and are not
    what a body rests on: where a capture lays a hand on the floor they hang through it as the
    rig or the glove curled them, and counted as the body they sank it 116 mm under its floor
    (the shared get-up, fingers added: refused as if the file's up were another; fingers curled
    15 degrees and moving 10 either way, the same) or planted every finger joint as a contact
    of its own (a fist 60 mm through the floor). The hand they hang from stays the body's end,
    as large as a palm (cleanup/body.py), and the fix leaves them as captured. Path lengths,
    not the reference pose's distances or Skeleton.reach: a rig's translation channels widen
    its reach (six channels on every joint: the arms passed for digits) and a rest pose may
    fold an arm."""
    J = skeleton.n_joints
    bone = np.linalg.norm(frame_offsets(skeleton), axis=1)
    start = bone_starts(skeleton)
    depth = np.zeros(skeleton.n_frames)
    for f in range(1, skeleton.n_frames):  # parents first: joints in order, then the sites
        depth[f] = depth[start[f]] + bone[f]
    below = [[j] for j in range(J)]  # every joint's branch, itself first
    for j in range(J - 1, 0, -1):
        below[skeleton.parents[j]] += below[j]
    frames_of = np.concatenate([np.arange(J), skeleton.site_joint])
    root = body_root(skeleton)
    size = (depth[np.isin(frames_of, below[root])] - depth[root]).max()
    out = np.zeros(J, bool)
    for hub in range(J):
        short = []
        for child in np.flatnonzero(skeleton.parents == hub):
            inside = np.isin(frames_of, below[child])
            if child > 0 and (depth[inside] - depth[hub]).max() <= DIGIT_REACH * size:
                short.append(child)
        if len(short) >= DIGITS:
            for child in short:
                out[below[child]] = True
    return out


def body_root(skeleton: Skeleton) -> int:
    """The joint the body hangs from: the first below the carriers (carrier_joints), the root
    when there are none (the hips of a rig rooted at its hips)."""
    carriers = carrier_joints(skeleton)
    return int(np.argmin(carriers)) if carriers.any() else 0


_BODY_REACH: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # skeleton -> body_reach


def body_reach(skeleton: Skeleton) -> float:
    """Longest path length from body_root to a joint or site (Skeleton.reach measured from the
    body, not from the carriers above it): the same body gets the same reach whether its rig
    is rooted at the hips or at a `Reference` joint on the ground below them. Worked out once
    per skeleton (the clip fix asks in every step and frame)."""
    if skeleton not in _BODY_REACH:
        root = body_root(skeleton)
        longest = skeleton.reach
        if root != 0:
            depth = np.array([skeleton.path_length(f) for f in range(skeleton.n_frames)])
            longest = float(depth[~off_body(skeleton)].max() - depth[root])
        _BODY_REACH[skeleton] = longest if longest > 0 else 1.0
    return _BODY_REACH[skeleton]


def link_distance(skeleton: Skeleton) -> np.ndarray:
    """(F, F) how many links apart bones are: 0 for a bone and itself, 1 for bones that share a
    frame (parent and child, siblings), 2 for bones joined through one other bone, ...; F for
    the root's row and column (it ends no bone)."""
    start = bone_starts(skeleton)
    F = skeleton.n_frames
    # ancestor[i, k]: frame i lies on the path from the root to frame k (itself included); the
    # ancestors of a frame form one chain, so two frames share as many as their lowest common
    # ancestor's depth + 1, and their distance along the tree follows from the depths
    ancestor = np.zeros((F, F), np.float32)
    for k in range(F):
        if start[k] >= 0:
            ancestor[:, k] = ancestor[:, start[k]]
        ancestor[k, k] = 1.0
    depth = ancestor.sum(axis=0) - 1
    common = np.rint(ancestor.T @ ancestor) - 1
    tree = (depth[:, None] + depth[None, :] - 2 * common).astype(np.int64)
    ends = np.maximum(start, 0)
    nearest = np.minimum.reduce([tree[ends][:, ends], tree[ends][:, :], tree[:, ends], tree])
    distance = np.where(np.eye(F, dtype=bool), 0, nearest + 1)
    distance[0, :] = distance[:, 0] = F
    return distance


def default_radii(
    skeleton: Skeleton, pose: np.ndarray | None = None, seated: bool = False, height: float | None = None
) -> np.ndarray:
    """(J,) capsule radius of the bones leaving each joint (length units), measured in `pose`
    (D,) (default the reference pose). With masses: the joint's share of the body volume
    (BODY_VOLUME times the height cubed, the height being `height` or else the pose's extent
    along `up`, carrier joints aside: a rest pose lying down is as tall as it stands) as a
    cylinder along its longest bone, so a thigh is about 8 cm and an upper arm
    4 cm on a 1.75 m humanoid and a massless joint (a neck, a clavicle) gets 0. Without masses:
    MASSLESS_RADIUS times that bone's length. With `seated`, a joint sitting on another
    (seat_anchors) gives its bones and mass to that one and has none: the body's measure; the
    capsules of self-collision keep each joint its own."""
    J = skeleton.n_joints
    start, length = bone_starts(skeleton), bone_lengths(skeleton, pose)
    anchor = seat_anchors(skeleton) if seated else np.arange(J)
    longest = np.zeros(J)
    np.maximum.at(longest, anchor[start[1:]], length[1:])
    if skeleton.total_mass <= 0:
        return MASSLESS_RADIUS * longest
    if height is None:
        p = forward_kinematics(skeleton, skeleton.reference if pose is None else pose).p_world_frame
        height = np.ptp(p[~off_body(skeleton)] @ skeleton.up) or skeleton.reach
    fraction = np.bincount(anchor[skeleton.mass_joint], skeleton.mass_value, J) / skeleton.total_mass
    volume = fraction * BODY_VOLUME * height**3
    return np.sqrt(np.divide(volume, np.pi * longest, out=np.zeros(J), where=longest > 0))

"""The body a clip cleanup keeps on the floor: its size, the soles of its feet, and how far its
surface lies from each joint and site. Nothing here reads a joint's name or a length unit.

Size (`span`): the longest path along the bones between two ends of the body, each bone as long
as its median over the capture (2.14 m on the shared humanoid, 1.6 m tall). Every size,
threshold and tolerance of deik.cleanup is a share of it, never a DOF limit or a unit. Joints
above the body that only carry it (deik.model.capsules.carrier_joints: a `Reference` joint on the
ground) are not part of it, nor are helpers hanging from them that the clip never moves (a game
rig's IK target bones) or a hand's fingers it never moves (with_helpers marks both on the
skeleton: deik.model.capsules.helper_joints); such a hand is an end of the body.

Standing pose: the rig's rest pose (rotations 0, translations at their median over the capture:
a T-pose or a body standing with its arms down) unless it stands less than STANDING as tall as
the tallest frame, the tallest carried rest below, or its own length (its longest extent along
its body root's axes). A rig that rests lying (its hips, or a joint above them, turned 90
degrees in every frame, as an FBX export writes a Z-up scene) stands in its rest pose once its
body root and the joints above it turn as in a frame of the capture: the tallest of those
carried rests, when it stands UPRIGHT x its length, levelled (the body root's axis nearest up
turned onto it). A clip that never stands (a crawl) carries it upright in no frame: the rest
pose is then stood on the axis of its body root along which it stands on two feet (two foot
chains at its lowest, the body root LEGS x span above them: a T- or A-pose does so only on its
own up), and only when none does, the tallest frame itself, whose feet may be tilted (a rig
that rests folded): on the shared walk with its rest pose laid down, the tallest frame's heel
strike tilted the soles laid through it and the fix slid 16 mm a frame; on the crawl, whose
rest passed for standing beside its low frames, the soles lay on the hips and the body 98 mm
under the floor was reported met. The body's height for its radii is that standing pose's
extent along up. Feet and their soles: cleanup/soles.py.

Radius (how far the body's surface lies from a point): the capsule radius (default_radii, in the
standing pose) of the thinnest bone with one that the point ends or starts (a shoulder is as
thick as its upper arm, not as the chest it hangs from); for a point of a foot its height
above the sole; 0 for the sole sites. A bone's radius is its segment's volume as a cylinder
along it, thinner than a limb where it is thickest and than a palm, so two points are sized up:
- the top of a limb segment (a joint that starts one bone: a shoulder, elbow, hip, knee, neck)
  is at least TOP x that bone's radius: a limb tapers, and a frustum whose far end is TAPER
  (0.6: ankle over calf, wrist over forearm girth) of its near end holds the cylinder's volume
  with its near end 1.24 times as thick (a knee 4.7 cm against the shin's 3.8 cm on the shared
  humanoid, an elbow 4.25 against its forearm and hand's 3.43);
- an end of the body other than a foot (a hand, the head) is at least PALM x the length of the
  bone that ends there: an adult hand is about 4.8 % of stature broad across the knuckles (8-9
  cm at 1.75 m) and the forearm 14.6 % of it long (Drillis & Contini), so half the palm is
  0.165 of the forearm (4.3 cm on the shared humanoid); a head keeps its own, larger radius;
- an end whose segment holds a ball as wide as the segment is long (a head, not a forearm with
  its hand) is that ball around it: a head is round, and lying on its back its centre stays a
  ball's radius above the floor (9.0 cm on the shared humanoid, whose DeepMimic head sphere is
  10.25 cm), where its volume as a cylinder along the bone gave 7.4 cm.
`bone_radius` keeps each bone's own cylinder radius: the surface along it (cleanup/bone_points.py).

Trunk centres: a segment whose joint starts two or more bones of the body and whose cylinder is
thicker than the joint's own radius (a chest: 12.2 cm against the 8.0 of the abdomen its joint
also bounds, on the shared humanoid) gets a site at its centre, halfway from the joint to the
mean of its bones' ends, as thick as the segment (`Body.centres`): lying on its back the body
rests on its upper back, which neither the chest joint nor the neck represents, and measured on
them alone a body laid 15 mm through the floor by the DeepMimic humanoid's chest sphere (11 cm,
12 cm up the spine) read 3 mm above it. The floor keeps a centre out as any point of the body; it
is no contact (planting the chest of the shared get-up, which lies on it face down for a few
frames, took its forearms' lift back: 52 mm under the floor), no point a pop is measured on, and
counts in no statistic of the body's points (`Body.own`) nor in the warm start's DOF weights.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from deik.cleanup.soles import Foot, body_ends, foot_chains, sole_points, sole_sites, toe_joint
from deik.errors import InputError
from deik.io.trajectory import Motion, Trajectory
from deik.model.build import with_sites
from deik.model.capsules import (
    STILL_TURN,
    body_root,
    bone_starts,
    default_radii,
    helper_joints,
    off_body,
    seat_anchors,
    still_branches,
)
from deik.model.joints import ROTATE
from deik.model.kinematics import Kinematics, forward_kinematics
from deik.model.rotations import upright
from deik.model.skeleton import Skeleton

STANDING = 0.5
LEGS = 0.2  # of the span: a body root standing on two feet lies at least this far above them
UPRIGHT = 0.9  # of the rest pose's length along its own axes: a carried rest that stands this tall stands
TAPER = 0.6  # a limb segment's far end over its near end
TOP = (3.0 / (1.0 + TAPER + TAPER**2)) ** 0.5  # its near end over its volume's cylinder: 1.24
PALM = 0.165  # half a hand's breadth, of the forearm's length
SHORT_LEVER = 0.05  # of the span: a joint carrying the body no farther is a short lever (short_levers)


@dataclass(frozen=True, eq=False)
class Body:
    """The body of a clip (module notes): `skeleton` the clip's with the sole sites and trunk
    centres added (the same DOFs), `span` (length units), `radius` (F,) per joint then site of
    `skeleton`, `part` (F,) bool whether each is part of the body (carriers are not), `feet`,
    `bone_radius` (F,) the capsule radius of the bone that ends at each joint or site (its start
    joint's, default_radii; 0 for the root and where a carrier starts it), and `centres` the
    trunk centres' site names."""

    skeleton: Skeleton
    span: float
    radius: np.ndarray
    part: np.ndarray
    feet: tuple[Foot, ...]
    bone_radius: np.ndarray
    centres: tuple[str, ...] = ()

    @property
    def sole_names(self) -> tuple[str, ...]:
        return tuple(name for foot in self.feet for name in foot.soles)

    @property
    def own(self) -> np.ndarray:
        """(F,) bool: the part of the body that is the clip's own joints and sites or sole sites,
        the trunk centres aside (statistics over the body's points leave them out)."""
        return self.part & ~np.isin(self.skeleton.frame_names, self.centres)

    @property
    def points(self) -> np.ndarray:
        """(F,) bool: the clip's own joints and sites that are part of the body, the points
        whose accelerations the no-new-pops rule compares (the sole sites and trunk centres
        ride on the clip's own)."""
        return self.own & ~np.isin(self.skeleton.frame_names, self.sole_names)

    def contact_points(self) -> tuple[str, ...]:
        """Every point that may rest on the floor: the heel and toe of each foot, and every other
        joint and site of the body but the feet's chains, flanking sole sites and trunk centres."""
        feet = {name for foot in self.feet for name in foot.chain + foot.soles}
        own = [name for f, name in enumerate(self.skeleton.frame_names) if self.own[f] and name not in feet]
        return tuple([name for foot in self.feet for name in (foot.heel, foot.toe)] + own)


def on_body(motion: Motion, body: Body) -> Trajectory:
    """`motion`'s frames on body.skeleton (its sole sites included), same frame time and source."""
    return Trajectory(body.skeleton, motion.frames, motion.frame_time, motion.source)


def with_helpers(clip: Motion) -> Motion:
    """`clip` on its skeleton with the helper joints its frames show marked (skeleton.helpers:
    deik.model.capsules.helper_joints), so that every measure of the body leaves them out, and
    the mass a reader gave them moved back onto the body's own joints (the total kept); `clip`
    itself when it has none."""
    sk = clip.skeleton
    helpers = helper_joints(sk, clip.frames)
    if not helpers.any():
        return clip
    on_helper = helpers[sk.mass_joint]
    mass = sk.mass_value
    if on_helper.any() and mass[~on_helper].sum() > 0:  # their estimated share goes back to the body
        mass = np.where(on_helper, 0.0, mass) * (mass.sum() / mass[~on_helper].sum())
    return replace(clip, skeleton=replace(sk, helpers=helpers | sk.helpers, mass_value=mass))


def short_levers(body: Body, motion: Motion) -> np.ndarray:
    """(D,) bool: the DOFs of the joints of `body` whose part of the body reaches no farther than
    SHORT_LEVER x span from them (a toe, a finger), by the median distances over `motion` (on
    the body: on_body)."""
    sk = body.skeleton
    p = motion.kinematics.p_world_frame
    start = bone_starts(sk)
    reach = np.zeros(sk.n_frames)
    for f in np.flatnonzero(body.part):
        joint = start[f]
        while joint >= 0:
            reach[joint] = max(reach[joint], float(np.median(np.linalg.norm(p[:, f] - p[:, joint], axis=-1))))
            joint = start[joint]
    return ((reach <= SHORT_LEVER * body.span) & body.part)[sk.dof_joint]


def median_pose(clip: Motion) -> np.ndarray:
    """(D,) rotations 0, translations at their median over the clip: the rig's own rest pose."""
    sk = clip.skeleton
    middle = np.median(clip.frames, axis=0) if clip.n_frames else sk.reference
    return np.where(sk.dof_kind == ROTATE, 0.0, middle)


def _tree_span(skeleton: Skeleton, length: np.ndarray, part: np.ndarray) -> float:
    """The longest path between two frames through bones of `length` (F,) (bone f ends at f)
    among the `part` (F,) frames."""
    start = bone_starts(skeleton)
    down = np.zeros(skeleton.n_frames)  # longest path from each frame down to an end below it
    best = 0.0
    for f in range(skeleton.n_frames - 1, 0, -1):  # children after parents: reversed is bottom-up
        s = start[f]
        if not (part[f] and part[s]):
            continue
        through = down[f] + length[f]
        best = max(best, down[s] + through)
        down[s] = max(down[s], through)
    return best


def _carried_rests(clip: Motion) -> np.ndarray:
    """(N, D) the rest pose (median_pose) turned in each frame as the capture turns the joints
    that carry the body: the body root (capsules.body_root) and every joint above it."""
    sk = clip.skeleton
    carrying, k = set(), body_root(sk)
    while k >= 0:
        carrying.add(k)
        k = int(sk.parents[k])
    turns = np.isin(sk.dof_joint, list(carrying)) & (sk.dof_kind == ROTATE)
    return np.where(turns, clip.frames, median_pose(clip))


def _frame_axes(kin: Kinematics, joint: int) -> np.ndarray:
    """(6, 3) the world directions of `joint`'s frame axes in `kin` (one pose), each way."""
    axes = kin.R_world_frame[0, joint].T  # rows: the frame's x, y and z in the world
    return np.concatenate([axes, -axes])


def _stood_on(kin: Kinematics, axis: np.ndarray) -> Kinematics:
    """`kin` (one pose) turned so that the world direction `axis` (3,) points up."""
    turn = upright(kin.skeleton.up).T @ upright(axis)  # axis -> +Y -> up
    return replace(
        kin,
        R_world_frame=turn @ kin.R_world_frame,
        p_world_frame=kin.p_world_frame @ turn.T,
        p_world_com=kin.p_world_com @ turn.T,
    )


def _levelled(kin: Kinematics, joint: int) -> Kinematics:
    """`kin` (one pose) turned so that the axis of `joint`'s frame nearest to up points exactly
    up: a rest pose carried upright by a capture frame's turn, without that frame's tilt."""
    axes = _frame_axes(kin, joint)
    return _stood_on(kin, axes[int(np.argmax(axes @ kin.skeleton.up))])


def _on_two_feet(kin: Kinematics, part: np.ndarray, span: float) -> Kinematics | None:
    """The rest kinematics `kin` stood on the axis of its body root's frame along which it stands
    on two feet (two foot chains at its lowest, _foot_chains, the body root LEGS x span above
    them), the tallest such; None when no axis does. A T- or A-pose stands so only along its
    own up: upside down its head is lowest, on its side one hand, lying flat every end at once."""
    sk = kin.skeleton
    root = body_root(sk)
    best, tallest = None, 0.0
    for axis in _frame_axes(kin, root):
        turned = _stood_on(kin, axis)
        p = turned.p_world_frame[0]
        height = p[part] @ sk.up
        if len(foot_chains(sk, p, part, span)) == 2 and p[root] @ sk.up - height.min() >= LEGS * span:
            if np.ptp(height) > tallest:
                best, tallest = turned, float(np.ptp(height))
    return best


def rest_stands_along(clip: Motion) -> np.ndarray | None:
    """(3,) the world direction along which `clip`'s rest pose (median_pose, as the file writes
    it) stands on two feet (_on_two_feet), None when along none: a file made with Z up stands
    its rest pose along Z whichever up it is read with."""
    sk = clip.skeleton
    part = ~off_body(sk)
    at_rest = forward_kinematics(sk, median_pose(clip)[None])
    p = at_rest.p_world_frame[0]
    start = bone_starts(sk)
    length = np.where(start >= 0, np.linalg.norm(p - p[np.maximum(start, 0)], axis=-1), 0.0)
    stood = _on_two_feet(at_rest, part, _tree_span(sk, length, part) or sk.reach)
    if stood is None:
        return None
    turn = stood.R_world_frame[0, 0] @ at_rest.R_world_frame[0, 0].T  # at rest -> stood
    return turn.T @ sk.up


def rest_standing(skeleton: Skeleton) -> Kinematics:
    """The kinematics of `skeleton` at rest (every DOF 0), turned to stand along its up when the
    rest pose stands on two feet along another axis (rest_stands_along: a rig exported lying);
    as it is otherwise (a robot arm, a rest pose that stands)."""
    zero = np.zeros((1, skeleton.n_dofs))
    at_rest = forward_kinematics(skeleton, zero[0])
    along = rest_stands_along(Trajectory(skeleton, zero, 1.0))
    return at_rest if along is None or along @ skeleton.up > 1 - 1e-9 else _stood_on(at_rest, along)


def _standing(clip: Motion, part: np.ndarray, span: float) -> tuple[np.ndarray, Kinematics]:
    """(pose (D,), its kinematics) of the standing pose of the module notes."""
    sk = clip.skeleton
    rest = median_pose(clip)
    if not clip.n_frames:
        return rest, forward_kinematics(sk, rest[None])
    carried = _carried_rests(clip)
    every = forward_kinematics(sk, np.vstack([rest, clip.frames, carried]))
    extent = np.ptp(every.p_world_frame[:, part] @ sk.up, axis=1)
    rest_extent, frame_extent, carried_extent = extent[0], extent[1 : clip.n_frames + 1], extent[clip.n_frames + 1 :]
    first = {name: getattr(every, name)[:1] for name in ("R_world_frame", "p_world_frame", "p_world_com")}
    at_rest = replace(every, **first)  # the rest pose's row: its kinematics once
    p = at_rest.p_world_frame[0, part]
    length = np.ptp(p @ _frame_axes(at_rest, body_root(sk))[:3].T, axis=0).max()  # along its own axes
    if rest_extent >= STANDING * max(frame_extent.max(), carried_extent.max(), length):
        return rest, at_rest
    if carried_extent.max() >= UPRIGHT * length:  # the rest pose stood up by the body's own turn
        pose = carried[int(np.argmax(carried_extent))]
        return pose, _levelled(forward_kinematics(sk, pose[None]), body_root(sk))
    stood = _on_two_feet(at_rest, part, span)
    if stood is not None:  # no frame stands it up (a crawl): its own two feet do
        return rest, stood
    pose = clip.frames[int(np.argmax(frame_extent))]
    return pose, forward_kinematics(sk, pose[None])


def _thinnest(skeleton: Skeleton, joint_radius: np.ndarray, start: np.ndarray) -> np.ndarray:
    """(F,) per joint and site the radius of the thinnest bone with a radius that ends or starts
    there (a bone's radius is its start joint's, `joint_radius` (J,)); 0 where none has one."""
    F = skeleton.n_frames
    ending = np.where(start >= 0, joint_radius[np.maximum(start, 0)], 0.0)  # the bone that ends at f
    thinnest = np.where(ending > 0, ending, np.inf)
    leaving = np.concatenate([joint_radius, np.zeros(F - skeleton.n_joints)])  # bones that start at f
    thinnest = np.where(leaving > 0, np.minimum(thinnest, leaving), thinnest)
    return np.where(np.isfinite(thinnest), thinnest, 0.0)


def _balls(joint_radius: np.ndarray, start: np.ndarray, length: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """(F,) at each end of the body (`ends` (F,) bool) whose segment, the bone from `start` (F,)
    of `length` (F,) with the cylinder radius of its start joint (`joint_radius` (J,)), holds
    a ball as wide as the bone is long, that ball's radius (module notes: a head); 0 elsewhere."""
    cylinder = np.where(start >= 0, joint_radius[np.maximum(start, 0)], 0.0)
    ball = (0.75 * cylinder**2 * length) ** (1.0 / 3.0)  # the same volume
    return np.where(ends & (start >= 0) & (2.0 * ball >= length), ball, 0.0)


def _trunk_centres(skeleton: Skeleton, kin: Kinematics, radii: tuple, start: np.ndarray, part: np.ndarray) -> list:
    """[(name, joint name, offset (3,) in its frame, radius)]: a site at the centre of each
    segment of the body whose joint starts two or more of its bones (`start` (F,) each frame's
    bone's start joint, `part` (F,) bool) and whose cylinder (radii[0] (J,)) is thicker than
    the joint's own radius (radii[1] (F,)): halfway from the joint to the mean of the bones'
    ends in the standing kinematics `kin` (module notes: a chest)."""
    joint_radius, own = radii
    p, R = kin.p_world_frame[0], kin.R_world_frame[0]
    out = []
    for j in range(skeleton.n_joints):
        children = np.flatnonzero((start == j) & part)
        if len(children) < 2 or joint_radius[j] <= own[j] * (1.0 + 1e-9):
            continue
        offset = R[j].T @ (0.5 * (p[children].mean(axis=0) - p[j]))
        name = f"{skeleton.frame_names[j]}_centre"
        while name in skeleton.frame_names:
            name += "_"
        out.append((name, skeleton.frame_names[j], offset, float(joint_radius[j])))
    return out


def body_of(clip: Motion) -> Body:
    """The Body of `clip` (module notes)."""
    sk = clip.skeleton
    part = ~off_body(sk)
    off = ~part[: sk.n_joints]
    start = bone_starts(sk)
    poses = clip.frames if clip.n_frames else sk.reference[None]
    motion = forward_kinematics(sk, poses)
    p = motion.p_world_frame
    length = np.where(start >= 0, np.median(np.linalg.norm(p - p[:, np.maximum(start, 0)], axis=-1), axis=0), 0.0)
    if not np.any(length > 0):
        raise InputError(f"{clip.source or 'the clip'}: every bone has zero length: there is no body to clean")
    span = _tree_span(sk, length, part) or sk.reach
    standing, kin = _standing(clip, part, span)
    height = kin.p_world_frame[0] @ sk.up
    stature = float(np.ptp(height[part]))  # the standing kinematics', which may be a turned rest pose
    feet, sites, foot_radius = [], [], {}
    rest = forward_kinematics(sk, median_pose(clip)[None])
    turning = ~still_branches(sk, clip.frames, STILL_TURN) & np.isin(np.arange(sk.n_joints), sk.dof_joint)
    for chain in foot_chains(sk, kin.p_world_frame[0], part, span):
        shape = sole_points(sk, chain, kin, (motion, rest), span, stature)
        if shape is None:
            continue
        sole, heel, toe = shape
        soles = sole_sites(sk, chain, kin, heel, toe, toe_joint(chain, turning))
        sites += soles
        feet.append(Foot(sk.frame_names[chain[0]], tuple(sk.frame_names[f] for f in chain), tuple(s[0] for s in soles)))
        foot_radius.update({f: height[f] - sole for f in chain})
    # a joint sitting on another (a zero OFFSET: the CMU rigs' LHipJoint at the Hips) is that
    # point: its bones and mass are the other's, and it is as thick as the other is there
    seat = seat_anchors(sk)
    seated_start = np.where(start >= 0, seat[np.maximum(start, 0)], -1)
    ends = body_ends(sk, part)
    joint_radius = np.where(off | ends[: sk.n_joints], 0.0, default_radii(sk, standing, seated=True, height=stature))
    own = _thinnest(sk, joint_radius, seated_start)
    ball = _balls(joint_radius, seated_start, length, ends)
    own = np.where(ends, np.maximum(own, np.maximum(PALM * length, ball)), own)
    frame_radius = np.concatenate([joint_radius, np.zeros(sk.n_frames - sk.n_joints)])
    counted = seated_start[(seated_start >= 0) & part]  # the body's bones: a helper riding on a limb is none
    limb_top = (np.bincount(counted, minlength=sk.n_frames) == 1) & (frame_radius > 0)
    own = np.where(limb_top, np.maximum(own, TOP * frame_radius), own)
    for f, value in foot_radius.items():
        own[f] = value
    centres = _trunk_centres(sk, kin, (joint_radius, own), seated_start, part)
    body = with_sites(sk, sites + [centre[:3] for centre in centres])
    radius = np.concatenate([np.where(part, own, 0.0), np.zeros(len(sites)), [centre[3] for centre in centres]])
    body_start = bone_starts(body)
    bone_radius = np.where(body_start >= 0, joint_radius[seat[np.maximum(body_start, 0)]], 0.0)
    part = np.concatenate([part, np.ones(len(sites) + len(centres), bool)])
    names = tuple(centre[0] for centre in centres)
    return Body(body, float(span), radius, part, tuple(feet), bone_radius, names)

"""Hard cases for deik clip, made from the shared humanoid clips without deik (judging/rigs.py).

Each case is a BVH file and what the judge (judging/clips.py) needs to measure it: which
of its joints is which canonical joint of the source rig (the DeepMimic humanoid: Hips, RightHip,
RightKnee, ... and their End Sites), its length units per metre and how much each bone was
scaled. The floor stays at height 0 (up +Y) in every case: the source clips stand on it.

Transforms (each keeps the motion physically the same unless it says otherwise):
- studio: another rig family: centimetres, a root joint `Reference` above the hips that carries
  the walk over the ground, six channels (positions then ZYX rotations) on every joint, position
  channels holding each joint's local position (they repeat its OFFSET), Unreal-style joint
  names, 30 frames per second (60 fps sources keep every other frame).
- anon: joints named J00, J01, ... (nothing to learn from a name), YXZ rotation channels, 120
  frames per second (rotations interpolated by slerp, positions linearly).
- backwards: the frames in reverse order.
- fast: every other frame at the same frame time (twice the speed).
- hifps: the same motion at 120 frames per second (slerp between the frames), every name and
  channel as it is.
- pal: the same motion at 50 frames per second (slerp), as many European studios capture: a
  rate no shared clip has, neither a multiple of 30 nor of 60.
- limbs: the left leg's bones 8 % longer and the right leg's 4 % shorter, the arms 10 % longer,
  the root raised by the mean change of the legs: one foot sinks through the floor, the other
  floats, the feet slide.
- noisy: capture noise (0.2 degrees on every rotation channel, 1 mm on the root) and the whole
  body 12 mm lower, so the feet rest under the floor.
- shaky: the noisy transform at 60 frames per second or more (the clips captured at 30 fps
  resampled to 120 fps first, as hifps): capture noise hides rests there and stays in every
  frame nothing plants.
- bind: the rig's bind pose (every rotation channel 0: a T-pose) as a first frame before the
  motion, as many exporters write it: over the first frame's root, standing on the floor (its
  lowest joint or End Site at height 0).
- glitch: the middle frame's rotation channels all 0: the pose leaps into the T-pose and back.
- stand: the first and last poses held 2 s each (an actor standing still as a take starts and
  ends) and the whole body 12 mm lower (a floor calibrated a centimetre off): the standing feet
  rest through the floor.
- tpose: the same motion on a rig whose rest pose is a T-pose: each shoulder's and elbow's frame
  turned 90 degrees about Z so that the arms' bones point sideways at rotation 0 (the OFFSETs
  and every rotation channel follow; the world motion is the same to rounding).
- laid: the same motion on a rig whose rest pose lies on its back (every joint's frame turned 90
  degrees about X, the root's rotation carrying the body upright in every frame), as an FBX
  export of a Z-up scene writes it.
- seats: CMU's zero-length bones: a joint at the hips' origin above each hip and one under the
  chest (a zero OFFSET, three still rotation channels), as the CMU captures' LHipJoint,
  RHipJoint and LowerBack sit at their Hips.
- digits: a game rig's hands and feet: each hand End Site becomes a wrist joint carrying four
  fingers and a thumb of three joints each, curled 15 degrees, and each foot's toe tip hangs from
  a toe joint 70 % of the way from the ankle; none of them moves (a capture that leaves fingers
  and toes still). The toes change no point the judge measures, the fingers lengthen the body.
  Every clip also gets its digits with the noisy transform (`_digits_noisy`): a capture solver
  shakes the joints it has no data for as it shakes the rest. Case.names gains RightToe and
  LeftToe, the toe joints, on which the judge hangs the part of the foot box beyond them.
- toes: the digits rig whose toes the capture bends: each toe joint's Xrotation channel plus
  TOE_BEND sin(2 pi TOE_HERTZ t + phase) degrees (5 degrees at 0.7 Hz, the feet a radian out of
  phase), as a capture with toe markers bends them; every clip gets it, without and with the
  noisy transform (`_toes`, `_toes_noisy`).
- fingers: the digits rig whose fingers the capture moves, as a glove does: each finger joint's
  Xrotation channel plus FINGER_BEND sin(2 pi FINGER_HERTZ t + phase) degrees (10 degrees at
  0.5 Hz on the 15 degrees of curl, each joint a radian out of phase); the get-up and the crawl,
  which lay those hands on the floor (`_fingers`).
- twists: a game rig's twist bones: two joints on each thigh, shin, upper arm and forearm, a
  third and two thirds of the way down the bone, each with an End Site 5 % of the bone long
  along it, turning about the bone 20 degrees either way at 0.4 Hz (a skinning rig's twist
  bones, which an export writes with the rest); the walk, the crawl and the punch (`_twists`).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from judging.rigs import Rig, joint_values, parse_rig, pose_points

CANON = (
    "Hips", "RightHip", "RightKnee", "RightAnkle", "LeftHip", "LeftKnee", "LeftAnkle", "Chest", "Neck",
    "RightShoulder", "RightElbow", "LeftShoulder", "LeftElbow",
)  # fmt: skip
STUDIO_NAMES = dict(
    zip(
        CANON,
        ("pelvis", "thigh_r", "calf_r", "foot_r", "thigh_l", "calf_l", "foot_l", "spine_03", "neck_01",
         "upperarm_r", "lowerarm_r", "upperarm_l", "lowerarm_l"),
    )
)  # fmt: skip
LEFT_LEG, RIGHT_LEG = ("LeftHip", "LeftKnee", "LeftAnkle"), ("RightHip", "RightKnee", "RightAnkle")
ARMS = ("RightShoulder", "RightElbow", "LeftShoulder", "LeftElbow")
EXTRAS = {  # the second transform of each shared clip, so that every one is tried on two clips
    "walk": "noisy", "run": "fast", "jump": "backwards", "crawl": "limbs", "getup_facedown": "anon",
    "kick": "noisy", "punch": "limbs", "dance_a": "backwards",
}  # fmt: skip
CUTS = {"walk": "bind", "run": "bind", "getup_facedown": "bind", "kick": "glitch", "dance_a": "glitch"}  # a third
STANDS = ("walk", "kick", "dance_a")  # and a stand (a fourth case)
DIGITS = ("run", "jump", "punch", "dance_a", "getup_facedown", "crawl")  # fingers and toes (the last two: hands down)
FINGERED = ("getup_facedown", "crawl")  # and fingers the capture moves (hands down)
TWISTED = ("walk", "crawl", "punch")  # and twist bones on the limbs
LAID = ("walk", "kick", "crawl")  # and a rest pose lying down
HIFPS = ("walk", "run", "kick", "punch")  # and 120 fps (the 30 fps clips)
SHAKY = ("walk", "run", "kick", "jump", "dance_a")  # and noisy at 60 fps or more
STAND_SECONDS, SUNK = 2.0, 0.012  # s held at each end, m under the floor


@dataclasses.dataclass(frozen=True)
class Case:
    """One file to clean: `rig`, `names` {canonical joint: its name in the rig}, `unit` (length
    units per metre), `bone_scale` {canonical joint: scale of its bones (the bones it carries and
    its End Sites')}, what was done to it, and `truth`: the same rig's frames without the errors
    a transform adds to the data (noise, the body sunk, a glitch frame), or None where it adds
    none; the judge takes where points rest from it (judging/clips.py); `turns` {canonical
    joint: (3, 3)} the constant turn a transform gave a joint's frame (its axes in the source's),
    with which the judge turns the shapes it hangs there."""

    name: str
    rig: Rig
    names: dict
    unit: float
    bone_scale: dict
    description: str
    truth: Rig | None = None
    turns: dict = dataclasses.field(default_factory=dict)


def source_case(path: Path) -> Case:
    """The shared clip at `path` as it is."""
    rig = parse_rig(path.read_text())
    names = {name: name for name in CANON}
    return Case(path.stem.replace("humanoid3d_", ""), rig, names, 1.0, dict.fromkeys(CANON, 1.0), "as shared")


def encode(rig: Rig, rotations: np.ndarray, translations: np.ndarray, frame_time: float) -> Rig:
    """`rig` with frames that give local `rotations` (N, J, 3, 3) and `translations` (N, J, 3)
    (its position_mode, channels and OFFSETs), each channel's Euler angles continuous."""
    columns = []
    for j, chans in enumerate(rig.channels):
        order = "".join(c[0] for c in chans if c.endswith("rotation"))
        angles = Rotation.from_matrix(rotations[:, j]).as_euler(order.upper(), degrees=True) if order else None
        if angles is not None:
            angles = np.degrees(np.unwrap(np.radians(angles), axis=0))
        base = np.zeros(3) if (rig.position_mode == "local") else rig.offsets[j]
        position = translations[:, j] - base
        r = 0
        for c in chans:
            if c.endswith("rotation"):
                columns.append(angles[:, r])
                r += 1
            else:
                columns.append(position[:, "XYZ".index(c[0])])
    frames = np.stack(columns, axis=1) if columns else np.zeros((len(rotations), 0))
    return dataclasses.replace(rig, frames=frames, frame_time=frame_time)


def resample(rotations: np.ndarray, translations: np.ndarray, factor: float) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations (N, J, 3, 3) and translations (N, J, 3) at `factor` times the frame rate:
    slerp and linear interpolation (a factor 1/k keeps every k-th frame)."""
    N, J = translations.shape[:2]
    if factor < 1 and abs(1 / factor - round(1 / factor)) < 1e-3:  # a frame time written to 6 digits
        step = int(round(1 / factor))
        return rotations[::step], translations[::step]
    times = np.arange(N)
    new = np.linspace(0, N - 1, int((N - 1) * factor) + 1)
    out_r = np.stack([Slerp(times, Rotation.from_matrix(rotations[:, j]))(new).as_matrix() for j in range(J)], axis=1)
    out_t = np.stack([[np.interp(new, times, translations[:, j, k]) for k in range(3)] for j in range(J)], axis=0)
    return out_r, out_t.transpose(2, 0, 1)


def studio(case: Case, order: tuple[str, ...] = ("Zrotation", "Yrotation", "Xrotation")) -> Case:
    """The studio transform (module notes); `order` the order of every joint's rotation
    channels (ZYX; the source's order leaves the rig family as the only change)."""
    rig, metres = case.rig, 100.0
    rotations, translations = joint_values(rig)
    if rig.frame_time < 0.025:
        rotations, translations = resample(rotations, translations, 0.5)
    N, J = translations.shape[:2]
    hips = translations[:, 0] * metres
    ground = hips * np.array([1.0, 0.0, 1.0])
    offsets = np.concatenate([[np.zeros(3)], [np.median(hips - ground, axis=0)], rig.offsets[1:] * metres])
    channels = ("Xposition", "Yposition", "Zposition") + tuple(order)
    names = ("Reference",) + tuple(STUDIO_NAMES[case.names[name]] if name in case.names else name for name in rig.names)
    new = Rig(
        names,
        (-1,) + tuple(p + 1 for p in rig.parents),
        offsets,
        (channels,) * (J + 1),
        tuple((f"{STUDIO_NAMES[rig.names[j]]}_end", j + 1, offset * metres) for _, j, offset in rig.sites),
        np.zeros((0, 6 * (J + 1))),
        0.0,
        "local",
    )
    all_r = np.concatenate([np.broadcast_to(np.eye(3), (N, 1, 3, 3)), rotations], axis=1)
    all_t = np.concatenate([ground[:, None], (hips - ground)[:, None], translations[:, 1:] * metres], axis=1)
    frame_time = rig.frame_time * (2 if case.rig.frame_time < 0.025 else 1)
    names_map = {canon: STUDIO_NAMES[canon] for canon in CANON}
    return Case(case.name + "_studio", encode(new, all_r, all_t, frame_time), names_map, metres, case.bone_scale,
                "studio rig: cm, a Reference root above the hips, 6 local channels per joint, ZYX, 30 fps")  # fmt: skip


def anon(case: Case) -> Case:
    """The anon transform (module notes)."""
    rig = case.rig
    rotations, translations = joint_values(rig)
    factor = round(rig.frame_time / (1 / 120))
    rotations, translations = resample(rotations, translations, factor)
    names = tuple(f"J{j:02d}" for j in range(len(rig.names)))
    channels = tuple(tuple(c for c in chans if c.endswith("position")) + ("Yrotation", "Xrotation", "Zrotation")
                     for chans in rig.channels)  # fmt: skip
    sites = tuple((f"{names[j]}_end", j, offset) for _, j, offset in rig.sites)
    new = dataclasses.replace(rig, names=names, channels=channels, sites=sites)
    names_map = {canon: names[rig.names.index(case.names[canon])] for canon in CANON}
    return Case(case.name + "_anon", encode(new, rotations, translations, rig.frame_time / factor), names_map,
                case.unit, case.bone_scale, "joints J00.., YXZ channels, 120 fps")  # fmt: skip


def backwards(case: Case) -> Case:
    rig = dataclasses.replace(case.rig, frames=case.rig.frames[::-1].copy())
    return dataclasses.replace(case, name=case.name + "_backwards", rig=rig, description="played backwards")


def shaky(case: Case) -> Case:
    """The shaky transform (module notes)."""
    return noisy(hifps(case) if case.rig.frame_time > 1 / 45 else case)


def hifps(case: Case) -> Case:
    """The hifps transform (module notes)."""
    rotations, translations = resample(*joint_values(case.rig), round(case.rig.frame_time * 120))
    rig = encode(case.rig, rotations, translations, 1 / 120)
    return dataclasses.replace(case, name=case.name + "_120fps", rig=rig, description="captured at 120 fps")


def pal(case: Case) -> Case:
    """The pal transform (module notes)."""
    rotations, translations = resample(*joint_values(case.rig), case.rig.frame_time * 50)
    rig = encode(case.rig, rotations, translations, 1 / 50)
    return dataclasses.replace(case, name=case.name + "_50fps", rig=rig, description="captured at 50 fps")


def fast(case: Case) -> Case:
    rig = dataclasses.replace(case.rig, frames=case.rig.frames[::2].copy())
    return dataclasses.replace(case, name=case.name + "_fast", rig=rig, description="twice the speed")


def limbs(case: Case) -> Case:
    """The limbs transform (module notes)."""
    rig = case.rig
    scale = dict(case.bone_scale)
    for names, factor in ((LEFT_LEG, 1.08), (RIGHT_LEG, 0.96), (ARMS, 1.10)):
        for name in names:
            scale[name] = factor
    canon = {case.names[name]: name for name in CANON}
    offsets = rig.offsets.copy()
    for j, parent in enumerate(rig.parents):
        if parent >= 0:
            offsets[j] = offsets[j] * scale.get(canon.get(rig.names[parent]), 1.0)
    sites = tuple((name, j, offset * scale.get(canon.get(rig.names[j]), 1.0)) for name, j, offset in rig.sites)
    legs = np.mean([np.linalg.norm(rig.offsets[rig.names.index(case.names[n])]) * (scale[p] - 1.0)
                    for p, n in (("LeftHip", "LeftKnee"), ("LeftKnee", "LeftAnkle"), ("RightHip", "RightKnee"),
                                 ("RightKnee", "RightAnkle"))]) * 2  # fmt: skip
    new = dataclasses.replace(rig, offsets=offsets, sites=sites)
    rotations, translations = joint_values(rig)
    translations = np.where(np.arange(len(rig.names))[None, :, None] == 0, translations, offsets[None])
    translations[:, 0, 1] += legs
    return Case(case.name + "_limbs", encode(new, rotations, translations, rig.frame_time), case.names, case.unit,
                scale, "left leg +8 %, right leg -4 %, arms +10 %")  # fmt: skip


def _lowered(case: Case, frames: np.ndarray, metres: float) -> np.ndarray:
    """`frames` of `case`'s rig with the root `metres` lower."""
    out = frames.copy()
    out[:, [k for k, (j, c) in enumerate(case.rig.columns) if j == 0 and c == "Yposition"]] -= metres * case.unit
    return out


def noisy(case: Case, seed: int = 0, degrees: float = 0.2) -> Case:
    """The noisy transform (module notes); `degrees` other than 0.2 scales the noise of every
    channel (the root's millimetre with it)."""
    rig = case.rig
    rng = np.random.default_rng(seed)
    frames = rig.frames.copy()
    for k, (j, channel) in enumerate(rig.columns):
        if channel.endswith("rotation"):
            frames[:, k] += rng.normal(0.0, degrees, len(frames))
        elif j == 0:
            frames[:, k] += rng.normal(0.0, 0.001 * case.unit * degrees / 0.2, len(frames))
    noisy_rig = dataclasses.replace(rig, frames=_lowered(case, frames, SUNK))
    description = "noise, 12 mm under the floor"
    return dataclasses.replace(case, name=case.name + "_noisy", rig=noisy_rig, description=description, truth=rig)


def _t_pose(rig: Rig, frame: np.ndarray) -> np.ndarray:
    """`frame` (C,) of `rig` with every rotation channel 0: the rig's T-pose."""
    out = frame.copy()
    out[[k for k, (_, c) in enumerate(rig.columns) if c.endswith("rotation")]] = 0.0
    return out


def bind(case: Case) -> Case:
    """The bind transform (module notes)."""
    rig = case.rig
    pose = _t_pose(rig, rig.frames[0])
    lowest = pose_points(dataclasses.replace(rig, frames=pose[None]))[0, :, 1].min()
    pose[[k for k, (j, c) in enumerate(rig.columns) if j == 0 and c == "Yposition"]] -= lowest
    rig = dataclasses.replace(rig, frames=np.concatenate([pose[None], rig.frames]))
    return dataclasses.replace(case, name=case.name + "_bind", rig=rig, description="a T-pose frame before the motion")


def glitch(case: Case) -> Case:
    """The glitch transform (module notes)."""
    frames = case.rig.frames.copy()
    middle = len(frames) // 2
    frames[middle] = _t_pose(case.rig, frames[middle])
    rig = dataclasses.replace(case.rig, frames=frames)
    description = "the middle frame a T-pose"
    return dataclasses.replace(case, name=case.name + "_glitch", rig=rig, description=description, truth=case.rig)


def stand(case: Case) -> Case:
    """The stand transform (module notes)."""
    frames, n = case.rig.frames, int(round(STAND_SECONDS / case.rig.frame_time))
    held = np.concatenate([np.repeat(frames[:1], n, axis=0), frames, np.repeat(frames[-1:], n, axis=0)])
    rig = dataclasses.replace(case.rig, frames=_lowered(case, held, SUNK))
    description = "standing 2 s at each end, 12 mm deep"
    truth = dataclasses.replace(case.rig, frames=held)
    return dataclasses.replace(case, name=case.name + "_stand", rig=rig, description=description, truth=truth)


def _turned(case: Case, turns: dict, suffix: str, description: str) -> Case:
    """`case` with the frame of each canonical joint of `turns` {canonical name: C (3, 3)} turned
    by C: its rotation R_j becomes C_parent^T R_j C_j and the OFFSETs below it C_j^T o, so every
    world position stays."""
    rig = case.rig
    rotations, translations = joint_values(rig)
    canon = {name: key for key, name in case.names.items()}
    turn = np.array([turns.get(canon.get(name, ""), np.eye(3)) for name in rig.names])
    up = np.array([turn[p] if p >= 0 else np.eye(3) for p in rig.parents])
    rotations = np.einsum("jki,njkl,jlm->njim", up, rotations, turn)
    translations = np.einsum("jki,njk->nji", up, translations)
    offsets = np.einsum("jki,jk->ji", up, rig.offsets)
    sites = tuple((name, j, turn[j].T @ offset) for name, j, offset in rig.sites)
    new = dataclasses.replace(rig, offsets=offsets, sites=sites)
    rig = encode(new, rotations, translations, rig.frame_time)
    return dataclasses.replace(case, name=case.name + suffix, rig=rig, description=description, turns=turns)


def tpose(case: Case) -> Case:
    """The tpose transform (module notes)."""
    turns = {
        key: Rotation.from_euler("z", 90.0 if key.startswith("Left") else -90.0, degrees=True).as_matrix()
        for key in case.names
        if key.endswith(("Shoulder", "Elbow"))
    }
    return _turned(case, turns, "_tpose", "a T-pose rest: arms sideways at rotation 0")


def laid(case: Case) -> Case:
    """The laid transform (module notes)."""
    turn = Rotation.from_euler("x", -90.0, degrees=True).as_matrix()
    return _turned(case, dict.fromkeys(case.names, turn), "_laid", "a rest pose lying on its back, the hips turned up")


# metres: each finger's spread across the palm and its three bones
FINGERS = ((-0.03, (0.045, 0.03, 0.022)), (-0.01, (0.05, 0.032, 0.024)), (0.01, (0.048, 0.03, 0.022)),
           (0.03, (0.04, 0.025, 0.02)), (0.04, (0.03, 0.03, 0.025)))  # fmt: skip
PALM, TOE, CURL = 0.08, 0.7, 15.0  # metres from the wrist to the knuckles; the toe joint's share; degrees
TOE_BEND, TOE_HERTZ = 5.0, 0.7  # degrees, cycles per second: the toes transform
FINGER_BEND, FINGER_HERTZ = 10.0, 0.5  # degrees, cycles per second: the fingers transform
TWIST_AT, TWIST_STUB = (0.33, 0.66), 0.05  # of the bone: where twist bones hang, their End Sites' length
TWIST_TURN, TWIST_HERTZ = 20.0, 0.4  # degrees, cycles per second: how they turn about the bone
CHANNELS = ("Zrotation", "Xrotation", "Yrotation")  # of every joint a transform adds


def _nodes(rig: Rig) -> list[list]:
    """`rig`'s joints as nodes [name, parent node, OFFSET, channels, rotations (N, 3, 3),
    translations (N, 3)] that a transform may add to and rewire, for _built."""
    rotations, translations = joint_values(rig)
    return [[name, parent, rig.offsets[j], rig.channels[j], rotations[:, j], translations[:, j]]
            for j, (name, parent) in enumerate(zip(rig.names, rig.parents))]  # fmt: skip


def _built(rig: Rig, nodes: list[list], sites: list) -> Rig:
    """A Rig of `nodes` (_nodes) and `sites` [(name, node, offset)], its joints in depth-first
    order as a BVH file lists them, its frames encoded from the nodes' motion (`rig`'s frame
    time and position mode)."""
    order = []

    def visit(k):
        order.append(k)
        for c, node in enumerate(nodes):
            if node[1] == k and c != k:
                visit(c)

    visit(0)
    at = {k: i for i, k in enumerate(order)}
    new = Rig(
        tuple(nodes[k][0] for k in order),
        tuple(at[nodes[k][1]] if nodes[k][1] >= 0 else -1 for k in order),
        np.array([nodes[k][2] for k in order]),
        tuple(nodes[k][3] for k in order),
        tuple((name, at[j], offset) for name, j, offset in sites),
        np.zeros((0, 0)),
        0.0,
        rig.position_mode,
    )
    rotations = np.stack([nodes[k][4] for k in order], axis=1)
    translations = np.stack([nodes[k][5] for k in order], axis=1)
    return encode(new, rotations, translations, rig.frame_time)


def digits(case: Case) -> Case:
    """The digits transform (module notes)."""
    rig, unit = case.rig, case.unit
    N = len(rig.frames)
    nodes = _nodes(rig)
    channels = CHANNELS
    still, curl = (
        np.broadcast_to(np.eye(3), (N, 3, 3)),
        np.broadcast_to(Rotation.from_euler("x", CURL, degrees=True).as_matrix(), (N, 3, 3)),
    )

    def add(name, parent, offset, rotation):
        nodes.append([name, parent, offset, channels, rotation, np.broadcast_to(offset, (N, 3))])
        return len(nodes) - 1

    hands = {case.names[name] for name in ("RightElbow", "LeftElbow")}
    feet = {case.names[name] for name in ("RightAnkle", "LeftAnkle")}
    sites = []
    for name, j, offset in rig.sites:
        along = offset / np.linalg.norm(offset)
        if rig.names[j] in hands:
            wrist = add(f"{rig.names[j]}_wrist", j, offset, still)
            across = np.cross(along, [1.0, 0.0, 0.0])
            across /= np.linalg.norm(across)
            for f, (spread, bones) in enumerate(FINGERS):
                joint, step = wrist, (along * PALM + across * spread) * unit
                for k, length in enumerate(bones):
                    joint = add(f"{rig.names[j]}_finger{f}{k}", joint, step, curl)
                    step = along * length * unit
                sites.append((f"{nodes[joint][0]}_end", joint, step))
        elif rig.names[j] in feet:
            toe = add(f"{rig.names[j]}_toe", j, offset * TOE, still)
            sites.append((f"{nodes[toe][0]}_end", toe, offset * (1.0 - TOE)))
        else:
            sites.append((name, j, offset))
    rig = _built(rig, nodes, sites)
    ankles = {case.names[f"{side}Ankle"]: side for side in ("Right", "Left")}
    toes = {f"{ankles[name[:-4]]}Toe": name for name in rig.names if name.endswith("_toe") and name[:-4] in ankles}
    names = {**case.names, **toes}
    description = "still fingers, wrists and toes"
    return dataclasses.replace(case, name=case.name + "_digits", rig=rig, names=names, description=description)


def twists(case: Case) -> Case:
    """The twists transform (module notes)."""
    rig = case.rig
    N = len(rig.frames)
    nodes, sites = _nodes(rig), list(rig.sites)
    t = np.arange(N) * rig.frame_time
    for canon in (*LEFT_LEG[:2], *RIGHT_LEG[:2], *ARMS):
        j = rig.names.index(case.names[canon])
        child = next((node[2] for node in nodes if node[1] == j), None)
        along = child if child is not None else next(offset for _, k, offset in rig.sites if k == j)
        for k, share in enumerate(TWIST_AT):
            angle = TWIST_TURN * np.sin(2.0 * np.pi * TWIST_HERTZ * t + k)
            turn = Rotation.from_euler("y", angle[:, None], degrees=True).as_matrix()
            nodes.append(
                [f"{rig.names[j]}_twist{k}", j, along * share, CHANNELS, turn, np.broadcast_to(along * share, (N, 3))]
            )
            sites.append((f"{rig.names[j]}_twist{k}_end", len(nodes) - 1, along * TWIST_STUB))
    rig = _built(rig, nodes, sites)
    return dataclasses.replace(case, name=case.name + "_twists", rig=rig, description="twist bones on the limbs")


def fingers(case: Case) -> Case:
    """The fingers transform (module notes)."""
    case = digits(case)
    rig = case.rig
    frames = rig.frames.copy()
    t = np.arange(len(frames)) * rig.frame_time
    bent = [k for k, (j, c) in enumerate(rig.columns) if "_finger" in rig.names[j] and c == "Xrotation"]
    for phase, column in enumerate(bent):
        frames[:, column] += FINGER_BEND * np.sin(2.0 * np.pi * FINGER_HERTZ * t + phase)
    rig = dataclasses.replace(rig, frames=frames)
    name = case.name[: -len("_digits")] + "_fingers"
    return dataclasses.replace(case, name=name, rig=rig, description="moving fingers, still toes")


def toes(case: Case) -> Case:
    """The toes transform (module notes)."""
    case = digits(case)
    rig = case.rig
    frames = rig.frames.copy()
    t = np.arange(len(frames)) * rig.frame_time
    for side, phase in (("Right", 0.0), ("Left", 1.0)):
        joint = rig.names.index(case.names[f"{side}Toe"])
        column = rig.columns.index((joint, "Xrotation"))
        frames[:, column] += TOE_BEND * np.sin(2.0 * np.pi * TOE_HERTZ * t + phase)
    rig = dataclasses.replace(rig, frames=frames)
    return dataclasses.replace(case, name=case.name[: -len("_digits")] + "_toes", rig=rig, description="bending toes")


def seats(case: Case) -> Case:
    """The seats transform (module notes)."""
    rig = case.rig
    N = len(rig.frames)
    nodes = _nodes(rig)
    for key in ("RightHip", "LeftHip", "Chest"):
        j = rig.names.index(case.names[key])
        still = np.broadcast_to(np.eye(3), (N, 3, 3))
        nodes.append([f"{rig.names[j]}_seat", nodes[j][1], np.zeros(3), CHANNELS, still, np.zeros((N, 3))])
        nodes[j][1] = len(nodes) - 1
    rig = _built(rig, nodes, list(rig.sites))
    description = "joints at the hips' origin (zero OFFSET) above each leg and the chest"
    return dataclasses.replace(case, name=case.name + "_seats", rig=rig, description=description)


TRANSFORMS = {"studio": studio, "anon": anon, "backwards": backwards, "fast": fast, "limbs": limbs, "noisy": noisy,
              "bind": bind, "glitch": glitch, "stand": stand, "digits": digits, "tpose": tpose,
              "laid": laid, "seats": seats, "hifps": hifps, "pal": pal, "shaky": shaky, "toes": toes,
              "fingers": fingers, "twists": twists}  # fmt: skip


def source_cases(folder: Path, names: list[str] | None = None) -> list[Case]:
    """The humanoid3d_*.bvh clips of `folder` as they are (source_case), in name order; only
    those `names` when given."""
    bases = [source_case(path) for path in sorted(folder.glob("humanoid3d_*.bvh"))]
    return [base for base in bases if not names or base.name in names]


def cases(folder: Path, names: list[str] | None = None) -> list[Case]:
    """Every shared clip in `folder` (or those `names`), its studio rig, its EXTRAS transform,
    its CUTS transform, if any, its stand if in STANDS, its digits if in DIGITS, its laid rest if
    in LAID, its 120 fps copy if in HIFPS, its noisy copy at 60 fps or more if in SHAKY, its
    digits with noise (fingers and toes the capture only shakes), its moving fingers if in
    FINGERED, its twist bones if in TWISTED, its toes, without and with noise, and its copy at
    50 fps."""
    out = []
    for base in source_cases(folder, names):
        out += [base, studio(base), TRANSFORMS[EXTRAS.get(base.name, "noisy")](base)]
        out += [TRANSFORMS[CUTS[base.name]](base)] if base.name in CUTS else []
        out += [stand(base)] if base.name in STANDS else []
        out += [digits(base)] if base.name in DIGITS else []
        out += [laid(base)] if base.name in LAID else []
        out += [hifps(base)] if base.name in HIFPS else []
        out += [shaky(base)] if base.name in SHAKY else []
        out += [fingers(base)] if base.name in FINGERED else []
        out += [twists(base)] if base.name in TWISTED else []
        out += [noisy(digits(base)), toes(base), noisy(toes(base)), pal(base)]
    return out

"""Targets for the robot IK benchmark (TRAC-IK protocol) and the one scorer every solver gets.

For a case (robot, base link, tip link): N joint configurations drawn uniformly inside the joint
limits (seeded), the tip's pose at each by deik's float64 forward kinematics (the targets), and
the mid-limit start pose every solver begins from. `pose_errors` scores any solver's joint
solutions with deik's FK, so no solver's own error report is trusted. Besides the shared data's
robots, two made here that deik was never tuned on (GENERATED): the Panda with every arm joint
continuous, and a six-joint arm with a UR5's published kinematics and limits of +-2 pi. `export_chain` writes the
arrays a vectorised FK needs (benchmarks/peers/chain_fk.py) for the DE peers.
Units: metres, radians.
"""

from __future__ import annotations

import math
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import deik
from benchmarks.data import need
from benchmarks.peers.chain_fk import rotation_angle
from benchmarks.peers.common import LIMIT_SLACK
from deik.model.joints import ROTATE


@dataclass(frozen=True)
class Case:
    """A robot file of the shared data's robots/ and the chain cut from it."""

    urdf: str
    base: str
    tip: str


CASES = {
    "panda": Case("panda.urdf", "panda_link0", "panda_hand_tcp"),
    "iiwa": Case("kuka_iiwa.urdf", "lbr_iiwa_link_0", "lbr_iiwa_link_7"),
    "human": Case("human.urdf", "middle_pelvis", "right_hand"),
    "panda_continuous": Case("panda_continuous.urdf", "panda_link0", "panda_hand_tcp"),
    "ur5_wide": Case("ur5_wide.urdf", "base_link", "tool0"),
}
GENERATED_DIR = Path(tempfile.gettempdir()) / "deik-benchmark-robots"
# a UR5's joints as its public description places them: (name, parent link, child link, xyz
# metres, rpy radians, axis); every one turns within +-2 pi
UR5_JOINTS = (
    ("shoulder_pan_joint", "base_link", "shoulder_link", (0, 0, 0.089159), (0, 0, 0), (0, 0, 1)),
    ("shoulder_lift_joint", "shoulder_link", "upper_arm_link", (0, 0.13585, 0), (0, math.pi / 2, 0), (0, 1, 0)),
    ("elbow_joint", "upper_arm_link", "forearm_link", (0, -0.1197, 0.425), (0, 0, 0), (0, 1, 0)),
    ("wrist_1_joint", "forearm_link", "wrist_1_link", (0, 0, 0.39225), (0, math.pi / 2, 0), (0, 1, 0)),
    ("wrist_2_joint", "wrist_1_link", "wrist_2_link", (0, 0.093, 0), (0, 0, 0), (0, 0, 1)),
    ("wrist_3_joint", "wrist_2_link", "wrist_3_link", (0, 0, 0.09465), (0, 0, 0), (0, 1, 0)),
)


def _continuous_panda() -> str:
    """The shared Panda with its seven arm joints continuous (no limits)."""
    root = ET.parse(need("robots", "panda.urdf")).getroot()
    for joint in root.findall("joint"):
        if joint.get("type") == "revolute" and joint.get("name", "").startswith("panda_joint"):
            joint.set("type", "continuous")
            for element in joint.findall("limit") + joint.findall("safety_controller"):
                joint.remove(element)
    return ET.tostring(root, encoding="unicode")


def _wide_ur5() -> str:
    """A UR5-type arm (UR5_JOINTS) with a tool flange 0.0823 m past the last wrist, limits +-2 pi."""
    robot = ET.Element("robot", name="ur5_wide")
    links = ["base_link"] + [child for _, _, child, *_ in UR5_JOINTS] + ["tool0"]
    for link in links:
        ET.SubElement(robot, "link", name=link)
    joints = UR5_JOINTS + (("tool0_fixed_joint", "wrist_3_link", "tool0", (0, 0.0823, 0), (-math.pi / 2, 0, 0), None),)
    for name, parent, child, xyz, rpy, axis in joints:
        joint = ET.SubElement(robot, "joint", name=name, type="fixed" if axis is None else "revolute")
        ET.SubElement(joint, "parent", link=parent)
        ET.SubElement(joint, "child", link=child)
        ET.SubElement(joint, "origin", xyz=" ".join(map(str, xyz)), rpy=" ".join(map(str, rpy)))
        if axis is not None:
            ET.SubElement(joint, "axis", xyz=" ".join(map(str, axis)))
            limits = {"lower": str(-2 * math.pi), "upper": str(2 * math.pi), "effort": "150", "velocity": "3.15"}
            ET.SubElement(joint, "limit", limits)
    return ET.tostring(robot, encoding="unicode")


GENERATED = {"panda_continuous": _continuous_panda, "ur5_wide": _wide_ur5}


def robot_file(name: str, robots: Path | None = None) -> Path:
    """The URDF of case `name`: in `robots` (default the shared data's robots/), or written into
    GENERATED_DIR for a generated case."""
    case = CASES[name]
    if name in GENERATED:
        GENERATED_DIR.mkdir(exist_ok=True)
        path = GENERATED_DIR / case.urdf
        path.write_text(GENERATED[name]())
        return path
    return Path(robots) / case.urdf if robots else need("robots", case.urdf)


def load_case(name: str, robots: Path | None = None) -> tuple[deik.Skeleton, Case, Path]:
    """The deik skeleton of case `name`, the case and the URDF path (in `robots`, default the
    shared data's robots/)."""
    case = CASES[name]
    path = robot_file(name, robots)
    return deik.read_urdf(path, case.base, case.tip), case, path


def make_targets(name: str, n: int, seed: int = 0, robots: Path | None = None) -> dict:
    """N targets of case `name`: q_true (N, D) uniform in [lower, upper]; positions (N, 3) m and
    rotations (N, 3, 3) of the tip in the base frame; start (D,) mid-limit pose; limits (D,)."""
    skeleton, case, path = load_case(name, robots)
    rng = np.random.default_rng(seed)
    q_true = rng.uniform(skeleton.lower, skeleton.upper, (n, skeleton.n_dofs))
    kin = deik.forward_kinematics(skeleton, q_true)
    return {
        "case": name,
        "urdf": str(path),
        "base": case.base,
        "tip": case.tip,
        "seed": seed,
        "dof_names": np.array(skeleton.dof_names),
        "joint_names": np.array(skeleton.joint_names),
        "q_true": q_true,
        "positions": kin.position(case.tip),
        "rotations": kin.rotation(case.tip),
        "start": (skeleton.lower + skeleton.upper) / 2,
        "lower": skeleton.lower.copy(),
        "upper": skeleton.upper.copy(),
    }


def save_targets(targets: dict, path: Path) -> None:
    """Write a make_targets dict to an .npz file (strings as 0-d arrays; peers.common.load_targets
    reads it)."""
    np.savez(path, **{k: np.asarray(v) for k, v in targets.items()})


def pose_errors(skeleton: deik.Skeleton, tip: str, Q, positions, rotations):
    """Score joint solutions Q (N, D) against targets (N, 3) m and (N, 3, 3) with deik's float64
    FK -> position error (N,) m, orientation error (N,) rad (angle of R_target^T R), and
    within_limits (N,) bool (every joint inside [lower, upper] up to LIMIT_SLACK). Rows of Q that
    are not finite get infinite errors and count as outside the limits."""
    Q = np.asarray(Q, dtype=np.float64)
    finite = np.isfinite(Q).all(axis=1)
    kin = deik.forward_kinematics(skeleton, np.where(finite[:, None], Q, skeleton.lower))
    pos = np.linalg.norm(kin.position(tip) - positions, axis=1)
    rot = rotation_angle(np.asarray(rotations, dtype=np.float64), kin.rotation(tip))
    inside = ((Q >= skeleton.lower - LIMIT_SLACK) & (Q <= skeleton.upper + LIMIT_SLACK)).all(axis=1)
    return np.where(finite, pos, np.inf), np.where(finite, rot, np.inf), inside & finite


def export_chain(skeleton: deik.Skeleton, tip: str) -> dict:
    """Arrays for benchmarks/peers/chain_fk.py: the joints from the root to `tip`'s joint
    (`path`, root first) with their parents (J,), offsets (J, 3) m, rest rotations (J, 3, 3);
    their motions (free and mimic DOFs: joint_start (J+1,), rotate (M,) bool, axis (M, 3),
    source (M,), scale (M,), bias (M,)); the tip's joint, offset (3,) and rotation (3, 3) in it;
    limits (D,)."""
    frame = skeleton.frame_index(tip)
    if frame < skeleton.n_joints:
        tip_joint, tip_offset, tip_rotation = frame, np.zeros(3), np.eye(3)
    else:
        s = frame - skeleton.n_joints
        tip_joint = int(skeleton.site_joint[s])
        tip_offset, tip_rotation = skeleton.site_offset[s], skeleton.site_rotation[s]
    path = [tip_joint]
    while skeleton.parents[path[-1]] >= 0:
        path.append(int(skeleton.parents[path[-1]]))
    m = skeleton.motions
    return {
        "path": np.array(path[::-1], np.int64),
        "parents": np.asarray(skeleton.parents, np.int64),
        "offsets": skeleton.offsets.copy(),
        "joint_rotation": skeleton.joint_rotation.copy(),
        "joint_start": np.asarray(m.joint_start, np.int64),
        "rotate": m.kind == ROTATE,
        "axis": m.axis.copy(),
        "source": np.asarray(m.source, np.int64),
        "scale": m.scale.copy(),
        "bias": m.bias.copy(),
        "tip_joint": np.int64(tip_joint),
        "tip_offset": np.array(tip_offset),
        "tip_rotation": np.array(tip_rotation),
        "lower": skeleton.lower.copy(),
        "upper": skeleton.upper.copy(),
    }

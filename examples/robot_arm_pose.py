"""For roboticists: a URDF arm's 6-D pose (position and orientation of the tool), solved again
and again by one reused Solver, as a control loop would.

    python examples/robot_arm_pose.py [ARM.urdf [TARGETS]]

The Panda from ../shared/data beside the clone (or $DEIK_SHARED_DATA) by default, base
panda_link0, tool frame panda_hand_tcp. Each target is the tool pose of a random pose within the
limits (so it is reachable); the Solver checks and packs only the new targets, and each solve
starts from the previous answer. Met within 0.01 mm and 0.01 degrees, in float64.
"""

import math
import os
import sys
import time
from pathlib import Path

import numpy as np

import deik

DATA = Path(os.environ.get("DEIK_SHARED_DATA") or Path(__file__).resolve().parents[2] / "shared" / "data")
BASE, TOOL = "panda_link0", "panda_hand_tcp"


def tool_poses(arm, count: int, seed: int) -> np.ndarray:
    """(count, 4, 4) world poses of the tool frame in random poses within the limits."""
    angles = np.random.default_rng(seed).uniform(arm.lower, arm.upper, (count, arm.n_dofs))
    kin = deik.forward_kinematics(arm, angles)
    poses = np.tile(np.eye(4), (count, 1, 1))
    poses[:, :3, :3], poses[:, :3, 3] = kin.rotation(TOOL), kin.position(TOOL)
    return poses


def main(path: str, count: int) -> None:
    arm = deik.read_urdf(path, base=BASE, tip=TOOL)  # the chain from the base to the tool frame
    targets = tool_poses(arm, count, seed=0)
    goals = deik.pose_goals(TOOL, targets[0], tolerance=1e-5, angle_tolerance=math.radians(0.01))
    ik = deik.Solver(deik.Problem(arm, list(goals)), population=32, dtype="float64", seed=0)

    current = arm.reference  # where the arm is now
    times, met, worst = [], 0, [0.0, 0.0]
    for T in targets:
        began = time.perf_counter()
        result = ik.solve({f"position {TOOL}": T[:3, 3], f"orientation {TOOL}": T}, initial=current[None])
        times.append(time.perf_counter() - began)
        met += bool(result.converged)
        position, orientation = (float(goal.error) for goal in result.goals)
        worst = [max(worst[0], position), max(worst[1], math.degrees(orientation))]
        current = result.angles  # the next solve starts here

    print(f"{arm.name}: {arm.n_dofs} DOFs, {count} tool poses, one reused Solver")
    print(f"met {met}/{count}; worst errors {worst[0] * 1000:.4f} mm and {worst[1]:.4f} degrees")
    print(f"time per solve: median {np.median(times) * 1000:.2f} ms (the first includes loading the kernels)")
    print("last answer by joint (degrees):")
    for joint, values in result.angles_by_joint.items():
        print(f"  {joint:14s} {math.degrees(values[0]):8.2f}")


if __name__ == "__main__":
    arguments = sys.argv[1:]
    main(
        arguments[0] if arguments else str(DATA / "robots" / "panda.urdf"),
        int(arguments[1]) if len(arguments) > 1 else 50,
    )

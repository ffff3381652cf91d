"""The goal flags of `deik solve` (--reach, --orient, tolerances, --com-over, --obstacle,
--self-collision, --comfort) and the goals they make. Angles on the command line are degrees; the orientation
form is always named (docs/conventions.md):

    --orient FRAME rpy R P Y               URDF roll, pitch, yaw: R = Rz(Y) Ry(P) Rx(R)
    --orient FRAME xyz A B C               intrinsic Euler X, Y, Z: R = Rx(A) Ry(B) Rz(C)
    --orient FRAME quat-wxyz W X Y Z       unit quaternion, scalar first
    --orient FRAME quat-xyzw X Y Z W       unit quaternion, scalar last
    --orient FRAME matrix R00 R01 ... R22  rotation matrix, row by row
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np

from deik.cleanup.units import METRES
from deik.cli.arguments import UsageError, number, numbers
from deik.objectives import goals as g
from deik.objectives.self_collision import SelfCollision

# CLI form -> (numbers it takes, whether they are degrees, what they are)
ORIENT_FORMS = {
    "rpy": (3, True, "R P Y: URDF roll, pitch, yaw in degrees (fixed axes X, Y, Z)"),
    "xyz": (3, True, "A B C: intrinsic Euler angles about X, new Y, new Z in degrees"),
    "quat-wxyz": (4, False, "W X Y Z: a unit quaternion, scalar first"),
    "quat-xyzw": (4, False, "X Y Z W: a unit quaternion, scalar last"),
    "matrix": (9, False, "R00 R01 R02 R10 ... R22: a rotation matrix row by row"),
}
FRAME_COMFORT = 1.0  # default weight of "stay near the clip frame / --start pose"
ORIENT_HELP = "; ".join(f"{form} {text}" for form, (_, _, text) in ORIENT_FORMS.items())


def add_goal_arguments(s: argparse.ArgumentParser) -> None:
    """The goal flags on `deik solve`'s subparser `s`."""
    s.add_argument(
        "--reach",
        nargs=4,
        action="append",
        default=[],
        metavar=("FRAME", "X", "Y", "Z"),
        help="put joint or site FRAME at X Y Z (length units; repeatable)",
    )
    s.add_argument(
        "--orient",
        nargs="+",
        action="append",
        default=[],
        metavar=("FRAME", "FORM VALUE"),
        help=f"turn FRAME to an orientation given as FORM and its numbers (repeatable): {ORIENT_HELP}",
    )
    s.add_argument(
        "--tolerance",
        type=number(0.0),
        metavar="LENGTH",
        help="--reach and --com-over goals are met within this distance (length units; default 1 mm "
        f"in the skeleton's unit, `deik info` says which; {g.LENGTH_TOLERANCE:g} where it has none)",
    )
    s.add_argument(
        "--angle-tolerance",
        type=number(0.0, 180.0),
        metavar="DEGREES",
        help=f"--orient goals are met within this angle (default {math.degrees(g.ANGLE_TOLERANCE):g} degrees)",
    )
    s.add_argument(
        "--com-over",
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="keep the centre of mass over this support point (horizontally)",
    )
    s.add_argument(
        "--obstacle",
        nargs=4,
        action="append",
        default=[],
        metavar=("X", "Y", "Z", "RADIUS"),
        help="keep every bone out of this sphere (repeatable)",
    )
    s.add_argument(
        "--self-collision",
        type=number(0.0),
        metavar="MARGIN",
        help="keep the bone capsules apart by MARGIN (length units, e.g. 0), above every other goal in priority",
    )
    s.add_argument(
        "--comfort",
        type=number(-1.0, 1.0),
        metavar="WEIGHT",
        help="stay near the rest pose (BVH: near the frame's pose, default weight 1) with this "
        "weight in [-1, 1], below the other goals in priority; 0 turns it off",
    )


def has_goals(args: argparse.Namespace) -> bool:
    """Whether any goal flag was given."""
    flags = (args.reach, args.orient, args.com_over, args.obstacle)
    return any(flags) or args.comfort is not None or args.self_collision is not None


def orientation_goal(words: list[str], tolerance: float | None) -> g.Orientation:
    """The Orientation goal of one --orient FRAME FORM VALUE... (degrees converted to radians)."""
    if len(words) < 2 or words[1] not in ORIENT_FORMS:
        given = words[1] if len(words) > 1 else "nothing"
        raise UsageError(
            f"--orient {' '.join(words)}: after FRAME name the form ({', '.join(ORIENT_FORMS)}), got {given!r}; "
            f"e.g. --orient {words[0]} rpy 0 90 0 (the old three Euler angles are now: xyz A B C)"
        )
    frame, form, values = words[0], words[1], words[2:]
    count, degrees, text = ORIENT_FORMS[form]
    if len(values) != count:
        raise UsageError(f"--orient {frame} {form} takes {count} numbers ({text}), got {len(values)}")
    value = np.asarray(numbers("--orient", values))
    if degrees:
        value = np.radians(value)
    elif form == "matrix":
        value = value.reshape(3, 3)
    goal = g.Orientation(frame, value, form, tolerance=tolerance)
    try:
        goal.rotation()
    except ValueError as error:
        raise UsageError(f"--orient {frame} {form}: {error}") from None
    return goal


def goals_from_flags(args: argparse.Namespace, frame_pose: np.ndarray | None, unit: str) -> list[g.Goal]:
    """Goals from the goal flags: targets on priority level 0, comfort below them on level 1
    (its reference `frame_pose` (D,), radians / length units, or None for the rest pose); with
    --self-collision, that goal on level 0 and every other one level lower. Without --tolerance
    a distance is met within 1 mm in the skeleton's length `unit` (deik.viz.marks.length_unit:
    0.1 in centimetres, 1 in millimetres), or g.LENGTH_TOLERANCE units when it has none."""
    angle_tolerance = None if args.angle_tolerance is None else math.radians(args.angle_tolerance)
    tolerance = args.tolerance
    if tolerance is None and unit in METRES:
        tolerance = 0.001 / METRES[unit]
    _once("--reach", [frame for frame, *_ in args.reach])
    goals = [g.Position(frame, numbers("--reach", xyz), tolerance=tolerance) for frame, *xyz in args.reach]
    _once("--orient", [words[0] for words in args.orient])
    goals += [orientation_goal(words, angle_tolerance) for words in args.orient]
    if args.com_over:
        goals.append(g.ComOverSupport(numbers("--com-over", args.com_over), tolerance=tolerance))
    for values in args.obstacle:
        *centre, radius = numbers("--obstacle", values)
        if not radius > 0:
            raise UsageError(f"--obstacle {' '.join(values)}: the radius (the last number) must be above 0")
        goals.append(g.Obstacle(centre, radius))
    weight = args.comfort if args.comfort is not None else (FRAME_COMFORT if frame_pose is not None else None)
    if weight:
        goals.append(g.Comfort(weight=weight, level=1, reference=frame_pose))
    if args.self_collision is not None:  # a target inside the body never buys a penetration
        goals = [SelfCollision(margin=args.self_collision)] + [replace(goal, level=goal.level + 1) for goal in goals]
    return goals


def _once(flag: str, frames: list[str]) -> None:
    """UsageError when `flag` names one joint or site twice: two targets for one point at one
    priority are a compromise between them that meets neither."""
    twice = sorted({frame for frame in frames if frames.count(frame) > 1})
    if twice:
        raise UsageError(f"{flag} {twice[0]} is given more than once: give one target per joint or site")

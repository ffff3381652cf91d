"""`deik retarget`: move a BVH clip onto other bone lengths or onto another skeleton.

    deik retarget walk.bvh --scale LeftHip=1.1,RightHip=1.1 --out walk_long_legs.bvh
    deik retarget walk.bvh --to tall.bvh --out walk_tall.bvh
    deik retarget walk.bvh --map examples/maps/shared_bvh_to_human_urdf.toml --to human.urdf \
        --out walk_human.csv --view walk_human.bvh --json walk_human_report.json
"""

from __future__ import annotations

import argparse
import os
import re
from collections.abc import Callable
from typing import TYPE_CHECKING

from deik.cli.arguments import UsageError, add_free_translations, add_up, check_outputs, up_of
from deik.console import add_output_flags, frames_reporter, progress_bar, show_progress
from deik.io.atomic import all_or_nothing, write_json_atomically
from deik.io.bvh import read_bvh, write_bvh
from deik.io.motion import Clip
from deik.io.trajectory import write_trajectory
from deik.viz.text import cut_lines, figure, format_table

if TYPE_CHECKING:  # deik.retargeting loads when a clip is retargeted
    from deik.retargeting.outcome import Retarget

SHOWN_STEPS = 10  # velocity violations printed; --json lists them all
FRAMES = re.compile(r"\s*(-?\d{1,12})?\s*:\s*(-?\d{1,12})?\s*")  # 12 digits: no clip is longer
SHOWN = (
    ("keypoint_error_mean_mm", "key-point error, mean", "mm"),
    ("keypoint_worst_max_mm", "key-point error, worst", "mm"),
    ("contact_sliding_max_mm_per_frame", "contact sliding, max", "mm/frame"),
    ("penetration_max_mm", "penetration, max", "mm"),
    ("floating_max_mm", "floating in contact, max", "mm"),
    ("self_penetration_max_mm", "self-penetration, max", "mm"),
    ("keypoint_velocity_peak_ratio", "key-point speed peak / targets'", "ratio"),
    ("keypoint_acceleration_peak_ratio", "key-point acceleration peak / targets'", "ratio"),
    ("joint_angle_deviation_mean_deg", "joint angle from the source, mean", "deg"),
    ("limit_violations_count", "limit violations", "count"),
    ("velocity_violations_count", "steps past a velocity limit (frame, DOF)", "count"),
    ("floor_height", "floor height (target world)", "length unit"),
    ("time_per_frame_ms", "time per frame", "ms"),
)


def add_arguments(r: argparse.ArgumentParser) -> None:
    """The `deik retarget` flags on subparser `r`."""
    r.add_argument("clip", metavar="IN.bvh", help="the source clip, or a folder of clips (every *.bvh in it)")
    r.add_argument(
        "--to", metavar="TARGET", help="the target: a .bvh (same rig, or with --map any rig), .urdf, humanoid"
    )
    r.add_argument("--scale", metavar="JOINT=FACTOR,...", help="scale the bones below these joints (same rig)")
    r.add_argument("--map", metavar="MAP.toml", help="joint map onto another skeleton (TOML or JSON, docs/retarget.md)")
    r.add_argument(
        "--out",
        required=True,
        metavar="OUT",
        help="OUT.bvh (a BVH target), or .csv/.json (joint trajectory); a folder for a folder of clips",
    )
    r.add_argument("--view", metavar="VIEW.bvh", help="also write a BVH of the target's motion to look at")
    r.add_argument("--json", metavar="report.json", help="the per-frame report as JSON")
    r.add_argument(
        "--frames", metavar="START:STOP", help="retarget only these source frames (STOP exclusive; -30: the last 30)"
    )
    add_free_translations(r)
    add_up(r)
    add_output_flags(r)


def _scale(text: str | None) -> dict | None:
    """{joint: factor} of --scale J=F,...; UsageError naming the form."""
    if text is None:
        return None
    factors = {}
    for part in text.split(","):
        joint, equals, value = part.partition("=")
        if joint.strip() in factors:
            raise UsageError(f"--scale {text!r}: {joint.strip()} is given twice; give each joint one factor")
        try:
            factors[joint.strip()] = float(value)
        except ValueError:
            equals = ""
        if not equals or not joint.strip():
            raise UsageError(f"--scale {text!r}: use JOINT=FACTOR[,JOINT=FACTOR...], e.g. LeftHip=1.1,RightHip=1.1")
    return factors


def _frames(text: str | None):
    if text is None:
        return None
    match = FRAMES.fullmatch(text)
    if not match:
        raise UsageError(
            f"--frames {text!r}: use START:STOP (whole numbers, STOP exclusive, either left out for the clip's "
            "start or end, a negative one counted from the end), e.g. 0:20 or -30:"
        )
    return tuple(None if value is None else int(value) for value in match.groups())


def retarget_options(args: argparse.Namespace) -> dict:
    """deik.retarget's keyword arguments from the flags: to, scale, joint_map and frames (cut
    from the source first)."""
    return {"to": args.to, "scale": _scale(args.scale), "joint_map": args.map, "frames": _frames(args.frames)}


def reading_options(args: argparse.Namespace) -> dict:
    """deik.read_bvh's keyword arguments for the source from the flags: free_translations, up."""
    return {"free_translations": args.free_translations, "up": up_of(args)}


def retarget_file(
    path: str, options: dict, reading: dict, progress: Callable[[int, int], None] | None = None
) -> Retarget:
    """deik.retarget of the BVH clip at `path`, read with `reading` (reading_options), with
    `options` (retarget_options); `progress(met, total)` follows the frames that meet their
    contacts."""
    from deik.retargeting.api import retarget
    from deik.retargeting.outcome import frame_range

    clip = frame_range(read_bvh(path, **reading), options["frames"])
    report = None if progress is None else (lambda met, stage: progress(met, clip.n_frames))
    return retarget(clip, **{**options, "frames": None}, progress=report)


def write_outputs(result: Retarget, paths: dict[str, str | None]) -> None:
    """Write the motion to paths["out"] (.bvh for a BVH target, else a .csv or .json joint
    trajectory) and, where given, its BVH view to paths["view"] and the report to
    paths["json"]: all or none. UsageError for a BVH target's motion asked as a trajectory."""
    out = paths["out"]
    if isinstance(result.motion, Clip) and not out.lower().endswith(".bvh"):
        raise UsageError(f"--out {out!r}: a BVH target's motion is written as .bvh")
    with all_or_nothing():
        if out.lower().endswith(".bvh"):
            write_bvh(out, result.clip)
        else:
            write_trajectory(out, result.motion)
        if paths.get("view"):
            write_bvh(paths["view"], result.clip)
        if paths.get("json"):
            write_json_atomically(paths["json"], result.report, missing_as_null=True)


def library_record(result: Retarget) -> dict:
    """What a folder run keeps of one clip: its frames and the report's summary."""
    summary = result.report["summary"]
    return {"frames": summary["frames_count"], "metrics": dict(summary)}


def print_velocity_steps(result: Retarget) -> None:
    """The first SHOWN_STEPS steps between frames that a DOF's velocity limit does not allow,
    in the target's units (rad, or a URDF's m)."""
    from deik.model.joints import ROTATE

    dofs = result.motion.skeleton
    for step in result.report.get("velocity_violations", [])[:SHOWN_STEPS]:
        unit = "rad" if dofs.dof_kind[dofs.dof_names.index(step["dof"])] == ROTATE else "m"
        print(
            f"frame {step['frame']}->{step['frame'] + 1}: {step['dof']} steps {step['step']:.4g} {unit}, "
            f"its velocity limit allows {step['largest']:.4g} {unit} a frame"
        )


def run_retarget(args: argparse.Namespace) -> int:
    """`deik retarget` on one clip: check the flags, retarget (deik.retarget), write (all
    outputs or none), print the report's summary."""
    check_outputs(
        {"--out": args.out, "--view": args.view, "--json": args.json},
        {"--out": (".bvh", ".csv", ".json"), "--view": (".bvh",), "--json": (".json",)},
        (args.clip, args.to, args.map),
    )
    from deik.retargeting.api import retarget
    from deik.retargeting.outcome import frame_range

    options = retarget_options(args)
    clip = frame_range(read_bvh(args.clip, **reading_options(args)), options["frames"])
    # the bar counts the frames that meet their contacts, after the warm start and each repair pass
    with progress_bar(clip.n_frames, "deik retarget", "frame", show_progress(args)) as bar:
        result = retarget(clip, **{**options, "frames": None}, progress=frames_reporter(bar, "their contacts"))
    if isinstance(result.motion, Clip) and not args.out.lower().endswith(".bvh"):
        raise UsageError(f"--out {args.out!r}: a BVH target's motion is written as .bvh")
    # written before anything is printed: a reader that stops early (`| head`) loses no output
    write_outputs(result, {"out": args.out, "view": args.view, "json": args.json})
    summary = result.report["summary"]
    rows = [[label, unit, figure(summary[key])] for key, label, unit in SHOWN if key in summary]
    print(format_table(["measure", "unit", "value"], rows))
    print(
        f"{summary['frames_count']} frames of {os.path.basename(args.clip)} onto "
        f"{result.motion.skeleton.name} in {summary['wall_time_s']:.2f} s"
    )
    fates = ("the target holds the motion's nearest frame there", "retargeted blended across", "retargeted across")
    for line in cut_lines(result.report["cuts"], fates):
        print(line)
    noise = result.report["noise"]
    if noise["low_pass_s"] is not None:
        from deik.cleanup.noise import Noise
        from deik.cleanup.units import guess_unit

        print(Noise(noise["level"], noise["low_pass_s"]).describe(guess_unit(clip.skeleton), "the retarget"))
    print_velocity_steps(result)
    return 0

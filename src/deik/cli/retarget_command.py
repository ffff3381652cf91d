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

from deik.cli.arguments import (
    UsageError,
    add_free_translations,
    announce_compile,
    check_device,
    check_outputs,
    record_compiles,
)
from deik.console import add_output_flags, frames_reporter, progress_bar, show_progress
from deik.io.atomic import all_or_nothing, write_json_atomically
from deik.viz.text import format_table

FRAMES = re.compile(r"\s*(\d+)\s*:\s*(\d+)\s*")
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
    r.add_argument("--frames", metavar="START:STOP", help="retarget only these source frames (STOP exclusive)")
    r.add_argument("--seed", type=int, help="random seed of the contact repairs (same rig; a --map retarget has none)")
    r.add_argument("--device", choices=["cpu", "gpu"], help="where the contact repairs run (same rig; default cpu)")
    add_free_translations(r)
    add_output_flags(r)


def _scale(text: str | None) -> dict | None:
    """{joint: factor} of --scale J=F,...; UsageError naming the form."""
    if text is None:
        return None
    factors = {}
    for part in text.split(","):
        joint, equals, value = part.partition("=")
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
        raise UsageError(f"--frames {text!r}: use START:STOP (two whole numbers, STOP exclusive), e.g. 0:20")
    return int(match[1]), int(match[2])


def run_retarget(
    args: argparse.Namespace,
    on_frames: Callable[[int, int], None] | None = None,
    record: dict | None = None,
) -> int:
    """`deik retarget`: read, retarget, report, write (all outputs or none). For a library
    (deik.cli.folder_command): `on_frames(done, total)` follows the frames that meet their contacts,
    and `record` (a dict) receives the frames and the report's summary."""
    from deik.io.bvh import read_bvh, write_bvh
    from deik.io.motion import Clip
    from deik.io.trajectory import write_trajectory
    from deik.retargeting.api import retarget
    from deik.retargeting.outcome import frame_range

    check_outputs(
        {"--out": args.out, "--view": args.view, "--json": args.json},
        {"--out": (".bvh", ".csv", ".json"), "--view": (".bvh",), "--json": (".json",)},
        (args.clip, args.to, args.map),
    )
    check_device(args.device)
    settings = {k: getattr(args, k) for k in ("seed", "device") if getattr(args, k) is not None}
    clip = frame_range(read_bvh(args.clip, free_translations=args.free_translations), _frames(args.frames))
    compiling = announce_compile(args.device or "cpu", "float32", polish=False, clip=True)
    # the bar counts the frames that meet their contacts, after the warm start and each repair pass
    with progress_bar(clip.n_frames, "deik retarget", "frame", show_progress(args)) as bar:
        progress = frames_reporter(bar, "their contacts", on_frames)
        result = retarget(clip, args.to, scale=_scale(args.scale), joint_map=args.map, progress=progress, **settings)
    record_compiles(compiling)
    trajectory = not isinstance(result.motion, Clip)
    if not trajectory and not args.out.lower().endswith(".bvh"):
        raise UsageError(f"--out {args.out!r}: a BVH target's motion is written as .bvh")
    summary = result.report["summary"]
    if record is not None:
        record.update(frames=summary["frames_count"], metrics=dict(summary))
    rows = [[label, unit, f"{summary[key]:.4g}"] for key, label, unit in SHOWN if key in summary]
    print(format_table(["measure", "unit", "value"], rows))
    print(
        f"{summary['frames_count']} frames of {os.path.basename(args.clip)} onto "
        f"{result.motion.skeleton.name} in {summary['wall_time_s']:.2f} s"
    )
    with all_or_nothing():
        if args.out.lower().endswith(".bvh"):
            write_bvh(args.out, result.clip)
        else:
            write_trajectory(args.out, result.motion)
        if args.view:
            write_bvh(args.view, result.clip)
        if args.json:
            write_json_atomically(args.json, result.report, missing_as_null=True)
    return 0

"""`deik clip`: fix a whole BVH clip at once: plant the feet, keep balance, follow reach tracks,
stay close to the performance; write the fixed clip, a before/after table and a plot.

    deik clip walk.bvh --plant-feet auto --balance --out walk_fixed.bvh --report report.png
    deik clip jump.bvh --reach LeftElbow_end=0.5,1.4,0.2@40:60 --out jump_fixed.bvh
"""

from __future__ import annotations

import argparse
import logging
import os
from dataclasses import fields
from typing import TYPE_CHECKING

import numpy as np

from deik.cleanup.specs import CONTACT_FORMS, PLANT_FORMS
from deik.cleanup.units import METRES
from deik.cli.arguments import (
    UsageError,
    add_free_translations,
    add_up,
    check_device,
    check_outputs,
    checked_settings,
    number,
    up_of,
)
from deik.console import add_output_flags, frames_reporter, progress_bar, show_progress
from deik.io.atomic import all_or_nothing, write_json_atomically
from deik.io.bvh import read_bvh, write_bvh
from deik.viz.text import cut_lines, figure, format_table, frame_spans

if TYPE_CHECKING:  # deik.cleanup.clean loads when a clip is cleaned
    from deik.cleanup.clean import CleanedClip, CleanOptions

log = logging.getLogger(__name__)


def add_arguments(c: argparse.ArgumentParser) -> None:
    """The `deik clip` flags on subparser `c`."""
    c.add_argument("clip", metavar="IN.bvh", help="the clip to fix, or a folder of clips (every *.bvh in it)")
    c.add_argument(
        "--out", required=True, metavar="OUT.bvh", help="the fixed clip (same channel layout); a folder for a folder"
    )
    c.add_argument("--segments", metavar="FILE.json", help="segment masses (default: estimated from bone lengths)")
    add_free_translations(c)
    add_up(c)
    c.add_argument(
        "--limits",
        metavar="FILE.json",
        help="joint limits table (degrees / length units), e.g. from `deik limits`; every frame must lie within it",
    )
    c.add_argument(
        "--plant-feet",
        action="append",
        default=[],
        metavar="auto|none|SITE:A-B",
        help=f"contacts to plant: {PLANT_FORMS}; default auto",
    )
    c.add_argument(
        "--contact",
        action="append",
        default=[],
        metavar="auto|none|POINT[@A-B]",
        help=f"contacts anywhere on the body: {CONTACT_FORMS}; combines with --plant-feet",
    )
    c.add_argument(
        "--floor",
        default="auto",
        metavar="HEIGHT|auto|none",
        help="the floor every joint and end site stays at or above (length units along up); "
        "default auto: detected from the clip and reported",
    )
    c.add_argument(
        "--contact-height",
        type=number(0.0),
        metavar="LENGTH",
        help="detected contacts: height above the floor (feet) or above the point's resting height (--contact)",
    )
    c.add_argument(
        "--contact-speed", type=number(0.0, above=True), metavar="SPEED", help="auto contacts: speed (length units/s)"
    )
    c.add_argument(
        "--balance",
        action="store_true",
        help="keep the zero-moment point over the support of the contacts by moving the centre of mass along a "
        "smooth track; frames it cannot hold without jolts are skipped and listed",
    )
    c.add_argument(
        "--self-collision",
        type=number(0.0),
        metavar="MARGIN",
        help="keep the bone capsules MARGIN apart (length units, e.g. 0): DE repairs the frames that collide",
    )
    c.add_argument(
        "--reach",
        action="append",
        default=[],
        metavar="SITE=TRACK",
        help="SITE follows TRACK: track.csv, track.json or X,Y,Z@A:B (repeatable)",
    )
    c.add_argument(
        "--fidelity",
        type=number(0.0, 1.0),
        default=1.0,
        metavar="W",
        help="DE repairs: weight of staying near the original (0-1)",
    )
    c.add_argument(
        "--coherence",
        type=number(0.0, 1.0),
        default=0.5,
        metavar="W",
        help="DE repairs: weight of moving like the neighbours (0-1)",
    )
    c.add_argument(
        "--passes",
        type=int,
        help="most DE passes over frames the warm start leaves unmet (default 1, 3 with --balance or --self-collision)",
    )
    c.add_argument(
        "--time-limit",
        type=number(0.0, above=True),
        metavar="SECONDS",
        help="stop the DE passes after this wall time (the warm start always runs; default: none)",
    )
    c.add_argument("--population", type=int, help="DE population per frame (default 24, 48 with --balance)")
    c.add_argument(
        "--memory-limit",
        type=number(0.0, above=True),
        metavar="GIB",
        help="memory the DE passes may use, GiB (default: 80%% of this machine's)",
    )
    c.add_argument("--generations", type=int, help="most generations per pass (default 60, 300 with --balance)")
    c.add_argument("--seed", type=int, help="random seed (same seed, same clip)")
    c.add_argument("--device", choices=["cpu", "gpu"], help="where the kernels run (default cpu)")
    c.add_argument(
        "--overwrite",
        action="store_true",
        help="allow an output to replace an input (the clip, a limits table, a track)",
    )
    c.add_argument(
        "--report",
        metavar="report.png",
        help="plot of the errors over time, before and after, under the frame the fix changed most",
    )
    c.add_argument("--report-3d", action="store_true", help="draw --report's frame as one 3-D perspective view")
    c.add_argument("--json", metavar="report.json", help="the before/after metrics, goals and contacts as JSON")
    c.add_argument(
        "--units",
        choices=sorted(METRES),
        help="the clip's length unit in the reports (default: read from the body's size, and said; the fix needs none)",
    )
    add_output_flags(c)


def _shown(values, pick) -> str:
    """`pick` (np.nanmean or np.nanmax) of `values` to 4 digits, "-" when none is finite."""
    values = np.asarray(values, float)
    return f"{pick(values):.4g}" if np.isfinite(values).any() else "-"


def _print_tables(document: dict, quiet: bool) -> None:
    """The goal table (mean error per frame where the goal applies), its notes and the metrics."""
    rows = [
        [
            goal["label"],
            goal["unit"],
            _shown(goal["before"], np.nanmean),
            _shown(goal["after"], np.nanmean),
            _shown(goal["after"], np.nanmax),
            "-" if goal["tolerance"] is None else f"{goal['tolerance']:.4g}",
        ]
        for goal in document["goals"]
    ]
    print(format_table(["goal (error per frame)", "unit", "before mean", "after mean", "after max", "tolerance"], rows))
    if not quiet:
        for name, note in document["goal_notes"].items():
            print(f"  {name}: {note}")
    rows = [[v["label"], v["unit"], figure(v["before"]), figure(v["after"])] for v in document["metrics"].values()]
    print(format_table(["metric", "unit", "before", "after"], rows))


def _summary_notes(document: dict) -> list[str]:
    """Lines for the report picture: the standard clip metrics, the peaks against the capture's."""
    metrics = document["metrics"]
    keys = (
        "sliding_max_mm_per_frame",
        "foot_skating_ratio_share",
        "penetration_max_mm",
        "floating_max_mm",
        "zmp_outside_support_mean_mm",
        "jerk_mean_m_per_s3",
        "joint_angle_deviation_max_deg",
        "position_acceleration_max_m_per_s2",
    )
    lines = []
    for key in (k for k in keys if k in metrics):
        m = metrics[key]
        lines.append(
            f"{m['label']}: {figure(m['before'], '.3g')} before, {figure(m['after'], '.3g')} after ({m['unit']})"
        )
    ratios = ", ".join(
        f"{k.replace('_', ' ')} x{figure(v, '.2f')}" for k, v in document["dynamics"]["peak_ratios"].items()
    )
    return lines + [f"peaks against the capture's: {ratios}"]


def _outcome_lines(document: dict) -> list[str]:
    """Lines after the tables: the cuts in the capture, the floor, the frames missing a goal and those whose change was
    taken back, balance kept and skipped, peaks against the capture's (the worst point's)."""
    lines = cut_lines(
        document["cuts"],
        ("written back as captured", "blended across from the frames beside it", "fixed across as one motion"),
    )
    floor, unit = document["floor"], document["length_unit"]
    noise = document.get("noise") or {}
    if noise.get("low_pass_s") is not None:
        from deik.cleanup.noise import Noise

        lines.append(Noise(noise["level"], noise["low_pass_s"]).describe(unit))
    if floor is not None:
        from deik.cleanup.ground import FloorChoice

        choice = FloorChoice(floor["height"], floor["how"], floor["resting_contacts_height"])
        lines.append(choice.describe(unit) + ("" if floor["kept"] else "; not kept (--floor none)"))
    unmet = [n for n, met in enumerate(document["met_per_frame"]) if not met]
    if unmet:
        lines.append(
            f"frames not met (a goal missed, the body under the floor, a resting point sliding): {frame_spans(unmet)}"
        )
    for key, words in (("sunk_frames", "the body under the floor"), ("sliding_frames", "a resting point sliding")):
        if document.get(key):
            lines.append(f"  of these, {words}: {frame_spans(document[key])}")
    if document["calmed_frames"]:
        lines.append(
            f"frames whose fix was partly taken back so that no point accelerates past x"
            f"{document['dynamics']['peak_ratio_limit']:g} its own capture peak within "
            f"{document['dynamics']['peak_window_s']:g} s: {frame_spans(document['calmed_frames'])}"
        )
    balance = document["balance"]
    if balance is not None:
        kept, skipped = balance["balanced_frames"], balance["skipped_frames"]
        line = f"balance: ZMP over the support in {len(kept)} frames"
        if skipped:
            line += (
                f"; skipped in {len(skipped)} frames ({frame_spans(skipped)}): holding them would move the centre of"
                f" mass faster than {balance['acceleration_budget_m_per_s2']:.3g} m/s^2 of acceleration or further than"
                " the performance allows, or make the motion jolt"
            )
        lines.append(line)
    dynamics = document["dynamics"]
    ratios = ", ".join(f"{k.replace('_', ' ')} x{figure(v, '.3f')}" for k, v in dynamics["peak_ratios"].items())
    worst = dynamics["worst_point"]
    if worst is not None:
        ratios += (
            f"; worst point's acceleration {worst['point']} x{figure(worst['ratio'], '.3f')} its own peak within "
            f"{dynamics['peak_window_s']:g} s"
        )
    kept = "kept" if dynamics["peaks_kept"] else f"NOT kept (limit x{dynamics['peak_ratio_limit']:g})"
    lines.append(f"peaks against the capture's, {kept}: {ratios}")
    return lines


def _far_warning(document: dict, far_degrees: float) -> str | None:
    """The warning about joints turned more than `far_degrees` from the capture, or None."""
    far = document["joints_far_from_capture"]["joint_frames"]
    if not far:
        return None
    worst = max(far, key=lambda d: d["deviation_deg"])
    frames = sorted({d["frame"] for d in far})
    return (
        f"{len(far)} joint-frames in {len(frames)} frames (first {frames[0]}) turned more than "
        f"{far_degrees:g} degrees from the capture, worst {worst['joint']} at frame {worst['frame']} "
        f"({worst['deviation_deg']:.0f} degrees); --json lists them"
    )


def clean_options(args: argparse.Namespace) -> CleanOptions:
    """The CleanOptions of `deik clip`'s flags (each field is the flag of the same name)."""
    from deik.cleanup.clean import CleanOptions

    return CleanOptions(**{option.name: getattr(args, option.name) for option in fields(CleanOptions)})


def check_first(args: argparse.Namespace) -> None:
    """Mistakes in the flags found before any work, for one clip or a folder."""
    from deik.cleanup.fix import MAX_PASSES

    check_device(args.device)
    if args.passes is not None and not 0 <= args.passes <= MAX_PASSES:
        raise UsageError(f"--passes {args.passes}: give a whole number from 0 to {MAX_PASSES}")
    if args.report_3d and not args.report:
        raise UsageError("--report-3d sets how --report draws the clip: add --report report.png")
    if args.report:
        from deik.viz.plot import require_matplotlib

        require_matplotlib()


def print_outcome(cleaned: CleanedClip, quiet: bool) -> None:
    """What `deik clip` prints on stdout: the goal and metric tables, the reaches out of reach,
    the summary line, balance and the peaks; then the warning about joints far from the capture."""
    document, fix = cleaned.report, cleaned.fix
    n_frames = cleaned.original.n_frames
    _print_tables(document, quiet)
    for key, missed in cleaned.unreachable.items():
        print(
            f"{key}: out of reach in {len(missed['frames'])} frames ({frame_spans(missed['frames'])}), up to "
            f"{max(missed['distance_mm']):.4g} mm short; contacts and the floor come first"
        )
    passes = f"{fix.passes} DE pass{'' if fix.passes == 1 else 'es'}"
    print(
        f"{n_frames} frames, warm start + {passes}, {fix.wall_time:.2f} s on {fix.settings.device}, "
        f"{document['frames_met']}/{n_frames} frames meet every contact/floor/balance/reach/self-collision goal "
        "with nothing under the floor and no resting point sliding"
    )
    for line in _outcome_lines(document):
        print(line)
    from deik.cleanup.dynamics import FAR_DEGREES

    far = _far_warning(document, FAR_DEGREES)
    if far:
        log.warning(far)


def write_outputs(cleaned: CleanedClip, paths: dict[str, str | None], report_3d: bool = False) -> None:
    """Write the fixed clip to paths["out"] and, where given, the JSON record to paths["json"]
    and the report picture to paths["report"] (drawn in 3-D with `report_3d`): all or none."""
    document = cleaned.report
    with all_or_nothing():
        write_bvh(paths["out"], cleaned.clip)
        if paths.get("json"):
            write_json_atomically(paths["json"], document, missing_as_null=True)
        if paths.get("report"):
            from deik.viz.clip_report import plot_clip_report, pose_panel

            series = {f"{v['label']} ({v['unit']})": (v["before"], v["after"]) for v in document["per_frame"].values()}
            original = cleaned.original
            title = f"deik clip {os.path.basename(original.source)}"
            panel = pose_panel(original, cleaned.clip, document, "3d" if report_3d else "2d", cleaned.unit)
            plot_clip_report(series, paths["report"], original.frame_time, title, _summary_notes(document), panel)


def library_record(cleaned: CleanedClip) -> dict:
    """What a folder run keeps of one clip (its sidecar record and summary row): frames,
    frames meeting their goals and the metrics after the fix."""
    document = cleaned.report
    metrics = {key: value["after"] for key, value in document["metrics"].items()}
    return {"frames": cleaned.original.n_frames, "frames_met": document["frames_met"], "metrics": metrics}


def run_clip(args: argparse.Namespace) -> int:
    """`deik clip` on one clip: check the flags, clean it (deik.clean_clip), write (atomically;
    nothing is written on an error), print."""
    outputs = (
        {"--out": args.out, "--report": args.report, "--json": args.json},
        {"--out": (".bvh",), "--report": (".png",), "--json": (".json",)},
        (args.clip, args.segments, args.limits),
        args.overwrite,
    )
    check_outputs(*outputs)
    from deik.cleanup.clean import plan_clean

    check_first(args)
    options = clean_options(args)
    given = options.settings()
    checked_settings(given, given)  # every setting there came from a flag
    clip = read_bvh(args.clip, segments=args.segments, free_translations=args.free_translations, up=up_of(args))
    plan = plan_clean(clip, options)
    check_outputs(*outputs)  # the reach tracks it read are inputs too
    with progress_bar(plan.clip.n_frames, "deik clip", "frame", show_progress(args)) as bar:
        cleaned = plan.run(progress=frames_reporter(bar, "every goal"))
    # written before anything is printed: a reader that stops early (`| head`) loses no output
    write_outputs(cleaned, {"out": args.out, "json": args.json, "report": args.report}, args.report_3d)
    print_outcome(cleaned, args.quiet)
    return 0

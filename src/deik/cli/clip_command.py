"""`deik clip`: fix a whole BVH clip at once: plant the feet, keep balance, follow reach tracks,
stay close to the performance; write the fixed clip, a before/after table and a plot.

    deik clip walk.bvh --plant-feet auto --balance --out walk_fixed.bvh --report report.png
    deik clip jump.bvh --reach LeftElbow_end=0.5,1.4,0.2@40:60 --out jump_fixed.bvh
"""

from __future__ import annotations

import argparse
import logging
import os
from collections.abc import Callable

import numpy as np

from deik.cleanup.units import METRES
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
from deik.suggest import did_you_mean
from deik.viz.text import format_table

PLANT_FORMS = "auto, none, or SITE:A-B[,A-B...] (repeatable)"
CONTACT_FORMS = (
    "auto (every joint and end site, detected), none, or POINT[@A-B[,A-B...]] (repeatable): POINT a "
    "joint, an end site or a bone PARENT-CHILD, detected without @, in contact over frames A-B "
    "(inclusive) with it"
)
log = logging.getLogger(__name__)


def add_arguments(c: argparse.ArgumentParser) -> None:
    """The `deik clip` flags on subparser `c`."""
    c.add_argument("clip", metavar="IN.bvh", help="the clip to fix, or a folder of clips (every *.bvh in it)")
    c.add_argument(
        "--out", required=True, metavar="OUT.bvh", help="the fixed clip (same channel layout); a folder for a folder"
    )
    c.add_argument("--segments", metavar="FILE.json", help="segment masses (default: estimated from bone lengths)")
    add_free_translations(c)
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
        type=float,
        metavar="LENGTH",
        help="detected contacts: height above the floor (feet) or above the point's resting height (--contact)",
    )
    c.add_argument("--contact-speed", type=float, metavar="SPEED", help="auto contacts: speed (length units/s)")
    c.add_argument(
        "--balance",
        action="store_true",
        help="keep the zero-moment point over the support of the contacts by moving the centre of mass along a "
        "smooth track; frames it cannot hold without jolts are skipped and listed",
    )
    c.add_argument(
        "--self-collision",
        type=float,
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
        "--fidelity", type=float, default=1.0, metavar="W", help="DE repairs: weight of staying near the original (0-1)"
    )
    c.add_argument(
        "--coherence",
        type=float,
        default=0.5,
        metavar="W",
        help="DE repairs: weight of moving like the neighbours (0-1)",
    )
    c.add_argument(
        "--passes",
        type=int,
        help="most DE passes over frames the warm start leaves unmet (default 1, 3 with --balance or --self-collision)",
    )
    c.add_argument("--population", type=int, help="DE population per frame (default 24, 48 with --balance)")
    c.add_argument("--generations", type=int, help="most generations per pass (default 60, 300 with --balance)")
    c.add_argument("--seed", type=int, help="random seed (same seed, same clip)")
    c.add_argument("--device", choices=["cpu", "gpu"], help="where the kernels run (default cpu)")
    c.add_argument("--overwrite", action="store_true", help="allow --out to replace the input clip")
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


def _check_site(clip, site: str, flag: str) -> None:
    """UsageError naming `flag`, the unknown `site` and the names to choose from."""
    sk = clip.skeleton
    if site not in sk.frame_names:
        raise UsageError(
            f"{flag}: no joint or site {site!r} in {os.path.basename(clip.source) or 'the clip'}"
            f"{did_you_mean(site, sk.frame_names)}; its sites are {', '.join(sk.site_names)} "
            f"and its joints {', '.join(sk.joint_names)}"
        )


def _frames(form: str, spans: str, n_frames: int, flag: str) -> list[tuple[int, int]]:
    """(start, stop) ranges, stop exclusive, of A-B[,A-B...] (inclusive), else UsageError."""
    out = []
    for span in spans.split(","):
        start, _, stop = span.partition("-")
        if not (start.strip().isdigit() and stop.strip().isdigit()):
            raise UsageError(f"{flag} {form!r}: frame range {span!r} must read A-B (inclusive)")
        start, stop = int(start), int(stop)
        if not start <= stop < n_frames:
            raise UsageError(
                f"{flag} {form!r}: frames {start}-{stop} are outside the clip or "
                f"reversed; valid frames: 0..{n_frames - 1} (A-B, both inclusive)"
            )
        out.append((start, stop + 1))
    return out


def _feet(args, motion, body, floor: float, paths):
    """The --plant-feet contacts (None for none; auto by default): each foot's heel and toe."""
    from deik.cleanup.ground import detect_resting, given_contacts

    forms = args.plant_feet or ["auto"]
    if forms == ["none"]:
        return None
    if "auto" in forms:
        if len(forms) > 1:
            raise UsageError(f"--plant-feet auto cannot be combined with other --plant-feet values; use {PLANT_FORMS}")
        points = tuple(name for foot in body.feet for name in (foot.heel, foot.toe))
        if not points:
            return None
        detect = dict(band=args.contact_height, speed=args.contact_speed, paths=paths)
        return detect_resting(motion, body, floor, points, idle=False, **detect)
    masks = {}
    for form in forms:
        site, _, spans = form.partition(":")
        if not site or not spans:
            raise UsageError(f"--plant-feet {form!r}: use {PLANT_FORMS}")
        _check_site(motion, site, f"--plant-feet {form!r}")
        mask = masks.setdefault(site, np.zeros(motion.n_frames, bool))
        for start, stop in _frames(form, spans, motion.n_frames, "--plant-feet"):
            mask[start:stop] = True
    return given_contacts(motion, body, floor, masks)


def _point(clip, point: str, form: str):
    """(parent, child) of a bone PARENT-CHILD, or (point,) of a joint or site; else UsageError."""
    from deik.cleanup.body_contacts import bone_ends

    if point in clip.skeleton.frame_names:
        return (point,)
    ends = bone_ends(clip.skeleton, point)
    if ends is None:
        _check_site(clip, point, f"--contact {form!r} (a joint, an end site or a bone PARENT-CHILD)")
    return ends


def _body(args, motion, body, floor: float, paths) -> list:
    """The --contact contacts, one Contacts per form (auto by default: every point of the body
    that rests, the feet's heels and toes aside, which --plant-feet gives)."""
    from deik.cleanup.body_contacts import bone_contacts
    from deik.cleanup.ground import detect_resting, given_contacts

    forms = args.contact or ["auto"]
    if forms == ["none"]:
        return []
    detect = dict(band=args.contact_height, speed=args.contact_speed, paths=paths)
    feet = {name for foot in body.feet for name in (foot.heel, foot.toe)}
    parts = []
    for form in forms:
        if form in ("auto", "none"):
            if form == "none":
                raise UsageError(f"--contact none cannot be combined with other --contact values; use {CONTACT_FORMS}")
            points = tuple(name for name in body.contact_points() if name not in feet)
            parts.append(detect_resting(motion, body, floor, points, idle=False, **detect))
            continue
        point, at, spans = form.partition("@")
        ends = _point(motion, point.strip(), form)
        if not at:
            parts.append(detect_resting(motion, body, floor, ends, **detect))
            continue
        frames = np.zeros(motion.n_frames, bool)
        for start, stop in _frames(form, spans, motion.n_frames, "--contact"):
            frames[start:stop] = True
        masks = bone_contacts(motion, *ends, frames) if len(ends) == 2 else {ends[0]: frames}
        parts.append(given_contacts(motion, body, floor, masks))
    return parts


def _floor(args, motion, body, paths):
    """(the floor, a deik.cleanup.ground.FloorChoice; whether it is kept as a goal): --floor auto,
    none or a number."""
    from deik.cleanup.ground import FloorChoice, detect_floor

    if args.floor in ("auto", "none"):
        return detect_floor(motion, body, paths), args.floor == "auto"
    try:
        height = float(args.floor)
    except ValueError:
        height = float("nan")
    if not np.isfinite(height):
        raise UsageError(f"--floor {args.floor!r}: use a height (a finite number in length units), auto or none")
    return FloorChoice(height, "given"), True


def _contacts(args, motion, body, floor: float, paths):
    """Every contact the flags ask for, merged on the floor at `floor`; None for none."""
    from deik.cleanup.body_contacts import merge_contacts

    parts = [part for part in [_feet(args, motion, body, floor, paths), *_body(args, motion, body, floor, paths)]]
    parts = [part for part in parts if part is not None and part.sites]
    return merge_contacts(parts, floor) if parts else None


def _reaches(args, clip):
    from deik.cleanup.clip_goals import Reach
    from deik.cleanup.tracks import parse_reach_spec

    out = []
    for spec in args.reach:
        site, mask, targets = parse_reach_spec(spec, clip.n_frames)
        _check_site(clip, site, f"--reach {spec!r}")
        out.append(Reach(site, mask, targets))
    return tuple(out)


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
    rows = [[v["label"], v["unit"], f"{v['before']:.4g}", f"{v['after']:.4g}"] for v in document["metrics"].values()]
    print(format_table(["metric", "unit", "before", "after"], rows))


def _spans(frames: list[int]) -> str:
    """Frames as inclusive ranges: [3, 4, 5, 9] -> "3-5, 9"."""
    runs, start = [], frames[0]
    for a, b in zip(frames, frames[1:] + [None]):
        if b != a + 1:
            runs.append(f"{start}-{a}" if a > start else f"{a}")
            start = b
    return ", ".join(runs)


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
        lines.append(f"{m['label']}: {m['before']:.3g} before, {m['after']:.3g} after ({m['unit']})")
    ratios = ", ".join(f"{k.replace('_', ' ')} x{v:.2f}" for k, v in document["dynamics"]["peak_ratios"].items())
    return lines + [f"peaks against the capture's: {ratios}"]


def _outcome_lines(document: dict) -> list[str]:
    """Lines after the tables: the floor, the frames missing a goal and those whose change was
    taken back, balance kept and skipped, peaks against the capture's (the worst point's)."""
    lines = []
    floor, unit = document["floor"], document["length_unit"]
    if floor is not None:
        from deik.cleanup.ground import FloorChoice

        choice = FloorChoice(floor["height"], floor["how"], floor["resting_contacts_height"])
        lines.append(choice.describe(unit) + ("" if floor["kept"] else "; not kept (--floor none)"))
    unmet = [n for n, met in enumerate(document["met_per_frame"]) if not met]
    if unmet:
        lines.append(f"frames missing a contact/floor/balance/reach goal: {_spans(unmet)}")
    if document["calmed_frames"]:
        lines.append(
            f"frames whose fix was partly taken back so that no point accelerates past x"
            f"{document['dynamics']['peak_ratio_limit']:g} its capture peak: {_spans(document['calmed_frames'])}"
        )
    balance = document["balance"]
    if balance is not None:
        kept, skipped = balance["balanced_frames"], balance["skipped_frames"]
        line = f"balance: ZMP over the support in {len(kept)} frames"
        if skipped:
            line += (
                f"; skipped in {len(skipped)} frames ({_spans(skipped)}): holding them would move the centre of mass"
                f" faster than {balance['acceleration_budget_m_per_s2']:.3g} m/s^2 of acceleration or further than"
                " the performance allows, or make the motion jolt"
            )
        lines.append(line)
    dynamics = document["dynamics"]
    ratios = ", ".join(f"{k.replace('_', ' ')} x{v:.3f}" for k, v in dynamics["peak_ratios"].items())
    worst = dynamics["worst_point"]
    if worst is not None:
        ratios += f"; worst point's acceleration {worst['point']} x{worst['ratio']:.3f}"
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


def run_clip(
    args: argparse.Namespace,
    on_frames: Callable[[int, int], None] | None = None,
    record: dict | None = None,
) -> int:
    """`deik clip`: read, fix, report, write (atomically; nothing is written on an error).
    For a library (deik.cli.folder_command): `on_frames(done, total)` follows the frames that meet
    their goals, and `record` (a dict) receives the clip's frames and summary metrics."""
    from deik.cleanup.body import body_of, on_body
    from deik.cleanup.clip_goals import GRAVITY, ClipGoals
    from deik.cleanup.document import clip_document
    from deik.cleanup.dynamics import FAR_DEGREES
    from deik.cleanup.fix import fix_clip
    from deik.cleanup.ground import body_paths
    from deik.cleanup.units import unit_of_span
    from deik.io.bvh import read_bvh, write_bvh

    check_outputs(
        {"--out": args.out, "--report": args.report, "--json": args.json},
        {"--out": (".bvh",), "--report": (".png",), "--json": (".json",)},
        (args.clip, args.segments, args.limits),
        args.overwrite,
    )
    check_device(args.device)
    if args.report_3d and not args.report:
        raise UsageError("--report-3d sets how --report draws the clip: add --report report.png")
    if args.report:
        from deik.viz.plot import require_matplotlib

        require_matplotlib()
    clip = read_bvh(args.clip, segments=args.segments, free_translations=args.free_translations)
    if args.limits:
        from deik.io.limits import clip_within, read_limits, with_limits

        clip = clip_within(
            clip, with_limits(clip.skeleton, read_limits(args.limits, clip.skeleton)), f"--limits {args.limits}"
        )
    body = body_of(clip)
    motion = on_body(clip, body)
    paths = body_paths(motion, body)
    floor, keep_floor = _floor(args, motion, body, paths)
    contacts = _contacts(args, motion, body, floor.height, paths)
    reach = _reaches(args, clip)
    unit = args.units or unit_of_span(body.span)
    goals = ClipGoals(
        contacts,
        reach,
        args.balance,
        args.fidelity,
        args.coherence,
        self_collision=args.self_collision,
        floor=floor.height if keep_floor else None,
        gravity=GRAVITY / METRES[unit],
    )
    if not args.units:
        log.info(
            f"reports in {unit}: the body spans {body.span:.4g} length units from end to end, a person's size in "
            f"{unit}; --units sets them (the fix itself needs no unit)"
        )
    if contacts is not None:
        described = contacts.describe().replace("\n", "\n  ")
        log.info("contacts" + (" (detected)" if contacts.detected else "") + ":\n  " + described)
    overrides = {
        k: getattr(args, k) for k in ("population", "generations", "seed", "device") if getattr(args, k) is not None
    }
    compiling = announce_compile(args.device or "cpu", "float32", polish=False, clip=True)
    with progress_bar(clip.n_frames, "deik clip", "frame", show_progress(args)) as bar:
        progress = frames_reporter(bar, "every goal", on_frames)
        fix = fix_clip(clip, goals, passes=args.passes, progress=progress, body=body, **overrides)
    record_compiles(compiling)
    reach_tracks = [(r.site, r.mask, r.targets) for r in reach]
    floor_record = floor.record() | {"kept": keep_floor}
    document = clip_document(fix, contacts, reach_tracks, unit, METRES[unit], FAR_DEGREES, floor_record)
    if record is not None:
        metrics = {key: value["after"] for key, value in document["metrics"].items()}
        record.update(frames=clip.n_frames, frames_met=document["frames_met"], metrics=metrics)
    _print_tables(document, args.quiet)
    for key, missed in document["reach_unreached"].items():
        if missed["frames"]:
            print(
                f"{key}: out of reach in {len(missed['frames'])} frames ({_spans(missed['frames'])}), up to "
                f"{max(missed['distance_mm']):.4g} mm short; contacts and the floor come first"
            )
    passes = f"{fix.passes} DE pass{'' if fix.passes == 1 else 'es'}"
    print(
        f"{clip.n_frames} frames, warm start + {passes}, {fix.wall_time:.2f} s on {fix.settings.device}, "
        f"{int(fix.met.sum())}/{clip.n_frames} frames meet every contact/floor/balance/reach/self-collision goal"
    )
    for line in _outcome_lines(document):
        print(line)
    far = _far_warning(document, FAR_DEGREES)
    if far:
        log.warning(far)
    with all_or_nothing():
        write_bvh(args.out, fix.clip)
        if args.json:
            write_json_atomically(args.json, document, missing_as_null=True)
        if args.report:
            from deik.viz.clip_report import plot_clip_report, pose_panel

            series = {f"{v['label']} ({v['unit']})": (v["before"], v["after"]) for v in document["per_frame"].values()}
            title = f"deik clip {os.path.basename(args.clip)}"
            panel = pose_panel(fix.original, fix.clip, document, "3d" if args.report_3d else "2d", unit)
            plot_clip_report(series, args.report, clip.frame_time, title, _summary_notes(document), panel)
    return 0

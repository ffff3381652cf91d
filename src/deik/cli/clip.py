"""`deik clip`: fix a whole BVH clip at once: plant the feet, keep balance, follow reach tracks,
stay close to the performance; write the fixed clip, a before/after table and a plot.

    deik clip walk.bvh --plant-feet auto --balance --out walk_fixed.bvh --report report.png
    deik clip jump.bvh --reach LeftElbow_end=0.5,1.4,0.2@40:60 --out jump_fixed.bvh
"""

from __future__ import annotations

import os
import sys

import numpy as np

from deik.cli.common import UsageError, announce_compile, check_device, check_outputs
from deik.clips.units import METRES
from deik.io.atomic import all_or_nothing, write_json_atomically
from deik.suggest import did_you_mean
from deik.viz.text import format_table

PLANT_FORMS = "auto, none, or SITE:A-B[,A-B...] (repeatable)"
FAR_DEGREES = 30.0  # a joint turned further than this from the capture is reported, frame by frame


def add_arguments(c) -> None:
    """The `deik clip` flags on subparser `c`."""
    c.add_argument("clip", metavar="IN.bvh", help="the clip to fix")
    c.add_argument("--out", required=True, metavar="OUT.bvh", help="the fixed clip (same channel layout)")
    c.add_argument("--segments", metavar="FILE.json", help="segment masses (default: estimated from bone lengths)")
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
    c.add_argument("--contact-height", type=float, metavar="LENGTH", help="auto contacts: height above the floor")
    c.add_argument("--contact-speed", type=float, metavar="SPEED", help="auto contacts: speed (length units/s)")
    c.add_argument("--balance", action="store_true", help="keep the centre of mass over the support polygon")
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
    c.add_argument("--report", metavar="report.png", help="plot of the errors over time, before and after")
    c.add_argument("--json", metavar="report.json", help="the before/after metrics, goals and contacts as JSON")
    c.add_argument(
        "--units",
        choices=sorted(METRES),
        help="the clip's length unit (default: guessed from the skeleton's size, and said)",
    )
    c.add_argument("--quiet", action="store_true", help="no progress bar and no notes on stderr (errors still print)")


def _check_site(clip, site: str, flag: str) -> None:
    """UsageError naming `flag`, the unknown `site` and the names to choose from."""
    sk = clip.skeleton
    if site not in sk.frame_names:
        raise UsageError(
            f"{flag}: no joint or site {site!r} in {os.path.basename(clip.source) or 'the clip'}"
            f"{did_you_mean(site, sk.frame_names)}; its sites are {', '.join(sk.site_names)} "
            f"and its joints {', '.join(sk.joint_names)}"
        )


def _contacts(args, clip):
    from deik.clips.contacts import contacts_from_ranges, detect_contacts, foot_sites

    forms = args.plant_feet or ["auto"]
    if forms == ["none"]:
        return None
    if "auto" in forms:
        if len(forms) > 1:
            raise UsageError(f"--plant-feet auto cannot be combined with other --plant-feet values; use {PLANT_FORMS}")
        return detect_contacts(clip, foot_sites(clip.skeleton), height=args.contact_height, speed=args.contact_speed)
    ranges = {}
    last = clip.n_frames - 1
    for form in forms:
        site, _, spans = form.partition(":")
        if not site or not spans:
            raise UsageError(f"--plant-feet {form!r}: use {PLANT_FORMS}")
        _check_site(clip, site, f"--plant-feet {form!r}")
        for span in spans.split(","):
            start, _, stop = span.partition("-")
            if not (start.strip().isdigit() and stop.strip().isdigit()):
                raise UsageError(f"--plant-feet {form!r}: frame range {span!r} must read A-B (inclusive)")
            start, stop = int(start), int(stop)
            if not start <= stop <= last:
                raise UsageError(
                    f"--plant-feet {form!r}: frames {start}-{stop} are outside the clip or "
                    f"reversed; valid frames: 0..{last} (A-B, both inclusive)"
                )
            ranges.setdefault(site, []).append((start, stop + 1))
    return contacts_from_ranges(clip, ranges)


def _reaches(args, clip):
    from deik.clips.problem import Reach
    from deik.clips.tracks import parse_reach_spec

    out = []
    for spec in args.reach:
        site, mask, targets = parse_reach_spec(spec, clip.n_frames)
        _check_site(clip, site, f"--reach {spec!r}")
        out.append(Reach(site, mask, targets))
    return tuple(out)


def _note(args, text: str) -> None:
    """An informational line on stderr, unless --quiet."""
    if not args.quiet:
        print(text, file=sys.stderr)


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


def _summary_notes(metrics: dict) -> list[str]:
    """Lines for the report picture: the summary numbers that are no per-frame series."""
    keys = ("foot_skating_ratio_share", "penetration_max_mm", "jerk_mean_m_per_s3", "joint_angle_deviation_max_deg")
    lines = []
    for key in (k for k in keys if k in metrics):
        m = metrics[key]
        lines.append(f"{m['label']}: {m['before']:.3g} before, {m['after']:.3g} after ({m['unit']})")
    return lines


def run_clip(args) -> int:
    """`deik clip`: read, fix, report, write (atomically; nothing is written on an error)."""
    from tqdm import tqdm

    from deik.clips.document import clip_document
    from deik.clips.problem import ClipGoals
    from deik.clips.solver import fix_clip
    from deik.clips.units import guess_unit, span
    from deik.io.bvh import read_bvh, write_bvh

    check_outputs(
        {"--out": args.out, "--report": args.report, "--json": args.json},
        {"--out": (".bvh",), "--report": (".png",), "--json": (".json",)},
        (args.clip, args.segments, args.limits),
        args.overwrite,
    )
    check_device(args.device)
    if args.report:
        from deik.viz.plot import require_matplotlib

        require_matplotlib()
    clip = read_bvh(args.clip, segments=args.segments)
    if args.limits:
        from deik.io.limits import clip_within, read_limits, with_limits

        clip = clip_within(
            clip, with_limits(clip.skeleton, read_limits(args.limits, clip.skeleton)), f"--limits {args.limits}"
        )
    contacts = _contacts(args, clip)
    reach = _reaches(args, clip)
    goals = ClipGoals(contacts, reach, args.balance, args.fidelity, args.coherence, self_collision=args.self_collision)
    unit = args.units or guess_unit(clip.skeleton)
    if not args.units:
        _note(args, f"lengths in {unit} (guessed: the skeleton spans {span(clip.skeleton):.3g}); --units sets them")
    if contacts is not None:
        described = contacts.describe().replace("\n", "\n  ")
        _note(args, "contacts" + (" (detected)" if contacts.detected else "") + ":\n  " + described)
    overrides = {
        k: getattr(args, k) for k in ("population", "generations", "seed", "device") if getattr(args, k) is not None
    }
    if not args.quiet:
        announce_compile(args.device or "cpu", "float32")
    with tqdm(total=clip.n_frames, desc="deik clip", unit="frame", file=sys.stderr, disable=args.quiet) as bar:

        def progress(met: int, stage: str) -> None:
            bar.set_postfix_str(f"{stage}: frames meeting every goal", refresh=False)
            bar.update(met - bar.n)

        fix = fix_clip(clip, goals, passes=args.passes, progress=progress, **overrides)
    reach_tracks = [(r.site, r.mask, r.targets) for r in reach]
    document = clip_document(fix, contacts, reach_tracks, unit, METRES[unit], FAR_DEGREES)
    _print_tables(document, args.quiet)
    passes = f"{fix.passes} DE pass{'' if fix.passes == 1 else 'es'}"
    print(
        f"{clip.n_frames} frames, warm start + {passes}, {fix.wall_time:.2f} s on {fix.settings.device}, "
        f"{int(fix.met.sum())}/{clip.n_frames} frames meet every contact/reach/balance/self-collision goal"
    )
    far = document["joints_far_from_capture"]["joint_frames"]
    if far:
        worst = max(far, key=lambda d: d["deviation_deg"])
        frames = sorted({d["frame"] for d in far})
        print(
            f"warning: {len(far)} joint-frames in {len(frames)} frames (first {frames[0]}) turned more than "
            f"{FAR_DEGREES:g} degrees from the capture, worst {worst['joint']} at frame {worst['frame']} "
            f"({worst['deviation_deg']:.0f} degrees); --json lists them"
        )
    with all_or_nothing():
        write_bvh(args.out, fix.clip)
        if args.json:
            write_json_atomically(args.json, document, missing_as_null=True)
        if args.report:
            from deik.viz.clip_report import plot_clip_report

            series = {f"{v['label']} ({v['unit']})": (v["before"], v["after"]) for v in document["per_frame"].values()}
            title = f"deik clip {os.path.basename(args.clip)}"
            plot_clip_report(series, args.report, clip.frame_time, title, _summary_notes(document["metrics"]))
    return 0

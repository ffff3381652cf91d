"""`deik clip DIR --out OUTDIR ...` and `deik retarget DIR ... --out OUTDIR`: every *.bvh clip of
a folder through the one-clip command, resumable, on local workers or Ray (deik.library).

    deik clip clips/ --out fixed/ --plant-feet auto --json reports/
    deik retarget clips/ --map map.toml --to human.urdf --out robot/ --view robot_views/ --workers 2
    deik retarget clips/ --map map.toml --to humanoid --out humanoid/ --executor ray --address auto

With a folder, the flags that name one output file name a folder instead, each created when
its parent exists: each clip NAME.bvh gives OUTDIR/NAME.bvh (a URDF target's trajectory:
NAME.csv), --json DIR/NAME.json, --report DIR/NAME.png, --view DIR/NAME.bvh, and its record
OUTDIR/.NAME.bvh.deik.json (hidden; deik.library.jobs), whose presence with the same settings and input
makes a rerun skip the clip. Every other flag applies to every clip.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import signal
import sys
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

from deik.cli import clip_command as cli_clip
from deik.cli import retarget_command as cli_retarget
from deik.cli.arguments import USER_ERRORS, UsageError, up_of
from deik.errors import InputError, error_line
from deik.io.bvh import read_bvh
from deik.io.files import check_not_input, command_inputs
from deik.viz.text import figure

if TYPE_CHECKING:  # deik.library loads when a folder is run
    from deik.library.jobs import Job

FOLDER_FLAGS = ("workers", "executor", "address")
OUTPUT_FLAGS = {"out": "--out", "json": "--json", "report": "--report", "view": "--view"}
FAILED = 1  # exit status when a clip failed
INTERRUPTED = 130


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The folder flags of `deik clip` and `deik retarget`, and a note on folders in --help."""
    parser.epilog = (
        "IN may be a folder: every *.bvh in it is done (a rerun skips the clips done before with the same "
        "settings and input), and --out, --json, --report and --view then name folders (docs/retarget.md, "
        '"Whole libraries").'
    )
    parser.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="with a folder: clips at once (local processes, default one per core, one with --device gpu, "
        "the cores shared out as Numba threads; with Ray, tasks in flight, default all)",
    )
    parser.add_argument(
        "--executor",
        choices=["local", "ray"],
        help='with a folder: where the clips run (default local; ray needs pip install "deik[ray]")',
    )
    parser.add_argument(
        "--address",
        metavar="ADDR",
        help="with --executor ray: the cluster (auto, ray://HOST:PORT; default: a Ray started here)",
    )


def run(args: argparse.Namespace) -> int:
    """`deik clip` or `deik retarget` on one clip or, for a folder, on every clip in it."""
    if os.path.isdir(args.clip):
        return run_folder(args)
    given = [f"--{flag}" for flag in FOLDER_FLAGS if getattr(args, flag) is not None]
    if given:
        raise UsageError(f"{', '.join(given)}: for a folder of clips; {args.clip!r} is one clip")
    return {"clip": cli_clip.run_clip, "retarget": cli_retarget.run_retarget}[args.command](args)


def do_clip(payload: dict, progress: Callable[[int, int], None]) -> dict:
    """The library task (runs in a worker): clean (deik.clean_clip) or retarget (deik.retarget)
    the clip payload["source"] with payload["options"], write payload["outputs"], and return
    its record (frames, metrics). JobFailed with the one-line reason for a mistake in the input
    or a bug."""
    from deik.library.jobs import JobFailed

    try:
        overwrite = payload["overwrite"]  # None: the command has no --overwrite
        with command_inputs(protect=not overwrite, overwrite_flag=overwrite is not None):
            if payload["command"] == "clip":
                return _clean_one(payload, progress)
            result = cli_retarget.retarget_file(payload["source"], payload["options"], payload["reading"], progress)
            cli_retarget.write_outputs(result, payload["outputs"])
            return cli_retarget.library_record(result)
    except USER_ERRORS as error:
        raise JobFailed(error_line(error)) from None
    except Exception as error:  # noqa: BLE001 - a bug: this clip fails, the others go on
        raise JobFailed(
            f"internal error: {type(error).__name__}: {error_line(error)} (a bug in deik: rerun this clip alone "
            "with DEIK_DEBUG=1 for the traceback)"
        ) from None


def _clean_one(payload: dict, progress: Callable[[int, int], None]) -> dict:
    """deik.clean_clip of one clip of a folder, its outputs written; its library record."""
    from deik.cleanup.clean import clean_clip

    reading = {key: payload[key] for key in ("segments", "free_translations", "up")}
    clip = read_bvh(payload["source"], **reading)
    cleaned = clean_clip(clip, payload["options"], progress=lambda met, stage: progress(met, clip.n_frames))
    cli_clip.write_outputs(cleaned, payload["outputs"], payload["report_3d"])
    return cli_clip.library_record(cleaned)


def _options(args) -> tuple[dict, dict, dict]:
    """(the options every clip's job takes, the settings that shape the outputs (JSON-able, for
    the fingerprint), {flag: file} of the files whose bytes shape them). UsageError for a named
    file that is missing."""
    from deik.cleanup.tracks import track_file

    if args.command == "clip":
        options = cli_clip.clean_options(args)
        reading = {"segments": args.segments, "free_translations": args.free_translations, "up": up_of(args)}
        common = {"options": options, "report_3d": args.report_3d, **reading}
        settings = {"report_3d": args.report_3d, **reading, **dataclasses.asdict(options)}
        files = {"--segments": args.segments, "--limits": options.limits}
        tracks = [track_file(spec) for spec in options.reach]
        files |= {f"--reach {k}": track for k, track in enumerate(tracks) if track is not None}
    else:
        options, reading = cli_retarget.retarget_options(args), cli_retarget.reading_options(args)
        common, settings = {"options": options, "reading": reading}, {**options, **reading}
        files = {"--map": args.map, "--to": args.to if os.path.splitext(args.to or "")[1] else None}  # humanoid: none
    files = {flag: path for flag, path in files.items() if path is not None}
    for flag, path in files.items():
        if not os.path.lexists(path):
            raise UsageError(f"{flag.split()[0]} {path!r}: no such file")
    return common, settings, files


def _outputs(args, stem: str, folders: dict) -> dict:
    """{flag: path} of the files one clip `stem` writes."""
    suffix = {"json": ".json", "report": ".png", "view": ".bvh"}
    robot = args.command == "retarget" and (args.to or "").lower().endswith(".urdf")
    suffix["out"] = ".csv" if robot else ".bvh"
    paths = {flag: os.path.join(folder, stem + suffix[flag]) for flag, folder in folders.items()}
    for flag, path in paths.items():
        for other, same in paths.items():
            if other > flag and same == path:
                raise UsageError(
                    f"{OUTPUT_FLAGS[flag]} and {OUTPUT_FLAGS[other]} would both write {os.path.basename(path)} "
                    f"in {os.path.dirname(path)}; give them different folders"
                )
    return paths


def _check_first(args) -> None:
    """Mistakes every clip would fail on, found before any work."""
    if args.command == "clip":
        cli_clip.check_first(args)
    else:
        from deik.retargeting.maps import read_map

        cli_retarget.retarget_options(args)  # --scale and --frames
        if args.map:
            read_map(args.map)
    if args.address is not None and args.executor != "ray":
        raise UsageError("--address names a Ray cluster: give it with --executor ray")
    if args.address not in (None, "local"):
        from deik.library.ray_cluster import check_address

        check_address(args.address)
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers {args.workers}: use a whole number >= 1 (default one per core)")


def library_jobs(args: argparse.Namespace) -> tuple[list[Job], list[str]]:
    """(one deik.library.jobs.Job per clip of the folder `args.clip`, names of the entries skipped)."""
    from deik.library.folder import find_clips, output_folder
    from deik.library.jobs import Job, fingerprint, sidecar_path

    clips, others = find_clips(args.clip)
    given = [flag for flag in OUTPUT_FLAGS if getattr(args, flag, None) is not None]
    folders = {flag: output_folder(OUTPUT_FLAGS[flag], getattr(args, flag), args.clip, create=False) for flag in given}
    common, settings, files = _options(args)
    jobs = []
    for path in clips:
        name = os.path.basename(path)
        outputs = _outputs(args, os.path.splitext(name)[0], folders)
        key = fingerprint(args.command, settings, path, files, outputs.values())  # reads every input
        for flag, output in outputs.items():
            try:
                check_not_input(output)
            except InputError as error:
                raise UsageError(f"{OUTPUT_FLAGS[flag]}: {error}") from None
        payload = {
            "command": args.command,
            "source": path,
            "outputs": outputs,
            "overwrite": getattr(args, "overwrite", None),
            **common,
        }
        jobs.append(
            Job(name, path, tuple(outputs.values()), sidecar_path(folders["out"], name), key, settings, payload)
        )
    for flag in given:  # every check passed: now the folders
        output_folder(OUTPUT_FLAGS[flag], getattr(args, flag), args.clip)
    return jobs, others


def _cell(key: str):
    """A summary column's pick: the record's metric `key` to 4 digits, "-" when absent."""

    def pick(record: dict) -> str:
        return figure((record.get("metrics") or {}).get(key))

    return pick


COLUMNS = {
    "clip": [
        ("frames met", lambda record: f"{record.get('frames_met', '-')}/{record.get('frames', '-')}"),
        ("sliding max mm/frame", _cell("sliding_max_mm_per_frame")),
        ("penetration max mm", _cell("penetration_max_mm")),
        ("angle from capture mean deg", _cell("joint_angle_deviation_mean_deg")),
    ],
    "retarget": [
        ("key points mean mm", _cell("keypoint_error_mean_mm")),
        ("sliding max mm/frame", _cell("contact_sliding_max_mm_per_frame")),
        ("penetration max mm", _cell("penetration_max_mm")),
        ("self-penetration max mm", _cell("self_penetration_max_mm")),
        ("limit violations", _cell("limit_violations_count")),
        ("ms/frame", _cell("time_per_frame_ms")),
    ],
}


@contextlib.contextmanager
def _terminate_as_interrupt():
    """SIGTERM (a job scheduler's stop, `kill`) handled as Ctrl-C inside the block: the run stops
    its workers and keeps the clips finished, where it ended at once and left the workers
    running on (they wrote nothing, but held the machine)."""
    if threading.current_thread() is not threading.main_thread():  # only the main thread sets handlers
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def run_folder(args: argparse.Namespace) -> int:
    """Every clip of the folder `args.clip`: skip those done, run the rest, print the summary;
    status 1 when a clip failed, 130 on Ctrl-C (the clips finished are kept)."""
    from deik.cli.arguments import announce_compile
    from deik.library.run import run_library, summary_line, summary_table

    _check_first(args)
    jobs, others = library_jobs(args)
    if not args.quiet:
        if others:
            shown = ", ".join(others[:6]) + (f" and {len(others) - 6} more" if len(others) > 6 else "")
            print(f"{len(jobs)} clips in {args.clip}; skipped (not *.bvh, or a sub-folder): {shown}", file=sys.stderr)
        announce_compile(
            getattr(args, "device", None) or "cpu", "float32", polish=False, clip=True
        )  # the workers compile
    try:
        with _terminate_as_interrupt():
            run = run_library(
                jobs,
                do_clip,
                executor=args.executor or "local",
                workers=args.workers
                or (1 if getattr(args, "device", None) == "gpu" and args.executor != "ray" else None),  # one GPU
                address=args.address,
                quiet=args.quiet,
                progress=args.progress,
            )
    except KeyboardInterrupt:
        print("deik: interrupted; the clips finished are kept, and rerunning the command goes on", file=sys.stderr)
        return INTERRUPTED
    print(summary_table(run, COLUMNS[args.command]))
    print(summary_line(run))
    return FAILED if run.count("failed") else 0

"""The `deik` command: `solve` poses one problem, `info` describes a skeleton, `clip` fixes a
whole clip, `retarget` moves one onto other proportions or another skeleton, `limits` measures
joint limits from a clip, `view` shows a pose, clip or robot in 3-D in the browser, `demo` runs
the paper's scenarios, `experiments` reproduces the paper's figures.

    deik solve chain:20 --reach tip 10 5 0 --comfort 0.5 --out pose.json --plot pose.png
    deik solve --skeleton walk.bvh --frame 12 --reach LeftElbow_end 0.4 1.2 0.3 --out fixed.bvh
    deik solve --skeleton panda.urdf --base panda_link0 --tip panda_hand_tcp --reach panda_hand_tcp 0.4 0.2 0.5
    deik info panda.urdf
    deik clip walk.bvh --plant-feet auto --balance --out walk_fixed.bvh --report report.png
    deik limits walk.bvh --margin 10 --out limits.json      (then --limits limits.json)
    deik retarget walk.bvh --map map.toml --to human.urdf --out walk_human.csv --view walk_human.bvh
    deik view walk_fixed.bvh --compare walk.bvh --report report.json   (a 3-D view in the browser)
    deik clip clips/ --out fixed/ --workers 2      (every *.bvh of a folder; a rerun skips the clips done)
    deik demo --out demo_output
    deik experiments all --quick --out figures

Mistakes in the input print one line `deik: error: ...` on stderr and exit with status 2; a bug prints
`deik: internal error: ...` and exits with 3; Ctrl-C stops the work, writes nothing and exits with 130.
"""

from __future__ import annotations

import argparse
import os
import sys

from deik import __version__
from deik.cli.arguments import USER_ERRORS, UsageError, add_up, check_outputs, number
from deik.console import Parser, add_output_flags, configure_logging, show_compile_bars, show_progress
from deik.errors import error_line
from deik.experiments import flags as experiment_flags
from deik.io.files import command_inputs

USAGE_ERROR = 2
INTERNAL_ERROR = 3
INTERRUPTED = 130  # 128 + SIGINT, as shells report it
BROKEN_PIPE = 141  # 128 + SIGPIPE


def run_demo(args: argparse.Namespace) -> int:
    """`deik demo`: the paper's scenarios; status 1 when one misses its target."""
    from deik.experiments import demo

    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise UsageError(f"--out {args.out!r} is a file; give a folder for the pictures and demo.json")
    rows = demo.run_demo(args.out, show=show_progress(args))
    return 0 if all(row["passed"] for row in rows) else 1


def run_limits(args: argparse.Namespace) -> int:
    """`deik limits IN.bvh --out limits.json`: each DOF's range over the clip plus margins."""
    from deik.io.bvh import read_bvh
    from deik.io.limits import range_of_motion, write_limits

    check_outputs({"--out": args.out}, {"--out": (".json",)}, (args.clip,))
    clip = read_bvh(args.clip)
    limits = range_of_motion(clip, args.margin, args.margin_length)
    write_limits(args.out, clip.skeleton, limits)
    left = clip.skeleton.n_dofs - len(limits)
    lengths = (
        f"{args.margin_length:g} length units"
        if args.margin_length is not None
        else f"the {left} translations that carry the body left free (--margin-length measures them)"
    )
    print(f"{len(limits)} DOFs of {clip.n_frames} frames, margin {args.margin:g} degrees, {lengths}: wrote {args.out}")
    return 0


def run_experiments(args: argparse.Namespace) -> int:
    """`deik experiments NAME|all [--quick] --out DIR`: the paper's figures (deik.experiments.runner)."""
    from deik.experiments.runner import run

    return run(args)


def _solve(parser: Parser) -> None:
    from deik.cli import solve_command

    solve_command.add_arguments(parser)
    parser.set_defaults(run=solve_command.run_solve)


def _info(parser: Parser) -> None:
    from deik.cli import info_command

    parser.add_argument("skeleton", help="a .bvh or .urdf file, or chain:N, chain3d:N, humanoid")
    parser.add_argument("--segments", metavar="FILE.json", help="BVH: segment masses (default: estimated)")
    parser.add_argument("--base", metavar="LINK", help="URDF: the link fixed in the world")
    parser.add_argument("--tip", action="append", default=[], metavar="LINK", help="URDF: keep the chain to LINK")
    add_up(parser)
    add_output_flags(parser, progress=False)
    parser.set_defaults(run=info_command.run_info)


def _clip(parser: Parser) -> None:
    from deik.cli import clip_command, folder_command

    clip_command.add_arguments(parser)
    folder_command.add_arguments(parser)
    parser.set_defaults(run=folder_command.run)


def _retarget(parser: Parser) -> None:
    from deik.cli import folder_command, retarget_command

    retarget_command.add_arguments(parser)
    folder_command.add_arguments(parser)
    parser.set_defaults(run=folder_command.run)


def _experiments(parser: Parser) -> None:
    experiment_flags.add_arguments(parser)
    parser.set_defaults(run=run_experiments)


def _limits(parser: Parser) -> None:
    parser.add_argument("clip", metavar="IN.bvh", help="the clip whose range of motion sets the limits")
    parser.add_argument("--out", required=True, metavar="limits.json", help="the table to write")
    parser.add_argument(
        "--margin",
        type=number(0.0, 180.0),
        default=10.0,
        metavar="DEGREES",
        help="added to each rotation's range on both sides (default 10)",
    )
    parser.add_argument(
        "--margin-length",
        type=number(0.0),
        metavar="LENGTH",
        help="also measure the translations that carry the body through the world (the root's), widened by "
        "LENGTH on both sides (default: left out, so a clip fix may lift or shift the body)",
    )
    add_output_flags(parser, progress=False)
    parser.set_defaults(run=run_limits)


def _view(parser: Parser) -> None:
    from deik.cli import view_command

    view_command.add_arguments(parser)
    parser.set_defaults(run=view_command.run_view)


def _warmup(parser: Parser) -> None:
    from deik.cli import warmup_command

    warmup_command.add_arguments(parser)
    parser.set_defaults(run=warmup_command.run_warmup)


def _demo(parser: Parser) -> None:
    parser.add_argument("--out", default="demo_output", metavar="DIR", help="folder for PNGs and demo.json")
    add_output_flags(parser)
    parser.set_defaults(run=run_demo)


# (name, summary, what adds its flags): a command's module is imported only when it is the one
# run (or every one, for `deik --help`), so `deik solve` does not load the clip pipeline
COMMANDS = (
    ("solve", "pose one problem and report per-goal errors", _solve),
    ("info", "print a skeleton's joint tree, DOFs, limits, masses and sites", _info),
    ("clip", "fix a whole BVH clip: plant feet, balance, reach tracks, stay close", _clip),
    ("retarget", "move a BVH clip onto other bone lengths or another skeleton", _retarget),
    ("experiments", experiment_flags.SUMMARY, _experiments),
    ("limits", "measure joint limits from a BVH clip's range of motion", _limits),
    ("view", "a 3-D view in the browser of a pose, a clip or a robot (needs deik[view])", _view),
    ("warmup", "compile the kernels ahead of time (minutes, once after an install)", _warmup),
    ("demo", "run the paper's scenarios, print a table and write pictures", _demo),
)


def build_parser(command: str | None = None) -> Parser:
    """The parser of the whole command line, with the flags of subcommand `command` (default:
    of every subcommand; the others are listed with their summaries only)."""
    parser = Parser(prog="deik", description="Inverse kinematics by parallel Differential Evolution.")
    parser.add_argument("--version", action="version", version=f"deik {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for name, summary, add_flags in COMMANDS:
        sub = commands.add_parser(name, help=summary, description=f"{summary[0].upper()}{summary[1:]}.")
        if command in (None, name):
            add_flags(sub)
    return parser


def _named_command(argv: list[str]) -> str | None:
    """The subcommand `argv` runs (its first word that is no flag), or None when that is no command."""
    word = next((arg for arg in argv if not arg.startswith("-")), None)
    return word if word in {name for name, _, _ in COMMANDS} else None


def main(argv: list[str] | None = None) -> int:
    """Run the command line `argv` (default sys.argv[1:]); returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        args = build_parser(_named_command(argv)).parse_args(argv)
        configure_logging(args)
        show_compile_bars(show_progress(args))
        overwrite = getattr(args, "overwrite", None)  # None: the command has no --overwrite
        with command_inputs(protect=not overwrite, overwrite_flag=overwrite is not None):  # no output replaces an input
            return args.run(args)
    except SystemExit as done:  # --help
        return done.code
    except BrokenPipeError:
        # the reader (e.g. `| head`) has gone: stay quiet, and keep Python from complaining at exit
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return BROKEN_PIPE
    except USER_ERRORS as error:
        print(f"deik: error: {error_line(error)}", file=sys.stderr)
        return USAGE_ERROR
    except KeyboardInterrupt:
        print("deik: interrupted; nothing was written", file=sys.stderr)
        return INTERRUPTED
    except Exception as error:  # a bug, not a mistake in the input
        if os.environ.get("DEIK_DEBUG"):
            raise
        print(
            f"deik: internal error: {type(error).__name__}: {error_line(error)}. This is a bug in deik; "
            "please report it with the command line (rerun with DEIK_DEBUG=1 for the traceback)",
            file=sys.stderr,
        )
        return INTERNAL_ERROR


if __name__ == "__main__":
    sys.exit(main())

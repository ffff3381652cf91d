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
from deik.cli import clip_command as cli_clip
from deik.cli import folder_command as cli_library
from deik.cli import info_command as cli_info
from deik.cli import retarget_command as cli_retarget
from deik.cli import solve_command as cli_solve
from deik.cli import view_command as cli_view
from deik.cli import warmup_command as cli_warmup
from deik.cli.arguments import USER_ERRORS, check_outputs, number
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


def _command(commands, name: str, summary: str) -> Parser:
    """The subcommand `name`: `summary` in `deik --help`'s list and, as a sentence, atop its own --help."""
    return commands.add_parser(name, help=summary, description=f"{summary[0].upper()}{summary[1:]}.")


def build_parser() -> Parser:
    """The parser of the whole command line: every subcommand and its flags."""
    parser = Parser(prog="deik", description="Inverse kinematics by parallel Differential Evolution.")
    parser.add_argument("--version", action="version", version=f"deik {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    s = _command(commands, "solve", "pose one problem and report per-goal errors")
    cli_solve.add_arguments(s)
    s.set_defaults(run=cli_solve.run_solve)
    i = _command(commands, "info", "print a skeleton's joint tree, DOFs, limits, masses and sites")
    i.add_argument("skeleton", help="a .bvh or .urdf file, or chain:N, chain3d:N, humanoid")
    i.add_argument("--segments", metavar="FILE.json", help="BVH: segment masses (default: estimated)")
    i.add_argument("--base", metavar="LINK", help="URDF: the link fixed in the world")
    i.add_argument("--tip", action="append", default=[], metavar="LINK", help="URDF: keep the chain to LINK")
    i.add_argument("--up", nargs=3, metavar=("X", "Y", "Z"), help="URDF: world up direction (default 0 0 1)")
    add_output_flags(i, progress=False)
    i.set_defaults(run=cli_info.run_info)
    c = _command(commands, "clip", "fix a whole BVH clip: plant feet, balance, reach tracks, stay close")
    cli_clip.add_arguments(c)
    cli_library.add_arguments(c)
    c.set_defaults(run=cli_library.run)
    r = _command(commands, "retarget", "move a BVH clip onto other bone lengths or another skeleton")
    cli_retarget.add_arguments(r)
    cli_library.add_arguments(r)
    r.set_defaults(run=cli_library.run)
    e = _command(commands, "experiments", experiment_flags.SUMMARY)
    experiment_flags.add_arguments(e)
    e.set_defaults(run=run_experiments)
    lim = _command(commands, "limits", "measure joint limits from a BVH clip's range of motion")
    lim.add_argument("clip", metavar="IN.bvh", help="the clip whose range of motion sets the limits")
    lim.add_argument("--out", required=True, metavar="limits.json", help="the table to write")
    lim.add_argument(
        "--margin",
        type=number(0.0, 180.0),
        default=10.0,
        metavar="DEGREES",
        help="added to each rotation's range on both sides (default 10)",
    )
    lim.add_argument(
        "--margin-length",
        type=number(0.0),
        metavar="LENGTH",
        help="also measure the translations that carry the body through the world (the root's), widened by "
        "LENGTH on both sides (default: left out, so a clip fix may lift or shift the body)",
    )
    add_output_flags(lim, progress=False)
    lim.set_defaults(run=run_limits)
    v = _command(commands, "view", "a 3-D view in the browser of a pose, a clip or a robot (needs deik[view])")
    cli_view.add_arguments(v)
    v.set_defaults(run=cli_view.run_view)
    w = _command(commands, "warmup", "compile the kernels ahead of time (minutes, once after an install)")
    cli_warmup.add_arguments(w)
    w.set_defaults(run=cli_warmup.run_warmup)
    d = _command(commands, "demo", "run the paper's scenarios, print a table and write pictures")
    d.add_argument("--out", default="demo_output", metavar="DIR", help="folder for PNGs and demo.json")
    add_output_flags(d)
    d.set_defaults(run=run_demo)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line `argv` (default sys.argv[1:]); returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        args = build_parser().parse_args(argv)
        configure_logging(args)
        show_compile_bars(show_progress(args))
        with command_inputs(protect=not getattr(args, "overwrite", False)):  # no output replaces an input
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

"""The `deik` command: `deik solve` poses one problem, `deik demo` runs the paper's scenarios.

    deik solve chain:20 --reach tip 10 5 0 --comfort 0.5 --out pose.json --plot pose.png
    deik solve humanoid --reach left_hand 0.23 1.0 0.25 --com-over -0.09 0 0.06
    deik solve --problem problem.toml --seed 3
    deik demo --out demo_output

Mistakes in the input print one line `deik: error: ...` on stderr and exit with status 2.
"""

from __future__ import annotations

import argparse
import math
import os
import sys

import numpy as np

from deik import plot
from deik.io.atomic import write_json_atomically
from deik.evolution.engine import STRATEGIES, Settings
from deik.objectives import goals as g
from deik.problem import Problem
from deik.problem_file import load_problem, skeleton_from_spec
from deik.rotations import euler_matrix
from deik.solve import solve

USAGE_ERROR = 2
SETTING_FLAGS = ("seed", "population", "generations", "strategy", "device", "dtype")
RADIAN_WORDS = ("orientation", "aim", "comfort")


class UsageError(Exception):
    """A mistake in the command line or its inputs: reported in one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise UsageError(f"{message} (see `{self.prog} --help`)")


def format_table(header: list[str], rows: list[list]) -> str:
    """Left-aligned text table: `header` column names, `rows` of cells turned into strings."""
    cells = [header] + [[str(c) for c in row] for row in rows]
    widths = [max(len(row[k]) for row in cells) for k in range(len(header))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in cells]
    return "\n".join([lines[0], "  ".join("-" * w for w in widths)] + lines[1:])


def unit(label: str) -> str:
    """Unit of a goal report's error from its label: "rad" for angles, "m" for lengths."""
    return "rad" if label.split()[0] in RADIAN_WORDS else "m"


def _numbers(flag: str, words) -> list[float]:
    values = []
    for word in words:
        try:
            value = float(word)
        except ValueError:
            raise UsageError(f"{flag}: {word!r} is not a number") from None
        if not math.isfinite(value):
            raise UsageError(f"{flag}: {word!r} is not a finite number")
        values.append(value)
    return values


def _flag_goals(args) -> list:
    """Goals from the goal flags: targets on priority level 0, comfort below them on level 1."""
    goals = [g.Position(frame, _numbers("--reach", xyz)) for frame, *xyz in args.reach]
    for frame, *angles in args.orient:
        rotation = euler_matrix("XYZ", np.radians(_numbers("--orient", angles)))
        goals.append(g.Orientation(frame, rotation))
    if args.com_over:
        goals.append(g.ComOverSupport(_numbers("--com-over", args.com_over)))
    for values in args.obstacle:
        *centre, radius = _numbers("--obstacle", values)
        goals.append(g.Obstacle(centre, radius))
    if args.comfort is not None:
        goals.append(g.Comfort(weight=args.comfort, level=1))
    return goals


def _problem(args) -> tuple[Problem, dict]:
    has_goal_flags = bool(args.reach or args.orient or args.com_over or args.obstacle) or args.comfort is not None
    if args.problem:
        if args.skeleton or has_goal_flags:
            raise UsageError("--problem FILE already names the skeleton and goals; "
                             "drop the SKELETON argument and goal flags or put them in the file")
        return load_problem(args.problem)
    if not args.skeleton:
        raise UsageError("give a SKELETON (chain:N, chain3d:N or humanoid) or --problem FILE.toml")
    skeleton = skeleton_from_spec(args.skeleton)
    if not has_goal_flags:
        raise UsageError("no goals: add e.g. --reach tip X Y Z (see `deik solve --help`)")
    return Problem(skeleton, _flag_goals(args)), {}


def _check_output(flag: str, path) -> None:
    if path is not None and not os.path.isdir(os.path.dirname(os.path.abspath(path))):
        raise UsageError(f"{flag}: folder {os.path.dirname(os.path.abspath(path))!r} does not exist")


def _check_device(device: str) -> None:
    if device != "gpu":
        return
    try:
        from numba import cuda
    except ImportError:
        raise UsageError('--device gpu needs numba-cuda: pip install "deik[gpu]"') from None
    if not cuda.is_available():
        raise UsageError("--device gpu: no CUDA GPU is available here; use --device cpu")


def _progress(generations: int, terminal: bool):
    """solve()'s progress callback: one line on stderr, redrawn in place on a terminal."""
    def report(generation, best):
        line = f"generation {generation}/{generations}  best fitness {best:.6g}"
        print(f"\r{line}" if terminal else line, end="" if terminal else "\n", file=sys.stderr, flush=True)
    return report


def run_solve(args) -> int:
    """`deik solve`: build the problem, solve, print the report, write the requested files."""
    _check_output("--out", args.out)
    _check_output("--plot", args.plot)
    if args.plot:
        plot.require_matplotlib()
    problem, settings = _problem(args)
    settings.update({k: getattr(args, k) for k in SETTING_FLAGS if getattr(args, k) is not None})
    settings = Settings(**settings)
    _check_device(settings.device)
    terminal = sys.stderr.isatty()
    progress = _progress(settings.generations, terminal) if args.progress or terminal else None
    result = solve(problem, settings, progress=progress)
    if progress and terminal:
        print(file=sys.stderr)
    rows = [[r.label, f"{float(r.error):.6g} {unit(r.label)}",
             f"{r.tolerance:.6g} {unit(r.label)}" if r.tolerance >= 0 else "-",
             "yes" if r.met else "NO"] for r in result.goals]
    print(format_table(["goal", "error", "tolerance", "met"], rows))
    print(f"generations {int(result.generations)}  time {result.wall_time:.3f} s  device {result.device}  "
          f"converged {'yes' if result.converged else 'no'}")
    if args.out:
        write_json_atomically(args.out, result.to_dict())
    if args.plot:
        plot.plot_result(problem, result, args.plot, title=f"deik solve {args.skeleton or args.problem}")
    return 0


def run_demo(args) -> int:
    """`deik demo`: the paper's scenarios; status 1 when one misses its target."""
    from deik import demo

    rows = demo.run_demo(args.out)
    return 0 if all(row["passed"] for row in rows) else 1


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="deik", description="Inverse kinematics by parallel Differential Evolution.")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    s = commands.add_parser("solve", help="pose one problem and report per-goal errors")
    s.add_argument("skeleton", nargs="?", help="chain:N (planar), chain3d:N or humanoid")
    s.add_argument("--problem", metavar="FILE.toml", help="read skeleton, goals and settings from a TOML file")
    s.add_argument("--reach", nargs=4, action="append", default=[], metavar=("FRAME", "X", "Y", "Z"),
                   help="put joint or site FRAME at X Y Z (repeatable)")
    s.add_argument("--orient", nargs=4, action="append", default=[], metavar=("FRAME", "RX", "RY", "RZ"),
                   help="turn FRAME to intrinsic XYZ Euler angles in degrees (repeatable)")
    s.add_argument("--com-over", nargs=3, metavar=("X", "Y", "Z"),
                   help="keep the centre of mass over this support point (horizontally)")
    s.add_argument("--obstacle", nargs=4, action="append", default=[], metavar=("X", "Y", "Z", "RADIUS"),
                   help="keep every bone out of this sphere (repeatable)")
    s.add_argument("--comfort", type=float, metavar="WEIGHT",
                   help="stay near the rest pose with this weight in [-1, 1], below the other goals in priority")
    s.add_argument("--seed", type=int, help="random seed (same seed, same answer)")
    s.add_argument("--population", type=int, help="DE population per problem (default 256)")
    s.add_argument("--generations", type=int, help="most generations to run (default 2000)")
    s.add_argument("--strategy", choices=list(STRATEGIES), help="DE mutation strategy")
    s.add_argument("--device", choices=["cpu", "gpu"], help="where the kernels run (default cpu)")
    s.add_argument("--dtype", choices=["float32", "float64"], help="kernel precision (default float32)")
    s.add_argument("--out", metavar="pose.json", help="write the result as JSON")
    s.add_argument("--plot", metavar="pose.png", help="draw the pose as PNG (needs deik[viz])")
    s.add_argument("--progress", action="store_true", help="report progress on stderr even when it is not a terminal")
    s.set_defaults(run=run_solve)
    d = commands.add_parser("demo", help="run the paper's scenarios, print a table and write pictures")
    d.add_argument("--out", default="demo_output", metavar="DIR", help="folder for PNGs and demo.json")
    d.set_defaults(run=run_demo)
    return parser


def main(argv=None) -> int:
    """Run the command line `argv` (default sys.argv[1:]); returns the exit status."""
    try:
        args = build_parser().parse_args(argv)
        return args.run(args)
    except SystemExit as done:  # --help
        return done.code
    except (UsageError, ValueError, ImportError, OSError, KeyError) as error:
        # KeyError (unknown joint) keeps its message in args[0]; str() would add quotes.
        message = error.args[0] if isinstance(error, KeyError) else error
        print(f"deik: error: {message}", file=sys.stderr)
        return USAGE_ERROR


if __name__ == "__main__":
    sys.exit(main())

"""`deik solve`: pose one problem from flags or a TOML file, on a built-in skeleton, a BVH
clip frame or a URDF robot, print per-goal errors and write JSON, BVH or PNG atomically.

    deik solve chain:20 --reach tip 10 5 0 --comfort 0.5 --out pose.json --plot pose.png
    deik solve --skeleton walk.bvh --frame 12 --reach LeftElbow_end 0.4 1.2 0.3 --out fixed.bvh
    deik solve --skeleton panda.urdf --base panda_link0 --tip panda_hand_tcp \\
        --reach panda_hand_tcp 0.4 0.2 0.5 --orient panda_hand_tcp rpy 180 0 0 --out pose.json
"""

from __future__ import annotations

import argparse
import logging
import os
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from deik.cli.arguments import (
    UsageError,
    add_free_translations,
    add_up,
    check_device,
    check_outputs,
    checked_settings,
    number,
    numbers,
    up_of,
)
from deik.cli.goal_flags import FRAME_COMFORT, add_goal_arguments, goals_from_flags, has_goals
from deik.console import Parser, add_output_flags, progress_bar, show_generation, show_progress
from deik.errors import DeikError
from deik.io.atomic import all_or_nothing, write_json_atomically
from deik.io.limits import read_limits, with_limits
from deik.io.load import load_skeleton
from deik.io.pose_json import pose_angles, read_pose_json
from deik.io.urdf import read_urdf
from deik.model.joints import ROTATE
from deik.solver.problem import Problem
from deik.solver.problem_file import ProblemFile, load_problem
from deik.solver.seeding import poses_around
from deik.solver.settings import STRATEGIES, Settings
from deik.solver.solve import prepare_solve, solve
from deik.viz import plot
from deik.viz.marks import goal_targets, length_unit
from deik.viz.text import format_table, shown

SETTING_FLAGS = (
    "seed",
    "population",
    "generations",
    "strategy",
    "device",
    "dtype",
    "time_limit",
    "polish",
    "restarts",
    "islands",
)
SEED_FRACTION = 4  # a quarter of the population starts near the clip frame
log = logging.getLogger(__name__)


def add_arguments(s: argparse.ArgumentParser) -> None:
    """The `deik solve` flags on subparser `s`."""
    s.add_argument("skeleton", nargs="?", help="chain:N (planar), chain3d:N, humanoid, or a .bvh/.urdf file")
    s.add_argument("--skeleton", dest="skeleton_flag", metavar="FILE", help="same as SKELETON: a .bvh or .urdf file")
    s.add_argument("--problem", metavar="FILE.toml", help="read skeleton, goals and settings from a TOML file")
    s.add_argument("--frame", type=int, metavar="N", help="BVH: pose frame N (0-based) of the clip")
    s.add_argument("--segments", metavar="FILE.json", help="BVH: segment masses (default: estimated from bone lengths)")
    add_free_translations(s)
    s.add_argument("--base", metavar="LINK", help="URDF: the link fixed in the world (default: the root link)")
    s.add_argument(
        "--tip",
        action="append",
        default=[],
        metavar="LINK",
        help="URDF: keep only the chain from --base to LINK (repeatable; default: every link)",
    )
    add_up(s)
    s.add_argument(
        "--limits",
        metavar="FILE.json",
        help='joint limits table {"DOF": [lower, upper]} (degrees / length units), e.g. from `deik limits`',
    )
    add_goal_arguments(s)
    s.add_argument("--seed", type=int, help="random seed (same seed, same answer)")
    s.add_argument("--population", type=int, help="DE population per problem (default 256)")
    s.add_argument("--generations", type=int, help="most generations to run (default 2000)")
    s.add_argument("--strategy", choices=list(STRATEGIES), help="DE mutation strategy")
    s.add_argument(
        "--time-limit",
        type=number(0.0, above=True),
        metavar="SECONDS",
        help="stop after this wall time (default: none)",
    )
    s.add_argument(
        "--polish",
        type=int,
        metavar="N",
        help="Levenberg-Marquardt steps per polish of the best individuals (default 30; 0: DE only)",
    )
    s.add_argument("--restarts", type=int, metavar="N", help="restarts of a stagnating unconverged search (default 20)")
    s.add_argument(
        "--islands", type=int, metavar="N", help="split the population into N islands that migrate (default 1)"
    )
    s.add_argument("--device", choices=["cpu", "gpu"], help="where the kernels run (default cpu)")
    s.add_argument("--dtype", choices=["float32", "float64"], help="kernel precision (default float32)")
    s.add_argument(
        "--memory-limit",
        type=number(0.0, above=True),
        metavar="GIB",
        help="memory a solve may use, GiB (default: 80%% of this machine's)",
    )
    s.add_argument(
        "--out",
        metavar="pose.json|pose.bvh",
        help="write the result as JSON, or as BVH (for a BVH input: the clip with the frame replaced)",
    )
    s.add_argument(
        "--plot",
        metavar="pose.png",
        help="draw the pose as PNG, front and side views, with its targets, centre of mass, root, tips and sites "
        "(needs deik[viz])",
    )
    s.add_argument("--plot-3d", action="store_true", help="draw --plot as one 3-D perspective view instead")
    s.add_argument("--overwrite", action="store_true", help="allow an output to replace an input file")
    s.add_argument(
        "--start",
        nargs="+",
        metavar="VALUE|pose.json",
        help="start near this pose: one value per DOF (degrees / length units, `deik info` order) or a "
        "pose.json written by --out; comfort then keeps the result near it unless --comfort is given",
    )
    add_output_flags(s)


def _start_pose(values: list[str], skeleton) -> np.ndarray:
    """The --start pose (D,) in radians and length units: numbers in DOF order on the command line
    (degrees for rotations, as `deik info` shows them), or the "angles" (radians) of a pose.json."""
    if len(values) == 1 and values[0].lower().endswith(".json"):
        try:
            pose = read_pose_json(values[0])
        except ValueError as error:
            raise UsageError(f"--start: cannot read a pose: {error}") from None
        if pose.batched:
            raise UsageError(f"--start {values[0]}: it holds a batch of {len(pose.angles)} poses; give one pose's JSON")
        return pose_angles(pose, skeleton, "--start")[0]
    pose = np.asarray(numbers("--start", values), np.float64)
    if pose.shape != (skeleton.n_dofs,):
        raise UsageError(
            f"--start needs {skeleton.n_dofs} values, one per DOF ({', '.join(skeleton.dof_names)}); got {pose.size}"
        )
    return np.where(skeleton.dof_kind == ROTATE, np.radians(pose), pose)  # poses_around checks the limits


def _file_flags_used(args) -> bool:
    flags = (args.frame, args.segments, args.base, args.tip, args.up, args.limits)
    return any(v not in (None, []) for v in flags) or args.free_translations


def pose_problem(args: argparse.Namespace) -> ProblemFile:
    """The problem the flags pose (deik.solver.problem_file.ProblemFile): from --problem FILE,
    or the skeleton, its options, --start and the goal flags; its settings hold the file's and
    the setting flags' (the flags win). UsageError for a mistake in the flags."""
    spec = args.skeleton_flag or args.skeleton
    if args.skeleton_flag and args.skeleton:
        raise UsageError("give the skeleton once: either SKELETON or --skeleton FILE")
    if args.problem:
        if spec or has_goals(args) or _file_flags_used(args) or args.start:
            raise UsageError(
                "--problem FILE already names the skeleton and goals; "
                "drop the SKELETON argument, skeleton options, --start and goal flags or put them in the file"
            )
        file = load_problem(args.problem)
        return replace(file, settings=file.settings | _settings(args))
    if not spec:
        raise UsageError("give a SKELETON (chain:N, chain3d:N, humanoid, a .bvh or .urdf file) or --problem FILE.toml")
    up = up_of(args)
    loaded = load_skeleton(
        spec, base=args.base, tip=args.tip, segments=args.segments, up=up, free_translations=args.free_translations
    )
    if args.limits:
        loaded = replace(loaded, skeleton=with_limits(loaded.skeleton, read_limits(args.limits, loaded.skeleton)))
    frame_pose = None
    if loaded.kind == "bvh":
        if args.frame is None:
            if not loaded.clip.n_frames:
                raise UsageError(
                    f"{spec}: the clip has no frames (Frames: 0), so no pose to start from; give one with motion"
                )
            if loaded.clip.n_frames > 1:
                raise UsageError(f"{spec} is a clip of {loaded.clip.n_frames} frames: choose one with --frame N")
        args.frame = 0 if args.frame is None else args.frame  # a clip of one frame: that one
        frame_pose = _clip_pose(loaded.clip, args.frame)
    elif args.frame is not None:
        raise UsageError("--frame only applies to a BVH clip")
    if args.start:
        frame_pose = _start_pose(args.start, loaded.skeleton)
    if frame_pose is not None:
        _within_limits(frame_pose, loaded.skeleton, "--start" if args.start else f"--frame {args.frame}", args.limits)
    if not has_goals(args):
        raise UsageError("no goals: add e.g. --reach FRAME X Y Z (see `deik solve --help`)")
    _check_cut(args, loaded, spec)
    unit = length_unit(loaded.skeleton, loaded.kind)[0]
    problem = Problem(loaded.skeleton, goals_from_flags(args, frame_pose, unit))
    return ProblemFile(problem, _settings(args), loaded, args.frame, frame_pose)


def _within_limits(pose: np.ndarray, skeleton, flag: str, table: str | None) -> None:
    """UsageError naming `flag` when the pose (D,) it gave lies outside the skeleton's limits
    (narrowed by the --limits `table`, if any), in degrees for a rotation."""
    pose = skeleton.wrapped(pose)
    outside = np.flatnonzero((pose < skeleton.lower - 1e-9) | (pose > skeleton.upper + 1e-9))
    if outside.size:
        d = outside[0]
        scale, unit = (np.degrees(1.0), "degrees") if skeleton.dof_kind[d] == ROTATE else (1.0, "length units")
        where = f"--limits {table}" if table else "its limits"
        raise UsageError(
            f"{flag}: DOF {skeleton.dof_names[d]!r} = {pose[d] * scale:.4g} {unit} lies outside {where} "
            f"([{skeleton.lower[d] * scale:.4g}, {skeleton.upper[d] * scale:.4g}] {unit}); "
            + ("widen the table, or measure it with `deik limits`" if table else "give a pose within them")
        )


def _check_cut(args, loaded, spec: str) -> None:
    """UsageError when a goal names a link of the URDF `spec` that --base/--tip cut away (the
    skeleton's own unknown-name error would suggest a link of the chain instead)."""
    if loaded.kind != "urdf" or not (args.base or args.tip):
        return
    named = [frame for frame, *_ in args.reach] + [words[0] for words in args.orient]
    missing = [name for name in named if name not in loaded.skeleton.frame_names]
    if not missing:
        return
    try:
        whole = read_urdf(spec, up=loaded.skeleton.up).frame_names
    except DeikError:  # the rest of the file cannot be built: the skeleton's own error says enough
        return
    for name in missing:
        if name in whole:
            cut = " ".join([f"--base {args.base}"] * bool(args.base) + [f"--tip {tip}" for tip in args.tip])
            raise UsageError(f"{name!r} is a link of {spec} but not on the chain {cut} keeps: add --tip {name}")


FLOAT32_FINEST = 2e-6  # of the reach: the finest position tolerance float32 solves meet reliably


def _check_precision(args, problem: Problem, settings: Settings) -> None:
    """A warning when --tolerance asks float32 kernels for less than FLOAT32_FINEST x the reach
    (a Panda in millimetres held to 0.001 stopped unconverged; 1e-5 m on the metre Panda is met)."""
    finest = FLOAT32_FINEST * problem.skeleton.reach
    if settings.dtype == "float32" and args.tolerance is not None and args.tolerance < finest:
        log.warning(
            f"--tolerance {args.tolerance:g} is finer than float32 kernels reliably reach on this skeleton "
            f"(about {finest:.2g} length units, {FLOAT32_FINEST:g} of its reach); add --dtype float64"
        )


def _settings(args) -> dict:
    """The settings the setting flags give (--seed, --population, ..., --memory-limit in GiB)."""
    settings = {k: getattr(args, k) for k in SETTING_FLAGS if getattr(args, k) is not None}
    if args.memory_limit is not None:
        settings["memory_limit"] = max(1, int(args.memory_limit * 2**30))
    return settings


def problem_from_flags(words: Sequence[str]) -> ProblemFile:
    """The problem `deik solve WORDS` would solve, e.g. problem_from_flags(["chain:20", "--reach",
    "tip", "12", "8", "0", "--seed", "3"]) (or ["--problem", "problem.toml"]): its Problem, its
    settings and the pose the search starts around; solve it with
    deik.solve(spec.problem, **spec.settings). Flags that only write or show (--out, --plot,
    --quiet, ...) are accepted and ignored. UsageError (a deik.InputError) for a mistake."""
    parser = Parser(prog="deik solve")
    add_arguments(parser)
    return pose_problem(parser.parse_args([str(word) for word in words]))


def _clip_pose(clip, frame: int):
    """Pose (D,) of clip frame `frame`; UsageError naming the valid frames when it is out of range."""
    try:
        return clip.pose(frame)
    except IndexError as error:
        raise UsageError(f"--frame: {error}") from None


def _write_pose(path: str, problem: Problem, result, loaded: object, frame: int | None, unit: str) -> None:
    """JSON summary (Result.to_dict with the length unit and the goals' target points,
    viz.marks.goal_targets; `unit` the skeleton's length unit), or
    BVH: the input clip with `frame` replaced, else a one-frame clip."""
    if os.path.splitext(path)[1].lower() != ".bvh":
        data = {**result.to_dict(), "length_unit": unit, "targets": goal_targets(problem)}
        if frame is not None:
            data["frame"] = frame
        write_json_atomically(path, data)
        return
    from deik.io.bvh import write_bvh
    from deik.io.motion import Clip

    if loaded is not None and loaded.clip is not None:
        clip = loaded.clip.with_pose(frame, result.angles)
    else:
        clip = Clip.from_poses(result.skeleton, result.angles[None], frame_time=1.0 / 30.0)
    write_bvh(path, clip)


def run_solve(args: argparse.Namespace) -> int:
    """`deik solve`: build the problem, solve, print the report, write the requested files."""
    inputs = (
        args.skeleton_flag,
        args.skeleton,
        args.problem,
        args.segments,
        args.limits,
        args.start[0] if args.start and len(args.start) == 1 else None,
    )
    outputs = ({"--out": args.out, "--plot": args.plot}, {"--out": (".json", ".bvh"), "--plot": (".png",)})
    check_outputs(*outputs, inputs, args.overwrite)
    if args.plot_3d and not args.plot:
        raise UsageError("--plot-3d sets how --plot draws the pose: add --plot pose.png")
    if args.plot:
        plot.require_matplotlib()
    posed = pose_problem(args)
    check_outputs(*outputs, inputs, args.overwrite)  # the files a --problem file names are inputs too
    problem, loaded, frame = posed.problem, posed.loaded, posed.frame
    settings = checked_settings(posed.settings, _settings(args))
    check_device(settings.device)
    _check_precision(args, problem, settings)
    initial = None
    if posed.start is not None:
        count = max(1, settings.population // SEED_FRACTION)
        initial = poses_around(
            problem.skeleton, posed.start, count, seed=settings.seed, memory_limit=settings.memory_limit
        )
        if args.comfort is None and not args.problem:
            near = "the --start pose" if args.start else f"frame {frame}"
            log.info(
                f"note: comfort keeps the pose near {near} (weight {FRAME_COMFORT}, below the "
                "targets); --comfort 0 turns it off"
            )
    if loaded is not None and loaded.kind == "bvh":
        log.info(f"note: masses {loaded.mass_source}")
    prepare_solve(problem, settings, initial)  # compiling first, with its own bar
    with progress_bar(settings.generations, "deik solve", "gen", show_progress(args)) as bar:
        progress = None if bar.disable else (lambda done, best: show_generation(bar, done, best))
        result = solve(problem, settings, initial=initial, progress=progress)
    # the table, the pose file and the picture name one length unit
    unit = length_unit(result.skeleton, loaded.kind if loaded is not None else None)[0]
    rows = [
        [
            r.label,
            shown(float(r.error), r.unit, unit),
            shown(r.tolerance, r.unit, unit) if r.tolerance >= 0 else "-",
            "yes" if r.met else "NO",
        ]
        for r in result.goals
    ]
    # written before anything is printed: a reader that stops early (`| head`) loses no output
    with all_or_nothing():
        if args.out:
            _write_pose(args.out, problem, result, loaded, frame, unit)
        if args.plot:
            spec = args.skeleton_flag or args.skeleton or args.problem
            title = f"deik solve {os.path.basename(str(spec))}"
            plot.plot_result(problem, result, args.plot, title, "3d" if args.plot_3d else "2d", unit)
    print(format_table(["goal", "error", "tolerance", "met"], rows))
    print(
        f"generations {int(result.generations)}  time {result.wall_time:.3f} s  device {result.device}  "
        f"converged {'yes' if result.converged else 'no'}"
    )
    return 0

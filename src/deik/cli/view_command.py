"""`deik view`: a 3-D view in the browser of a solved pose, a clip or a robot, served from this
machine until Ctrl-C (needs deik[view]).

    deik view pose.json                                   # a solved pose, its targets, its centre of mass
    deik view robot.urdf --pose pose.json                 # a robot in a solved pose
    deik view fixed.bvh --compare walk.bvh --report report.json   # a fixed clip over its original
"""

from __future__ import annotations

import argparse
import os
import sys
import webbrowser

from deik.cleanup.units import METRES
from deik.cli.arguments import UsageError, numbers
from deik.io.load import load_skeleton
from deik.io.pose_json import pose_angles, read_pose_json
from deik.viz.body_shapes import character_body, robot_body
from deik.viz.marks import length_unit
from deik.viz.scene import Scene, figure_from_pose_file, figure_from_poses, target_marks, with_compare

DEFAULT_PORT = 8080
DEFAULT_UP = (0.0, 1.0, 0.0)


def add_arguments(v: argparse.ArgumentParser) -> None:
    """The `deik view` flags on subparser `v`."""
    v.add_argument(
        "file",
        metavar="FILE",
        help="pose.json (from `deik solve --out`), a .bvh clip, a .urdf robot, or chain:N, chain3d:N, humanoid",
    )
    v.add_argument("--pose", metavar="pose.json", help="show the skeleton FILE in this solved pose (or batch)")
    v.add_argument(
        "--compare", metavar="OTHER", help="draw OTHER (a .bvh clip or pose.json) in grey: e.g. the clip before a fix"
    )
    v.add_argument(
        "--report", metavar="report.json", help="a clip's `deik clip --json` report: mark its contacts, reach and floor"
    )
    v.add_argument("--segments", metavar="FILE.json", help="BVH: segment masses (default: estimated from bone lengths)")
    v.add_argument("--base", metavar="LINK", help="URDF: the link fixed in the world")
    v.add_argument("--tip", action="append", default=[], metavar="LINK", help="URDF: keep the chain to LINK")
    v.add_argument("--up", nargs=3, metavar=("X", "Y", "Z"), help="URDF: world up direction (default 0 0 1)")
    v.add_argument("--units", choices=sorted(METRES), help="the length unit the view states (default: the file's)")
    v.add_argument("--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1: this machine only)")
    v.add_argument(
        "--port",
        type=int,
        default=DEFAULT_PORT,
        help=f"port (default {DEFAULT_PORT}; the next free one if taken; 0: any free port)",
    )
    v.add_argument("--no-browser", action="store_true", help="print the address instead of opening a browser")


def _pose_file_scene(path: str, units: str | None) -> Scene:
    """The scene of a pose JSON alone: its frames, tree, centre of mass and targets."""
    pose = read_pose_json(path)
    figure = figure_from_pose_file(pose)
    marks, obstacles = target_marks(pose.targets, len(pose.angles))
    unit, source = (units, "given") if units else (pose.length_unit, "the pose file")
    body = character_body(None, figure)
    return Scene(
        os.path.basename(path),
        figure,
        DEFAULT_UP if pose.up is None else pose.up,
        unit or "length units",
        source if unit else "not in the pose file; --units names it",
        step="problem" if pose.batched else "pose",
        marks=marks,
        obstacles=obstacles,
        notes=(body.note,),
        shapes=body.shapes,
    )


def _skeleton_scene(args) -> tuple[Scene, object]:
    """(scene, loaded skeleton) of FILE as a skeleton: a BVH clip's frames, or a skeleton in the
    --pose pose (a batch: one step per problem) or its reference pose."""
    up = numbers("--up", args.up) if args.up else None
    loaded = load_skeleton(args.file, base=args.base, tip=args.tip, segments=args.segments, up=up)
    skeleton = loaded.skeleton
    unit, source = length_unit(skeleton, loaded.kind, args.units)
    # the first clause says where the masses behind the centre of mass come from; the rest is detail
    notes = [f"masses: {loaded.mass_source.split(';')[0]}"] if skeleton.total_mass > 0 else []
    title = os.path.basename(args.file)
    marks, obstacles, step_time = (), (), None
    if args.pose:
        pose = read_pose_json(args.pose)
        angles = pose_angles(pose, skeleton, "--pose")
        marks, obstacles = target_marks(pose.targets, len(angles))
        figure = figure_from_poses(skeleton, angles)
        title = f"{title} in {os.path.basename(args.pose)}"
        step = "problem" if pose.batched else "pose"
    elif loaded.clip is not None:
        figure = figure_from_poses(skeleton, loaded.clip.poses())
        step, step_time = "frame", loaded.clip.frame_time
    else:
        figure, step = figure_from_poses(skeleton, skeleton.reference), "pose"
        notes.append("the reference pose: --pose pose.json shows a solved one")
    body = robot_body(args.file, figure) if loaded.kind == "urdf" else character_body(skeleton, figure)
    scene = Scene(
        title,
        figure,
        skeleton.up,
        unit,
        source,
        step=step,
        step_time=step_time,
        marks=marks,
        obstacles=obstacles,
        notes=(*notes, body.note),
        shapes=body.shapes,
    )
    return scene, loaded


def _compared(path: str, args):
    """The Figure of --compare: a BVH clip's frames or a pose JSON's pose(s)."""
    if path.lower().endswith(".json"):
        return figure_from_pose_file(read_pose_json(path), os.path.basename(path))
    if not path.lower().endswith(".bvh"):
        raise UsageError(f"--compare {path!r}: give a .bvh clip or a pose .json")
    loaded = load_skeleton(path, segments=args.segments)
    return figure_from_poses(loaded.skeleton, loaded.clip.poses(), os.path.basename(path))


def build_scene(args: argparse.Namespace) -> Scene:
    """The Scene the flags describe; UsageError or ValueError naming the flag or file at fault."""
    is_pose_file = args.file.lower().endswith(".json")
    if is_pose_file and any((args.pose, args.segments, args.base, args.tip, args.up)):
        raise UsageError(
            f"{args.file} is a pose JSON and draws itself; --pose and the skeleton flags apply to a "
            ".bvh, .urdf or built-in FILE"
        )
    if is_pose_file:
        scene, loaded = _pose_file_scene(args.file, args.units), None
    else:
        scene, loaded = _skeleton_scene(args)
    if args.report:
        if loaded is None or loaded.clip is None or args.pose:
            raise UsageError("--report marks a clip: give the clip it reports on as FILE (a .bvh), without --pose")
        from deik.viz.report_marks import read_clip_report, with_clip_report

        scene = with_clip_report(scene, read_clip_report(args.report), args.report)
    if args.compare:
        scene = with_compare(scene, _compared(args.compare, args), f"--compare {args.compare}")
    return scene


def _can_open_browser() -> bool:
    """Whether a graphical browser can open here: a display, macOS, Windows, or $BROWSER set
    (without one, Python's webbrowser may start a text browser in this terminal)."""
    shown = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY") or os.environ.get("BROWSER")
    return bool(shown) or sys.platform in ("darwin", "win32")


def run_view(args: argparse.Namespace) -> int:
    """`deik view`: build the scene (every input checked first), serve it, open the browser."""
    from deik.viz.viewer import require_viser, serve

    if not 0 <= args.port <= 65535:
        raise UsageError(f"--port {args.port}: give a port from 1 to 65535 (0: any free port)")
    require_viser()
    scene = build_scene(args)

    def ready(url: str) -> None:
        steps = f", {scene.n_steps} {scene.step}s" if scene.n_steps > 1 else ""
        print(f"deik view: {scene.title}{steps} at {url} (Ctrl-C stops)", flush=True)
        if args.no_browser:
            return
        if not (_can_open_browser() and webbrowser.open(url)):
            print("deik view: no browser to open here; open the address above in one", flush=True)

    try:
        serve(scene, args.host, args.port, on_ready=ready)
    except KeyboardInterrupt:
        print("deik view: stopped", file=sys.stderr)
    return 0

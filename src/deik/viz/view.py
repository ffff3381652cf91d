"""deik.view(): a 3-D view in the browser of a solved pose, a clip or a robot (`deik view`),
served from this machine until Ctrl-C (needs deik[view]).

    deik.view("pose.json")                                             # a solved pose and its targets
    deik.view("robot.urdf", deik.ViewOptions(pose="pose.json"))        # a robot in a solved pose
    deik.view("fixed.bvh", deik.ViewOptions(compare="walk.bvh", report="report.json"))
"""

from __future__ import annotations

import os
import sys
import webbrowser
from collections.abc import Callable
from dataclasses import dataclass

from deik.cleanup.units import METRES
from deik.errors import InputError
from deik.io.load import load_skeleton
from deik.io.pose_json import pose_angles, read_pose_json
from deik.viz.body_shapes import character_body, robot_body
from deik.viz.hosts import check_host
from deik.viz.marks import length_unit
from deik.viz.scene import Scene, figure_from_pose_file, figure_from_poses, target_marks, with_compare

DEFAULT_PORT = 8080
DEFAULT_UP = (0.0, 1.0, 0.0)


@dataclass(frozen=True)
class ViewOptions:
    """What to show with a file (the flags of `deik view`): `pose` a pose.json to show the
    skeleton in (or a batch), `compare` a .bvh clip or pose.json drawn in grey, `report` a
    `deik clip --json` report whose contacts, reach and floor are marked; for the skeleton:
    `segments` (BVH masses), `base`, `tip`, `up` (URDF, as deik.load_skeleton); `units` the
    length unit the view states (default: the file's)."""

    pose: str | None = None
    compare: str | None = None
    report: str | None = None
    segments: str | None = None
    base: str | None = None
    tip: tuple[str, ...] = ()
    up: tuple[float, float, float] | None = None
    units: str | None = None

    def __post_init__(self):
        object.__setattr__(self, "tip", (self.tip,) if isinstance(self.tip, str) else tuple(self.tip or ()))
        if self.units is not None and self.units not in METRES:
            raise InputError(f"--units {self.units!r}: use one of {', '.join(sorted(METRES))}")


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


def _skeleton_scene(file: str, options: ViewOptions) -> tuple[Scene, object]:
    """(scene, loaded skeleton) of `file` as a skeleton: a BVH clip's frames, or a skeleton in the
    pose option's pose (a batch: one step per problem) or its reference pose."""
    loaded = load_skeleton(file, base=options.base, tip=options.tip, segments=options.segments, up=options.up)
    skeleton = loaded.skeleton
    unit, source = length_unit(skeleton, loaded.kind, options.units)
    # the first clause says where the masses behind the centre of mass come from; the rest is detail
    notes = [f"masses: {loaded.mass_source.split(';')[0]}"] if skeleton.total_mass > 0 else []
    title = os.path.basename(file)
    marks, obstacles, step_time = (), (), None
    if options.pose:
        pose = read_pose_json(options.pose)
        angles = pose_angles(pose, skeleton, "--pose")
        marks, obstacles = target_marks(pose.targets, len(angles))
        figure = figure_from_poses(skeleton, angles)
        title = f"{title} in {os.path.basename(options.pose)}"
        step = "problem" if pose.batched else "pose"
    elif loaded.clip is not None and loaded.clip.n_frames:
        figure = figure_from_poses(skeleton, loaded.clip.poses())
        step, step_time = "frame", loaded.clip.frame_time
    elif loaded.clip is not None:  # a hierarchy without motion: its skeleton at rest
        figure, step = figure_from_poses(skeleton, skeleton.reference), "pose"
        notes.append("the clip has no frames (Frames: 0): its skeleton at rest")
    else:
        figure, step = figure_from_poses(skeleton, skeleton.reference), "pose"
        notes.append("the reference pose: --pose pose.json shows a solved one")
    body = robot_body(file, figure) if loaded.kind == "urdf" else character_body(skeleton, figure)
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


def _compared(path: str, segments: str | None):
    """The Figure of the compare option: a BVH clip's frames or a pose JSON's pose(s)."""
    if path.lower().endswith(".json"):
        return figure_from_pose_file(read_pose_json(path), os.path.basename(path))
    if not path.lower().endswith(".bvh"):
        raise InputError(f"--compare {path!r}: give a .bvh clip or a pose .json")
    loaded = load_skeleton(path, segments=segments)
    return figure_from_poses(loaded.skeleton, loaded.clip.poses(), os.path.basename(path))


def view_scene(file: str, options: ViewOptions | None = None) -> Scene:
    """The Scene deik.view shows of `file` (a pose.json, a .bvh clip, a .urdf robot, or
    "chain:N", "chain3d:N", "humanoid") with `options`; InputError naming the option or file at fault."""
    options = ViewOptions() if options is None else options
    file = str(file)
    is_pose_file = file.lower().endswith(".json")
    if is_pose_file and any((options.pose, options.segments, options.base, options.tip, options.up)):
        raise InputError(
            f"{file} is a pose JSON and draws itself; --pose and the skeleton flags apply to a "
            ".bvh, .urdf or built-in FILE"
        )
    if is_pose_file:
        scene, loaded = _pose_file_scene(file, options.units), None
    else:
        scene, loaded = _skeleton_scene(file, options)
    if options.report:
        if loaded is None or loaded.clip is None or options.pose:
            raise InputError("--report marks a clip: give the clip it reports on as FILE (a .bvh), without --pose")
        from deik.viz.report_marks import read_clip_report, with_clip_report

        scene = with_clip_report(scene, read_clip_report(options.report), options.report)
    if options.compare:
        scene = with_compare(scene, _compared(options.compare, options.segments), f"--compare {options.compare}")
    return scene


def can_open_browser() -> bool:
    """Whether a graphical browser can open here: a display, macOS, Windows, or $BROWSER set
    (without one, Python's webbrowser may start a text browser in this terminal)."""
    shown = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY") or os.environ.get("BROWSER")
    return bool(shown) or sys.platform in ("darwin", "win32")


def view(
    file: str,
    options: ViewOptions | None = None,
    *,
    host: str = "127.0.0.1",
    port: int = DEFAULT_PORT,
    browser: bool = True,
    on_ready: Callable[[str, Scene], object] | None = None,
) -> None:
    """Show `file` with `options` (view_scene) in the browser: serve it at http://host:port
    (the next free port when that one is taken; 0: any free port) until Ctrl-C, opening a
    browser where one can open when `browser`; `on_ready(url, scene)` is called once the page
    loads. Every input is checked before serving (InputError); ImportError without deik[view]."""
    from deik.viz.viewer import require_viser, serve

    if not 0 <= port <= 65535:
        raise InputError(f"--port {port}: give a port from 1 to 65535 (0: any free port)")
    check_host(host)
    require_viser()
    scene = view_scene(file, options)

    def ready(url: str) -> None:
        if on_ready is not None:
            on_ready(url, scene)
        if browser and can_open_browser():
            webbrowser.open(url)

    serve(scene, host, port, on_ready=ready)

"""`deik view`: a 3-D view in the browser of a solved pose, a clip or a robot, served from this
machine until Ctrl-C (needs deik[view]).

    deik view pose.json                                   # a solved pose, its targets, its centre of mass
    deik view robot.urdf --pose pose.json                 # a robot in a solved pose
    deik view fixed.bvh --compare walk.bvh --report report.json   # a fixed clip over its original
"""

from __future__ import annotations

import argparse
import sys
import webbrowser

from deik.cleanup.units import METRES
from deik.cli.arguments import add_up, up_of
from deik.viz.scene import Scene
from deik.viz.view import DEFAULT_PORT, ViewOptions, can_open_browser, view, view_scene


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
    add_up(v)
    v.add_argument("--units", choices=sorted(METRES), help="the length unit the view states (default: the file's)")
    v.add_argument("--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1: this machine only)")
    v.add_argument(
        "--port",
        type=int,
        default=DEFAULT_PORT,
        help=f"port (default {DEFAULT_PORT}; the next free one if taken; 0: any free port)",
    )
    v.add_argument("--no-browser", action="store_true", help="print the address instead of opening a browser")


def view_options(args: argparse.Namespace) -> ViewOptions:
    """The ViewOptions of `deik view`'s flags."""
    up = up_of(args)
    names = ("pose", "compare", "report", "segments", "base", "tip", "units")
    return ViewOptions(up=up, **{name: getattr(args, name) for name in names})


def build_scene(args: argparse.Namespace) -> Scene:
    """The Scene the flags describe (deik.viz.view.view_scene); InputError naming the flag or file at fault."""
    return view_scene(args.file, view_options(args))


def run_view(args: argparse.Namespace) -> int:
    """`deik view`: build the scene (every input checked first), serve it (deik.view), open the browser."""

    def ready(url: str, scene: Scene) -> None:
        steps = f", {scene.n_steps} {scene.step}s" if scene.n_steps > 1 else ""
        print(f"deik view: {scene.title}{steps} at {url} (Ctrl-C stops)", flush=True)
        if args.no_browser:
            return
        if not (can_open_browser() and webbrowser.open(url)):
            print("deik view: no browser to open here; open the address above in one", flush=True)

    try:
        view(args.file, view_options(args), host=args.host, port=args.port, browser=False, on_ready=ready)
    except KeyboardInterrupt:
        print("deik view: stopped", file=sys.stderr)
    return 0

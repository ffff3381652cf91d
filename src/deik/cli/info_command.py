"""`deik info`: a skeleton described in text (deik.describe_skeleton's record): joint tree, DOFs
and limits, masses and sites."""

from __future__ import annotations

import argparse
import contextlib
import math

from deik.cli.arguments import up_of
from deik.errors import InputError
from deik.io.describe import describe_skeleton
from deik.io.load import load_skeleton
from deik.viz.marks import length_unit
from deik.viz.text import cut_lines, format_table


def _number(value: float) -> str:
    return f"{value:.6g}"


def _dof_cells(dof: dict) -> list[str]:
    """Name, motion and axis, and limits of one DOF (degrees for rotations, length units otherwise)."""
    scale, unit = (180.0 / math.pi, "deg") if dof["kind"] == "rotate" else (1.0, "")
    bound = lambda v: _number(v * scale) if math.isfinite(v) else ("-inf" if v < 0 else "inf")  # noqa: E731
    axis = " ".join(map(_number, dof["axis"]))
    return [dof["name"], f"{dof['kind']} ({axis})", f"{bound(dof['lower'])} .. {bound(dof['upper'])} {unit}".rstrip()]


MAX_INDENT = 32  # levels of the joint tree indented; deeper joints say their depth


def _joint_line(joint: dict) -> str:
    """One joint of the tree, indented by depth, with the URDF joint that moves it where its
    name differs (the key of its values in a pose), its DOF count and sites."""
    notes = (
        ([f"moved by joint {joint['label']}"] if joint["label"] != joint["name"] else [])
        + [f"{joint['dofs']} DOF"]
        + ([f"{joint['mimics']} mimic"] if joint["mimics"] else [])
        + ([f"sites: {', '.join(joint['sites'])}"] if joint["sites"] else [])
    )
    depth = joint["depth"]  # a long chain's tree stops indenting: its text would grow with depth squared
    indent = "  " * depth if depth <= MAX_INDENT else "  " * MAX_INDENT + f"[depth {depth}] "
    return f"{indent}{joint['name']}  ({'; '.join(notes)})"


CUT_FATES = (
    "deik clip writes it back as captured, deik retarget holds the motion's nearest frame there",
    "deik clip and deik retarget blend across it",
    "deik clip and deik retarget work across as one motion",
)
NO_CUTS = {"kept_frames": [], "bridged_frames": [], "between_takes": []}


def format_info(info: dict, source: str, unit: tuple[str, str] = ("length units", "the skeleton's own")) -> str:
    """The text `deik info` prints of describe_skeleton's record `info` of `source`, lengths in
    `unit` (name, where it comes from: deik.viz.marks.length_unit)."""
    mimics = f" (+{len(info['mimics'])} mimic)" if info["mimics"] else ""
    lines = [
        f"{source}: {info['kind']} skeleton {info['name']!r}",
        f"{info['joint_count']} joints, {info['dof_count']} DOFs{mimics}, {info['site_count']} sites, "
        f"reach {_number(info['reach'])} {unit[0]}, up {tuple(info['up'])}",
        f"lengths in {unit[0]}: {unit[1]}",
        f"mass: {_number(info['mass_kg'])} kg, {info['mass_source']}",
    ]
    if info["clip"] is not None:
        lines.append(f"clip: {info['clip']['frames']} frames, {info['clip']['frame_time_s']:g} s per frame")
        lines += ["  " + line for line in cut_lines(info["clip"].get("cuts") or NO_CUTS, CUT_FATES)]
    lines += ["", "joint tree:"] + ["  " + _joint_line(joint) for joint in info["joints"]]
    lines += ["", format_table(["DOF", "motion (axis)", "limits"], [_dof_cells(dof) for dof in info["dofs"]])]
    tables = (
        ("mimics", ["mimic DOF", "follows", "multiplier", "offset"], ("name", "follows", "multiplier", "offset")),
        ("masses", ["mass on joint", "kg", "centre (joint frame)"], ("joint", "kg", "centre")),
        ("sites", ["site", "on joint", "offset"], ("name", "joint", "offset")),
    )
    for key, header, fields in tables:
        if info[key]:
            rows = [[_cell(entry[field]) for field in fields] for entry in info[key]]
            lines += ["", format_table(header, rows)]
    return "\n".join(lines)


def _cell(value) -> str:
    """A table cell: a name as it is, a number to 6 digits, a vector's numbers side by side."""
    if isinstance(value, str):
        return value
    if isinstance(value, list):
        return " ".join(map(_number, value))
    return _number(value)


def run_info(args: argparse.Namespace) -> int:
    """`deik info`: print the joint tree, DOFs and limits, masses and sites of a skeleton."""
    up = up_of(args)
    loaded = load_skeleton(args.skeleton, base=args.base, tip=args.tip, segments=args.segments, up=up)
    info = describe_skeleton(loaded)
    if loaded.clip is not None and loaded.clip.n_frames > 1:
        from deik.cleanup.body import body_of, with_helpers
        from deik.cleanup.cuts import find_cuts

        with contextlib.suppress(InputError):  # a clip with no body (every bone of zero length) has no cuts
            info["clip"]["cuts"] = find_cuts(loaded.clip, body_of(with_helpers(loaded.clip)).span).record()
    print(format_info(info, args.skeleton, length_unit(loaded.skeleton, loaded.kind)))
    return 0

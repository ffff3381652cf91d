"""Write a Clip as a BVH file: the clip's hierarchy, OFFSETs and channel layout, degrees in the
file, written atomically (a failed write leaves no file and no temporary file).

Frame values are written with 6 decimals (0.5e-6 degrees or length units at most off), position
channels of a skeleton under a length unit long with more (a body scaled to millimetres of a
metre keeps its precision); offsets and the frame time are written exactly.
"""

from __future__ import annotations

import math

from deik.io.atomic import write_text_atomically
from deik.io.files import FilePath
from deik.io.motion import Clip
from deik.model.joints import ROTATE


def _exact(value: float) -> str:
    """Six decimals when they give `value` back exactly, else the shortest exact form."""
    text = f"{value:.6f}"
    return text if float(text) == value else repr(float(value))


def format_bvh(clip: Clip) -> str:
    """The BVH text of `clip`: its hierarchy in layout order, then N frame lines of C numbers
    (degrees for rotation channels, length units for position channels)."""
    sk = clip.skeleton
    entries = {entry.name: entry for entry in clip.layout}
    offsets = dict(zip(sk.joint_names, sk.offsets))
    site_offsets = dict(zip(sk.site_names, sk.site_offset))
    lines = ["HIERARCHY"]
    stack = [("joint", clip.layout[0].name, 0)]
    while stack:
        kind, name, depth = stack.pop()
        pad = "\t" * depth
        if kind == "close":
            lines.append(f"{pad}}}")
        elif kind == "site":
            lines += [
                f"{pad}End Site",
                f"{pad}{{",
                f"{pad}\tOFFSET {' '.join(map(_exact, site_offsets[name]))}",
                f"{pad}}}",
            ]
        else:
            entry = entries[name]
            lines += [
                f"{pad}{'ROOT' if depth == 0 else 'JOINT'} {name}",
                f"{pad}{{",
                f"{pad}\tOFFSET {' '.join(map(_exact, offsets[name]))}",
                f"{pad}\tCHANNELS {len(entry.channels)} {' '.join(entry.channels)}".rstrip(),
            ]
            stack.append(("close", name, depth))
            stack += [
                ("site" if child in site_offsets else "joint", child, depth + 1) for child in reversed(entry.children)
            ]
    lines += ["MOTION", f"Frames: {clip.n_frames}", f"Frame Time: {_exact(clip.frame_time)}"]
    if clip.channel_dofs.size:
        size = sk.reach if math.isfinite(sk.reach) else 1.0  # a free prismatic DOF reaches without end
        small = max(0, math.ceil(-math.log10(max(size, 1e-300))))  # extra decimals for a tiny body
        position = sk.dof_kind[clip.channel_dofs] != ROTATE
        formats = [f"{{:.{6 + small * bool(moves)}f}}" for moves in position]
        lines += [" ".join(form.format(v) for form, v in zip(formats, row)) for row in clip.channel_values()]
    return "\n".join(lines) + "\n"


def write_bvh(path: FilePath, clip: Clip) -> None:
    """Write `clip` to `path` as BVH, atomically: `path` is the old file or the whole new one."""
    if not isinstance(clip, Clip):
        raise TypeError(f"write_bvh writes a deik.Clip (deik.read_bvh, a fix's .clip), got {type(clip).__name__}")
    write_text_atomically(path, format_bvh(clip))

"""Read BVH motion files into a Clip: a Skeleton, its frames and the file's channel layout.

HIERARCHY holds one ROOT with nested JOINT and End Site blocks (OFFSET x y z; CHANNELS n
names); MOTION holds "Frames: N", "Frame Time: t" and N lines of numbers. Position channels may
sit on any joint, anywhere among its rotations: they become the joint's first DOFs (BVH moves
them along the parent's axes), its rotations follow in file order. Below the root they are
displacements from the joint's OFFSET, or its whole local position where every frame repeats
the OFFSET (_local_positions); below the first joint that translates they are held at the
capture's values unless freed (_translation_limits). Lengths keep the file's unit; degrees
become radians. Every malformed input raises FileFormatError naming file and line.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import BinaryIO

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import FileFormatError
from deik.io.bvh.frames import FrameReader
from deik.io.bvh.hierarchy import FRAME_TIME, FRAMES, Hierarchy, Node, number
from deik.io.files import FilePath, open_input
from deik.io.motion import CHANNELS, Clip, JointChannels
from deik.io.segments import estimate_segments, read_segment_table
from deik.model.build import build_skeleton
from deik.model.geometry import unit_up
from deik.model.joints import ROTATE, Joint, Site, euler, translation

MIN_FRAME_TIME, MAX_FRAME_TIME = 1e-6, 3600.0  # seconds: a megahertz capture to one frame an hour
LOCAL_TOLERANCE = 0.01  # of a bone's OFFSET: position channels this close to it in every frame repeat it
BVH_UP = (0.0, 1.0, 0.0)  # the BVH convention: Y up
MAX_HIERARCHY_BYTES = 16 << 20  # the HIERARCHY section: a 100,000-joint skeleton takes about 10 MB


def _lines(file: BinaryIO, source: str, first: int = 1):
    """(line number, text) of each line of `file` from line `first`, decoded (a byte-order mark
    allowed on line 1), lines ending in LF or CR LF; FileFormatError at a NUL byte, bytes that
    are not UTF-8 or lines ending in CR alone."""
    n = first - 1
    for raw in iter(file.readline, b""):
        if n == 0:
            raw = raw.removeprefix(b"\xef\xbb\xbf")
        if b"\0" in raw:
            raise FileFormatError(source, "not a text BVH file (NUL bytes)", line=n + 1)
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            raise FileFormatError(source, "not a text BVH file (bytes that are not UTF-8)", line=n + 1) from None
        n += 1
        text = text.removesuffix("\n").removesuffix("\r")
        if "\r" in text:
            raise FileFormatError(
                source,
                "its lines end in CR alone, as classic Mac OS wrote them: convert them to LF "
                "(tr '\\r' '\\n' < IN > OUT)",
                line=n,
            )
        yield n, text


def _hierarchy(file: BinaryIO, source: str) -> tuple[list[str], int | None]:
    """(the lines before MOTION, the line number of MOTION or None when the file has none)."""
    lines, size = [], 0
    for n, text in _lines(file, source):
        if [w.upper() for w in text.split()[:1]] == ["MOTION"]:
            if len(text.split()) != 1:
                raise FileFormatError(source, "MOTION must stand alone on its line", line=n)
            return lines, n
        size += len(text) + 1
        if size > MAX_HIERARCHY_BYTES:
            raise FileFormatError(
                source, f"the HIERARCHY section is over {MAX_HIERARCHY_BYTES} bytes: not a skeleton", line=n
            )
        lines.append(text)
    return lines, None


def _header(source: str, lines, motion: int) -> tuple[int, float, int, int]:
    """(frame count, frame time in s, the line of 'Frames:', the line of 'Frame Time:') of the
    two header lines after MOTION."""
    body = []
    for n, text in lines:
        if text.strip():
            body.append((n, text.strip()))
            if len(body) == 2:
                break
    header = [
        FRAMES.fullmatch(body[0][1]) if body else None,
        FRAME_TIME.fullmatch(body[1][1]) if len(body) > 1 else None,
    ]
    if header[0] is None or not (header[0][1].isascii() and header[0][1].isdigit()):
        raise FileFormatError(
            source, "expected 'Frames: N' (N a whole number) after MOTION", line=body[0][0] if body else motion
        )
    if len(header[0][1]) > 12:
        raise FileFormatError(
            source,
            f"'Frames: {header[0][1]}' is more frames than any capture holds (at most 12 digits)",
            line=body[0][0],
        )
    if header[1] is None:
        raise FileFormatError(
            source, "expected 'Frame Time: seconds' after 'Frames:'", line=body[min(1, len(body) - 1)][0]
        )
    time_line = body[1][0]
    frame_time = number(source, header[1][1], time_line, "Frame Time")
    if not MIN_FRAME_TIME <= frame_time <= MAX_FRAME_TIME:
        raise FileFormatError(
            source,
            f"Frame Time must lie between {MIN_FRAME_TIME:g} and {MAX_FRAME_TIME:g} seconds, got {header[1][1]}",
            line=time_line,
        )
    return int(header[0][1]), frame_time, body[0][0], time_line


def _site_names(nodes: list[Node]) -> dict[int, str]:
    """End Site node index -> f"{joint}_end", then "_end2", ..., never a joint's name."""
    taken, names = {n.name for n in nodes if not n.is_site}, {}
    for k, node in enumerate(nodes):
        if node.is_site:
            number = 1
            while (name := f"{node.name}_end{number if number > 1 else ''}") in taken:
                number += 1
            taken.add(name)
            names[k] = name
    return names


def _skeleton(source, nodes, site_names, limits, segments=(), up=BVH_UP):
    """Build the Skeleton; translation DOFs get `limits[(node, channel)]`, rotations [-pi, pi];
    `up` (3,) the world's up direction."""
    joints, sites = [], []
    for k, node in enumerate(nodes):
        parent = nodes[node.parent].name if node.parent >= 0 else None
        if node.is_site:
            sites.append(Site(site_names[k], parent, node.offset))
            continue
        channels = node.channels or ()
        dofs = tuple(translation(c[0], *limits[(k, c)])[0] for c in channels if c.endswith("position"))
        rotations = "".join(c[0] for c in channels if c.endswith("rotation"))
        dofs += euler(rotations) if rotations else ()
        joints.append(Joint(node.name, parent, node.offset, dofs))
    try:  # a safety net: the checks above leave build_skeleton nothing to reject
        return build_skeleton(joints, sites, segments, up=up, name=Path(source).stem or "bvh")
    except ValueError as error:
        raise FileFormatError(source, f"invalid skeleton: {error}") from None


def _local_positions(nodes: list[Node], columns: list[tuple[int, str]], values: np.ndarray) -> set[int]:
    """The joints (node indices, the root aside) whose position channels hold their whole local
    position rather than a displacement from their OFFSET: every such joint when the file writes
    them so, which it shows by repeating the OFFSET (within LOCAL_TOLERANCE of its length, every
    frame, on every axis the OFFSET uses) in the channels of at least half the joints that have
    both (MotionBuilder and other exporters write such files; reading them as displacements would
    double every bone); else none."""
    moving, repeating = [], 0
    for k, node in enumerate(nodes):
        if node.parent < 0 or node.is_site or not any(c.endswith("position") for c in node.channels or ()):
            continue
        moving.append(k)
        offset = np.asarray(node.offset, float)
        axes = {CHANNELS[c][1]: columns.index((k, c)) for c in node.channels if c.endswith("position")}
        size = float(np.linalg.norm(offset))
        if size == 0 or any(offset[a] != 0 and a not in axes for a in range(3)) or not len(values):
            continue
        gap = np.stack([values[:, column] - offset[axis] for axis, column in axes.items()], axis=1)
        repeating += bool(np.linalg.norm(gap, axis=1).max() <= LOCAL_TOLERANCE * size)
    return set(moving) if repeating and 2 * repeating >= len(moving) else set()


def _translation_limits(nodes, columns, values, local: set[int], free: bool, size_of) -> dict:
    """Limits of every position channel's DOF {(node, channel): (lower, upper)}, DOF values being
    the channel values less the OFFSET's component for `local` joints: the capture's exact range
    for the joints below the first that translates on each path from the root (held, so bones
    keep their lengths), that range widened by the body's size (`size_of(spans)`) for the first
    ones (they carry the body through the world) and for all of them when `free`."""
    spans = {}
    for j, (k, channel) in enumerate(columns):
        if channel.endswith("position"):
            bias = nodes[k].offset[CHANNELS[channel][1]] if k in local else 0.0
            column = values[:, j] - bias
            spans[(k, channel)] = (column.min(), column.max()) if len(column) else (0.0, 0.0)
    size = size_of(spans)

    def carried(k: int) -> bool:  # a joint whose ancestors have no position channel
        parent = nodes[k].parent
        while parent >= 0:
            if any(c.endswith("position") for c in nodes[parent].channels or ()):
                return False
            parent = nodes[parent].parent
        return True

    return {
        (k, channel): (lo - size, hi + size) if free or carried(k) else (lo, hi)
        for (k, channel), (lo, hi) in spans.items()
    }


def parse_bvh(
    text: str | bytes,
    source: str = "<string>",
    segments: FilePath | None = None,
    free_translations: bool = False,
    up: ArrayLike | None = None,
) -> Clip:
    """Parse BVH `text` (str or bytes) named `source` into a Clip.

    `segments`: a segment table path (JSON, see read_segment_table) or None to estimate masses
    from bone lengths; clip.mass_source says which. Frames (N, D) are radians / file length
    units in skeleton DOF order. Position channels below the first joint that translates are held
    at the capture's values (their limits are its exact range, so solves and clip fixes keep the
    bones' lengths) unless `free_translations`; docs/formats.md says how they are read. `up`
    (3,): the world's up direction, default +Y (the BVH convention). Raises
    FileFormatError naming `source` and the line.
    """
    data = text.encode("utf-8") if isinstance(text, str) else text
    return _read(io.BytesIO(data), len(data), source, (segments, free_translations, up))


def read_bvh(
    path: FilePath, segments: FilePath | None = None, free_translations: bool = False, up: ArrayLike | None = None
) -> Clip:
    """Read the BVH file at `path` into a Clip (see parse_bvh), streaming its frames (never the
    whole file in memory; deik.io.bvh.frames); `segments` a table path or None;
    `free_translations` lets solves move the position channels below the first joint that
    translates (by default they keep the capture's values); `up` (3,) the world's up direction
    (default +Y, the BVH convention; 0 0 1 for a file made with Z up).

    A path that cannot be read (missing, a folder or device, too large) or a malformed file,
    or a clip too large for the memory limit, raises FileFormatError naming it (and the line).
    """
    with open_input(path, "BVH") as (file, size):
        return _read(file, size, str(path), (segments, free_translations, up))


def _read(file: BinaryIO, size: int, source: str, options: tuple[FilePath | None, bool, ArrayLike | None]) -> Clip:
    """The Clip of the BVH in binary `file` of `size` bytes (see parse_bvh); `options`:
    (segments, free_translations, up)."""
    segments, free_translations, up = options
    up = BVH_UP if up is None else unit_up(up)
    lines, motion = _hierarchy(file, source)
    last = max((n for n, line in enumerate(lines, 1) if line.strip()), default=None)
    if last is None and motion is None:
        raise FileFormatError(source, "empty file: a BVH file starts with HIERARCHY", line=1)
    nodes = Hierarchy(source, lines, motion or last).parse()
    if motion is None:
        raise FileFormatError(source, "no MOTION section after the hierarchy", line=last)
    joint_nodes = [k for k, node in enumerate(nodes) if not node.is_site]
    columns = [(k, c) for k in joint_nodes for c in nodes[k].channels or ()]
    count, frame_time, frames_line, time_line = _header(source, _lines(file, source, motion + 1), motion)
    values = FrameReader(source, file, size, time_line + 1).read(count, len(columns), frames_line)
    site_names = _site_names(nodes)
    local = _local_positions(nodes, columns, values)

    def size_of(spans):  # the longest root-to-frame path, slides at the capture's extremes
        return _skeleton(source, nodes, site_names, spans).reach

    limits = _translation_limits(nodes, columns, values, local, free_translations, size_of)
    bare = _skeleton(source, nodes, site_names, limits)
    if segments is None:
        masses, mass_source = estimate_segments(bare)
    else:
        masses, mass_source = read_segment_table(segments, bare.joint_names)
    skeleton = _skeleton(source, nodes, site_names, limits, masses, up)
    first_dof = dict(zip(skeleton.joint_names, skeleton.joint_dof_start.tolist()))
    layout = []
    for k in joint_nodes:
        node, channels = nodes[k], nodes[k].channels or ()
        # positions first, then rotations, each in file order: channel i is DOF order.index(i)
        order = sorted(range(len(channels)), key=lambda i: CHANNELS[channels[i]][0] == ROTATE)
        dofs = tuple(first_dof[node.name] + order.index(i) for i in range(len(channels)))
        children = tuple(site_names.get(c, nodes[c].name) for c in node.children)
        layout.append(JointChannels(node.name, channels, dofs, children, k in local))
    return Clip.from_channel_values(skeleton, layout, values, frame_time, source, mass_source)

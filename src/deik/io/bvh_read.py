"""Read BVH motion files into a Clip: a Skeleton, its frames and the file's channel layout.

HIERARCHY holds one ROOT with nested JOINT and End Site blocks (OFFSET x y z; CHANNELS n
names); MOTION holds "Frames: N", "Frame Time: t" and N lines of numbers. Position channels may
sit on any joint, anywhere among its rotations: they become the joint's first DOFs (BVH moves
them along the parent's axes), its rotations follow in file order. Lengths keep the file's
unit; degrees become radians. Every malformed input raises FileFormatError naming file and line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from deik.io.clip import CHANNELS, Clip, JointChannels
from deik.io.errors import FileFormatError
from deik.io.segments import estimate_segments, read_segment_table
from deik.joints import ROTATE, Joint, Site, build_skeleton, euler, translation

MAX_MAGNITUDE = 1e12  # larger numbers are taken for corruption: they would overflow the maths
NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
NUMBER_LINE = re.compile(r"[0-9eE+\-.\s]*")
TOKEN = re.compile(r"[{}]|[^\s{}]+")
FRAMES = re.compile(r"frames\s*:\s*(\S*)", re.IGNORECASE)
FRAME_TIME = re.compile(r"frame\s+time\s*:\s*(\S*)", re.IGNORECASE)
CHANNEL_NAMES = {name.lower(): name for name in CHANNELS}


@dataclass
class _Node:
    """A JOINT, ROOT or End Site block while it is parsed; `parent` indexes the node list."""

    name: str
    parent: int
    line: int
    is_site: bool
    offset: tuple | None = None
    channels: tuple[str, ...] | None = None
    children: list[int] = field(default_factory=list)

    def describe(self) -> str:
        return f"End Site of {self.name!r}" if self.is_site else f"joint {self.name!r}"


def _show(token: str) -> str:
    return repr(token if len(token) <= 40 else token[:37] + "...")


def _number(source: str, token: str, line: int, what: str) -> float:
    """`token` as a finite float of at most MAX_MAGNITUDE, else FileFormatError."""
    if NUMBER.fullmatch(token):
        value = float(token)
        if abs(value) <= MAX_MAGNITUDE:
            return value
        problem = f"{what} {_show(token)} is beyond +-{MAX_MAGNITUDE:g}"
    elif token.lower().lstrip("+-") in ("nan", "inf", "infinity"):
        problem = f"{what} is {token}: NaN and infinite values are not allowed"
    else:
        problem = f"{what} {_show(token)} is not a number"
    raise FileFormatError(source, problem, line=line)


def _decode(data: bytes | str, source: str) -> str:
    """Text of a BVH file; NUL bytes or bytes that are not UTF-8 mean a binary file."""
    if isinstance(data, bytes):
        try:
            data = data.decode("utf-8-sig")
        except UnicodeDecodeError as error:
            line = data.count(b"\n", 0, error.start) + 1
            raise FileFormatError(source, "not a text BVH file (bytes that are not UTF-8)",
                                  line=line) from None
    if "\x00" in data:
        line = data.count("\n", 0, data.index("\x00")) + 1
        raise FileFormatError(source, "not a text BVH file (NUL bytes)", line=line)
    return data.removeprefix("\ufeff")


class _Hierarchy:
    """Parser of the HIERARCHY section (the lines before MOTION) into _Node blocks."""

    def __init__(self, source: str, lines: list[str], end_line: int):
        self.source, self.end_line = source, end_line
        self.tokens = [(t, n) for n, text in enumerate(lines, 1) for t in TOKEN.findall(text)]
        self.nodes: list[_Node] = []
        self.open: list[int] = []  # indices of the blocks not yet closed, innermost last
        self.first_line: dict[str, int] = {}  # joint name -> line that declared it

    def fail(self, problem: str, line: int):
        raise FileFormatError(self.source, problem, line=line)

    def rest_of_line(self, pos: int, line: int) -> tuple[list[str], int]:
        """Words from token `pos` to the end of `line` or the next brace, and the next position."""
        end = pos
        while (end < len(self.tokens) and self.tokens[end][1] == line
               and self.tokens[end][0] not in ("{", "}")):
            end += 1
        return [t for t, _ in self.tokens[pos:end]], end

    def parse(self) -> list[_Node]:
        """Blocks in file order; FileFormatError at the first problem."""
        tokens = self.tokens
        if not tokens or tokens[0][0].upper() != "HIERARCHY":
            self.fail("a BVH file must start with HIERARCHY",
                      tokens[0][1] if tokens else self.end_line)
        pos = self.rest_of_line(1, tokens[0][1])[1]
        if pos != 1:
            self.fail("HIERARCHY must stand alone on its line", tokens[0][1])
        handlers = {"ROOT": self.block, "JOINT": self.block, "END": self.block,
                    "OFFSET": self.offset, "CHANNELS": self.channels, "}": self.close}
        while pos < len(tokens):
            word, line = tokens[pos]
            if self.nodes and not self.open:
                self.fail(f"unexpected {_show(word)} after the ROOT block closed; a BVH file has "
                          "one ROOT and MOTION starts its own line", line)
            top = self.nodes[self.open[-1]] if self.open else None
            rest, pos = ([], pos + 1) if word in ("{", "}") else self.rest_of_line(pos + 1, line)
            handler = handlers.get(word.upper())
            if handler is None or (top is None and handler != self.block):
                self.fail(f"unknown keyword {_show(word)} here; expected OFFSET, CHANNELS, JOINT, "
                          "End Site or '}'" if top else f"unexpected {_show(word)}; expected ROOT",
                          line)
            pos = handler(word, rest, line, top, pos)
        if not self.nodes:
            self.fail("the hierarchy has no ROOT", self.end_line)
        if self.open:
            node = self.nodes[self.open[-1]]
            self.fail(f"the hierarchy ends inside {node.describe()} opened at line {node.line}: "
                      "missing '}'", self.end_line)
        return self.nodes

    def block(self, word, rest, line, top, pos) -> int:
        """ROOT name / JOINT name / End Site, then '{': open a block."""
        key = word.upper()
        if (key == "ROOT") != (top is None):
            self.fail("ROOT inside a joint: use JOINT" if key == "ROOT"
                      else "ROOT must come first, once; JOINTs go inside it", line)
        if top is not None and top.is_site:
            self.fail("an End Site cannot have children", line)
        if key == "END" and [r.upper() for r in rest] != ["SITE"]:
            self.fail("expected 'End Site'", line)
        if key != "END" and len(rest) != 1:
            self.fail(f"{word} needs one name on its line, found {len(rest)} words", line)
        name = top.name if key == "END" else rest[0]
        if key != "END" and name in self.first_line:
            self.fail(f"duplicate joint name {_show(name)} (first at line "
                      f"{self.first_line[name]})", line)
        if pos >= len(self.tokens) or self.tokens[pos][0] != "{":
            self.fail(f"expected '{{' to open {word} {_show(name)}", line)
        if key != "END":
            self.first_line[name] = line
        if top is not None:
            top.children.append(len(self.nodes))
        parent = self.open[-1] if self.open else -1
        self.open.append(len(self.nodes))
        self.nodes.append(_Node(name, parent, line, key == "END"))
        return pos + 1

    def offset(self, word, rest, line, top, pos) -> int:
        """OFFSET x y z of the innermost block."""
        if top.offset is not None:
            self.fail(f"second OFFSET in {top.describe()}", line)
        if len(rest) != 3:
            self.fail(f"OFFSET needs 3 numbers (x y z), found {len(rest)}", line)
        top.offset = tuple(_number(self.source, t, line, "OFFSET value") for t in rest)
        return pos

    def channels(self, word, rest, line, top, pos) -> int:
        """CHANNELS n name... of the innermost joint, names made canonical."""
        if top.is_site or top.channels is not None:
            self.fail(f"an End Site cannot have CHANNELS ({top.describe()})" if top.is_site
                      else f"second CHANNELS in {top.describe()}", line)
        if not rest or not (rest[0].isascii() and rest[0].isdigit()):
            self.fail("CHANNELS needs a count then the channel names", line)
        count, names = int(rest[0]), rest[1:]
        if count != len(names):
            self.fail(f"CHANNELS says {count} channels but names {len(names)}", line)
        channels = []
        for name in names:
            if name.lower() not in CHANNEL_NAMES:
                self.fail(f"unknown channel {_show(name)}; channels are {', '.join(CHANNELS)}",
                          line)
            if CHANNEL_NAMES[name.lower()] in channels:
                self.fail(f"duplicate channel {name} in {top.describe()}", line)
            channels.append(CHANNEL_NAMES[name.lower()])
        top.channels = tuple(channels)
        return pos

    def close(self, word, rest, line, top, pos) -> int:
        """'}': close the innermost block, which must have had its OFFSET."""
        if top.offset is None:
            self.fail(f"{top.describe()} (line {top.line}) has no OFFSET", line)
        self.open.pop()
        return pos


def _frame_row(source: str, text: str, line: int, expected: int) -> list[float]:
    words = text.split()
    if len(words) != expected:
        raise FileFormatError(source, f"frame has {len(words)} numbers, expected {expected} "
                                      "(one per channel)", line=line)
    if NUMBER_LINE.fullmatch(text):
        try:
            row = [float(w) for w in words]
            if all(abs(v) <= MAX_MAGNITUDE for v in row):
                return row
        except ValueError:
            pass
    return [_number(source, w, line, f"channel {k + 1}") for k, w in enumerate(words)]


def _parse_motion(source: str, lines: list[str], motion: int, n_channels: int):
    """(values (N, C) in file order and units, frame time in s) from lines after MOTION."""
    def fail(problem, line):
        raise FileFormatError(source, problem, line=line)

    if len(lines[motion - 1].split()) != 1:
        fail("MOTION must stand alone on its line", motion)
    body = [(n, text.strip()) for n, text in enumerate(lines[motion:], motion + 1) if text.strip()]
    header = [FRAMES.fullmatch(body[0][1]) if body else None,
              FRAME_TIME.fullmatch(body[1][1]) if len(body) > 1 else None]
    if header[0] is None or not (header[0][1].isascii() and header[0][1].isdigit()):
        fail("expected 'Frames: N' (N a whole number) after MOTION",
             body[0][0] if body else motion)
    if header[1] is None:
        fail("expected 'Frame Time: seconds' after 'Frames:'", body[min(1, len(body) - 1)][0])
    count, frames_line, time_line = int(header[0][1]), body[0][0], body[1][0]
    frame_time = _number(source, header[1][1], time_line, "Frame Time")
    if frame_time <= 0:
        fail(f"Frame Time must be positive seconds, got {header[1][1]}", time_line)
    rows = body[2:]
    if n_channels == 0 and rows:
        fail("frame numbers given but the hierarchy has no channels", rows[0][0])
    if n_channels == 0:
        return np.zeros((count, 0)), frame_time
    values = [_frame_row(source, text, n, n_channels) for n, text in rows[:count]]
    if len(rows) > count:
        fail(f"more frame lines than 'Frames: {count}' (line {frames_line}) says", rows[count][0])
    if len(rows) < count:
        fail(f"'Frames: {count}' but only {len(rows)} frame lines follow (truncated?)",
             frames_line)
    return np.array(values, dtype=np.float64).reshape(count, n_channels), frame_time


def _site_names(nodes: list[_Node]) -> dict[int, str]:
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


def _skeleton(source, nodes, site_names, limits, segments=()):
    """Build the Skeleton; translation DOFs get `limits[(node, channel)]`, rotations [-pi, pi]."""
    joints, sites = [], []
    for k, node in enumerate(nodes):
        parent = nodes[node.parent].name if node.parent >= 0 else None
        if node.is_site:
            sites.append(Site(site_names[k], parent, node.offset))
            continue
        channels = node.channels or ()
        dofs = tuple(translation(c[0], *limits[(k, c)])[0]
                     for c in channels if c.endswith("position"))
        rotations = "".join(c[0] for c in channels if c.endswith("rotation"))
        dofs += euler(rotations) if rotations else ()
        joints.append(Joint(node.name, parent, node.offset, dofs))
    try:  # a safety net: the checks above leave build_skeleton nothing to reject
        return build_skeleton(joints, sites, segments, up=(0.0, 1.0, 0.0),
                              name=Path(source).stem or "bvh")
    except ValueError as error:
        raise FileFormatError(source, f"invalid skeleton: {error}") from None


def parse_bvh(text: str | bytes, source: str = "<string>", segments=None) -> Clip:
    """Parse BVH `text` (str or bytes) named `source` into a Clip.

    `segments`: a segment table path (JSON, see read_segment_table) or None to estimate masses
    from bone lengths; clip.mass_source says which. Frames (N, D) are radians / file length
    units in skeleton DOF order. Raises FileFormatError naming `source` and the line.
    """
    lines = [line.removesuffix("\r") for line in _decode(text, source).split("\n")]
    if not any(line.strip() for line in lines):
        raise FileFormatError(source, "empty file: a BVH file starts with HIERARCHY", line=1)
    motion = next((n for n, line in enumerate(lines, 1)
                   if [w.upper() for w in line.split()[:1]] == ["MOTION"]), None)
    last = max(n for n, line in enumerate(lines, 1) if line.strip())
    nodes = _Hierarchy(source, lines[:motion - 1] if motion else lines, motion or last).parse()
    if motion is None:
        raise FileFormatError(source, "no MOTION section after the hierarchy", line=last)
    joint_nodes = [k for k, node in enumerate(nodes) if not node.is_site]
    columns = [(k, c) for k in joint_nodes for c in nodes[k].channels or ()]
    values, frame_time = _parse_motion(source, lines, motion, len(columns))
    span = {key: (values[:, j].min(), values[:, j].max()) if len(values) else (0.0, 0.0)
            for j, key in enumerate(columns)}
    site_names = _site_names(nodes)
    bare = _skeleton(source, nodes, site_names, span)
    if segments is None:
        masses, mass_source = estimate_segments(bare)
    else:
        masses, mass_source = read_segment_table(segments, bare.joint_names)
    reach = bare.reach
    limits = {key: (lo - reach, hi + reach) for key, (lo, hi) in span.items()}
    skeleton = _skeleton(source, nodes, site_names, limits, masses)
    first_dof = dict(zip(skeleton.joint_names, skeleton.joint_dof_start.tolist()))
    layout = []
    for k in joint_nodes:
        node, channels = nodes[k], nodes[k].channels or ()
        # positions first, then rotations, each in file order: channel i is DOF order.index(i)
        order = sorted(range(len(channels)), key=lambda i: CHANNELS[channels[i]][0] == ROTATE)
        dofs = tuple(first_dof[node.name] + order.index(i) for i in range(len(channels)))
        children = tuple(site_names.get(c, nodes[c].name) for c in node.children)
        layout.append(JointChannels(node.name, channels, dofs, children))
    return Clip.from_channel_values(skeleton, layout, values, frame_time, source, mass_source)


def read_bvh(path, segments=None) -> Clip:
    """Read the BVH file at `path` into a Clip (see parse_bvh); `segments` a table path or None.

    A path that cannot be read raises FileNotFoundError, IsADirectoryError or PermissionError
    naming it; a malformed file raises FileFormatError naming it and the line.
    """
    with open(path, "rb") as file:
        data = file.read()
    return parse_bvh(data, str(path), segments)

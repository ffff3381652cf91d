"""BVH text, part 1: numbers and the HIERARCHY block parsed into a list of nodes.

Every malformed input raises FileFormatError naming the file and the line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import NoReturn

from deik.errors import FileFormatError
from deik.io.motion import CHANNELS

MAX_MAGNITUDE = 1e12  # larger numbers are taken for corruption: they would overflow the maths
NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
NUMBER_LINE = re.compile(r"[0-9eE+\-.\s]*")
TOKEN = re.compile(r"[{}]|[^\s{}]+")
FRAMES = re.compile(r"frames\s*:\s*(\S*)", re.IGNORECASE)
FRAME_TIME = re.compile(r"frame\s+time\s*:\s*(\S*)", re.IGNORECASE)
CHANNEL_NAMES = {name.lower(): name for name in CHANNELS}


@dataclass
class Node:
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


def number(source: str, token: str, line: int, what: str) -> float:
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


class Hierarchy:
    """Parser of the HIERARCHY section (the lines before MOTION) into Node blocks."""

    def __init__(self, source: str, lines: list[str], end_line: int):
        self.source, self.end_line = source, end_line
        self.tokens = [(t, n) for n, text in enumerate(lines, 1) for t in TOKEN.findall(text)]
        self.nodes: list[Node] = []
        self.open: list[int] = []  # indices of the blocks not yet closed, innermost last
        self.first_line: dict[str, int] = {}  # joint name -> line that declared it

    def fail(self, problem: str, line: int) -> NoReturn:
        raise FileFormatError(self.source, problem, line=line)

    def rest_of_line(self, pos: int, line: int) -> tuple[list[str], int]:
        """Words from token `pos` to the end of `line` or the next brace, and the next position."""
        end = pos
        while end < len(self.tokens) and self.tokens[end][1] == line and self.tokens[end][0] not in ("{", "}"):
            end += 1
        return [t for t, _ in self.tokens[pos:end]], end

    def parse(self) -> list[Node]:
        """Blocks in file order; FileFormatError at the first problem."""
        tokens = self.tokens
        if not tokens or tokens[0][0].upper() != "HIERARCHY":
            self.fail("a BVH file must start with HIERARCHY", tokens[0][1] if tokens else self.end_line)
        pos = self.rest_of_line(1, tokens[0][1])[1]
        if pos != 1:
            self.fail("HIERARCHY must stand alone on its line", tokens[0][1])
        handlers = {
            "ROOT": self.block,
            "JOINT": self.block,
            "END": self.block,
            "OFFSET": self.offset,
            "CHANNELS": self.channels,
            "}": self.close,
        }
        while pos < len(tokens):
            word, line = tokens[pos]
            if self.nodes and not self.open:
                self.fail(
                    f"unexpected {_show(word)} after the ROOT block closed; a BVH file has "
                    "one ROOT and MOTION starts its own line",
                    line,
                )
            top = self.nodes[self.open[-1]] if self.open else None
            rest, pos = ([], pos + 1) if word in ("{", "}") else self.rest_of_line(pos + 1, line)
            handler = handlers.get(word.upper())
            if handler is None or (top is None and handler != self.block):
                self.fail(
                    f"unknown keyword {_show(word)} here; expected OFFSET, CHANNELS, JOINT, End Site or '}}'"
                    if top
                    else f"unexpected {_show(word)}; expected ROOT",
                    line,
                )
            pos = handler(word, rest, line, top, pos)
        if not self.nodes:
            self.fail("the hierarchy has no ROOT", self.end_line)
        if self.open:
            node = self.nodes[self.open[-1]]
            self.fail(
                f"the hierarchy ends inside {node.describe()} opened at line {node.line}: missing '}}'", self.end_line
            )
        return self.nodes

    def block(self, word: str, rest: list[str], line: int, top: Node | None, pos: int) -> int:
        """ROOT name / JOINT name / End Site, then '{': open a block."""
        key = word.upper()
        if (key == "ROOT") != (top is None):
            self.fail(
                "ROOT inside a joint: use JOINT"
                if key == "ROOT"
                else "ROOT must come first, once; JOINTs go inside it",
                line,
            )
        if top is not None and top.is_site:
            self.fail("an End Site cannot have children", line)
        if key == "END" and [r.upper() for r in rest] != ["SITE"]:
            self.fail("expected 'End Site'", line)
        if key != "END" and not rest:
            self.fail(f"{word} needs a name on its line", line)
        name = top.name if key == "END" else " ".join(rest)  # 3ds Max's Biped writes "Bip01 L Thigh"
        if key != "END" and name in self.first_line:
            self.fail(f"duplicate joint name {_show(name)} (first at line {self.first_line[name]})", line)
        if pos >= len(self.tokens) or self.tokens[pos][0] != "{":
            self.fail(f"expected '{{' to open {word} {_show(name)}", line)
        if key != "END":
            self.first_line[name] = line
        if top is not None:
            top.children.append(len(self.nodes))
        parent = self.open[-1] if self.open else -1
        self.open.append(len(self.nodes))
        self.nodes.append(Node(name, parent, line, key == "END"))
        return pos + 1

    def offset(self, word: str, rest: list[str], line: int, top: Node | None, pos: int) -> int:
        """OFFSET x y z of the innermost block."""
        if top.offset is not None:
            self.fail(f"second OFFSET in {top.describe()}", line)
        if len(rest) != 3:
            self.fail(f"OFFSET needs 3 numbers (x y z), found {len(rest)}", line)
        top.offset = tuple(number(self.source, t, line, "OFFSET value") for t in rest)
        return pos

    def channels(self, word: str, rest: list[str], line: int, top: Node | None, pos: int) -> int:
        """CHANNELS n name... of the innermost joint, names made canonical."""
        if top.is_site or top.channels is not None:
            self.fail(
                f"an End Site cannot have CHANNELS ({top.describe()})"
                if top.is_site
                else f"second CHANNELS in {top.describe()}",
                line,
            )
        if not rest or not (rest[0].isascii() and rest[0].isdigit() and len(rest[0]) <= 6):
            self.fail("CHANNELS needs a count then the channel names", line)
        count, names = int(rest[0]), rest[1:]
        if count != len(names):
            self.fail(f"CHANNELS says {count} channels but names {len(names)}", line)
        channels = []
        for name in names:
            if name.lower() not in CHANNEL_NAMES:
                self.fail(f"unknown channel {_show(name)}; channels are {', '.join(CHANNELS)}", line)
            if CHANNEL_NAMES[name.lower()] in channels:
                self.fail(f"duplicate channel {name} in {top.describe()}", line)
            channels.append(CHANNEL_NAMES[name.lower()])
        top.channels = tuple(channels)
        return pos

    def close(self, word: str, rest: list[str], line: int, top: Node | None, pos: int) -> int:
        """'}': close the innermost block, which must have had its OFFSET."""
        if top.offset is None:
            self.fail(f"{top.describe()} (line {top.line}) has no OFFSET", line)
        self.open.pop()
        return pos

"""BVH text, part 2: the MOTION section read as a stream, block by block, into one array.

The frame count and channel count are known before any frame is read, so the (N, C) array is
sized once, after two checks: the file must have room for N lines of C numbers (a header that
claims more frames than the bytes left is a truncated or corrupt file, refused before any
allocation), and the array, the clip built from it and its copy must fit the memory limit
(deik.memory). Each block of about BLOCK_BYTES is converted by NumPy's C reader in one call, from
its bytes; only a block that fails is decoded and checked line by line, so that the error names
the first bad line. Peak memory is about twice the frames' float64 size, the values and the
clip's frames, plus a block (the file is never held whole).
"""

from __future__ import annotations

import io
import warnings
from typing import BinaryIO, NoReturn

import numpy as np

from deik.errors import FileFormatError, SolveError
from deik.io.bvh.hierarchy import MAX_MAGNITUDE, NUMBER_LINE, number
from deik.memory import check_memory

BLOCK_BYTES = 8 << 20
MAX_EMPTY_FRAMES = 10_000_000  # frames a channel-less clip may declare (no lines back them)
COPIES = 2  # float64 arrays of the frames' size alive at once: the values, the clip's frames


class FrameReader:
    """Reads the frame lines that follow `Frame Time:` at line `line` of `file` (`size` bytes in
    all) into values (N, C) in file order and units."""

    def __init__(self, source: str, file: BinaryIO, size: int, line: int):
        self.source, self.file, self.size, self.line = source, file, size, line

    def fail(self, problem: str, line: int) -> NoReturn:
        raise FileFormatError(self.source, problem, line=line)

    def read(self, count: int, n_channels: int, frames_line: int) -> np.ndarray:
        """(count, n_channels) float64 of the frame lines; FileFormatError naming the line for
        a bad number, a wrong count of numbers, too many or too few lines, or a clip beyond
        the memory limit."""
        if n_channels == 0:
            return self._empty(count, frames_line)
        room = (self.size - self.file.tell() + 1) // (2 * n_channels)  # a number and a space each
        if count > room:
            self.fail(
                f"'Frames: {count}' but the rest of the file holds at most {room} frames (truncated?)", frames_line
            )
        try:
            check_memory(COPIES * 8 * count * n_channels, None, f"a clip of {count} frames x {n_channels} channels")
        except SolveError as error:
            self.fail(f"{error}".replace("; use a smaller population, batch or generation budget", ""), frames_line)
        values = np.empty((count, n_channels))
        row = 0
        for block in self._blocks(64 * n_channels + 1024):
            row = self._block(block, values, row, frames_line)
        if row < count:
            self.fail(f"'Frames: {count}' but only {row} frame lines follow (truncated?)", frames_line)
        return values

    def _blocks(self, longest: int):
        """The rest of the file in blocks of whole lines (about BLOCK_BYTES each), self.line the
        number of each block's first line; a line over `longest` bytes fails (no frame line
        is that long: this bounds the memory a file of one endless line takes)."""
        rest = b""
        while True:
            data = self.file.read(BLOCK_BYTES)
            buffer = rest + data
            cut = buffer.rfind(b"\n") if data else len(buffer)
            if cut < 0:
                if len(buffer) > longest:
                    self.fail(f"a line of more than {longest} bytes: not a frame line", self.line)
                rest = buffer
                continue
            block, rest = buffer[:cut], buffer[cut + 1 :]
            yield block
            self.line += block.count(b"\n") + 1
            if not data:
                return

    def _empty(self, count: int, frames_line: int) -> np.ndarray:
        if count > MAX_EMPTY_FRAMES:
            self.fail(
                f"'Frames: {count}' for a hierarchy without channels; give at most {MAX_EMPTY_FRAMES}", frames_line
            )
        for block in self._blocks(BLOCK_BYTES):
            for k, raw in enumerate(block.split(b"\n")):
                if raw.strip():
                    self.fail("frame numbers given but the hierarchy has no channels", self.line + k)
        return np.zeros((count, 0))

    def _text(self, block: bytes) -> str:
        """`block` decoded; FileFormatError at the line of a NUL or a byte that is not UTF-8."""
        if b"\0" in block:
            self.fail("not a text BVH file (NUL bytes)", self.line + block.count(b"\n", 0, block.index(b"\0")))
        try:
            return block.decode("utf-8")
        except UnicodeDecodeError as error:
            self.fail("not a text BVH file (bytes that are not UTF-8)", self.line + block.count(b"\n", 0, error.start))

    def _block(self, block: bytes, values: np.ndarray, row: int, frames_line: int) -> int:
        """Convert the lines of `block` (starting at line self.line) into values[row:]; the next row."""
        if not block.strip():
            return row
        count, expected = values.shape
        parsed = None
        if block.isascii() and b"\0" not in block:  # numbers are ASCII: read the bytes, no text copy
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    parsed = np.loadtxt(io.BytesIO(block), dtype=np.float64, comments=None, ndmin=2)
                except ValueError:
                    pass
        good = parsed is not None and parsed.shape[1:] == (expected,) and np.all(np.abs(parsed) <= MAX_MAGNITUDE)
        if good and row + len(parsed) <= count:  # (NaN fails the magnitude test)
            values[row : row + len(parsed)] = parsed
            return row + len(parsed)
        text = self._text(block)
        for k, line in enumerate(text.split("\n")):  # line by line: the first bad line is named
            line = line.strip()
            if not line:
                continue
            if row == count:
                self.fail(f"more frame lines than 'Frames: {count}' (line {frames_line}) says", self.line + k)
            values[row] = frame_row(self.source, line, self.line + k, expected)
            row += 1
        return row


def frame_row(source: str, text: str, line: int, expected: int) -> list[float]:
    """The `expected` numbers of one frame line, or FileFormatError naming the line and value."""
    words = text.split()
    if len(words) != expected:
        raise FileFormatError(
            source, f"frame has {len(words)} numbers, expected {expected} (one per channel)", line=line
        )
    if NUMBER_LINE.fullmatch(text):
        try:
            row = [float(w) for w in words]
            if all(abs(v) <= MAX_MAGNITUDE for v in row):
                return row
        except ValueError:
            pass
    return [number(source, w, line, f"channel {k + 1}") for k, w in enumerate(words)]

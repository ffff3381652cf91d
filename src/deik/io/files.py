"""The one reader of input files: only regular files, of bounded size and nesting, decoded and
parsed (JSON, TOML, CSV) with errors that name the file, and typed field access that names the
field.

Every reader of deik (BVH, URDF, TOML problems, JSON tables, reach tracks, joint maps, library
records) opens its file through `open_input`, so a link to /dev/zero, a FIFO, a device or a
folder is refused at once instead of being read forever (the file is opened without blocking
and checked by its open handle, so it cannot be swapped between the check and the read), and
a missing or unreadable file gets one line that names it and the reason.

Inside `command_inputs()` (each command of the CLI runs in one) every file read is recorded,
so that a command can check that no output it is about to write is one of its inputs, however
the input was named: on the command line, or inside another input (a problem file's skeleton,
a map, a reach track). deik.io.atomic refuses such a write.
"""

from __future__ import annotations

import contextlib
import contextvars
import csv
import io
import json
import math
import os
import stat
import tomllib
from collections.abc import Iterator
from typing import BinaryIO, NoReturn

from deik.errors import FileFormatError, InputError

FilePath = str | os.PathLike  # a file a user names: a string or a pathlib.Path
MAX_INPUT_BYTES = 1 << 30  # 1 GiB: far above any motion clip or robot file
INPUT_LIMIT_VARIABLE = "DEIK_MAX_INPUT_BYTES"
MAX_DEPTH = 32  # nesting of JSON arrays and objects, TOML arrays and tables: deik's files need 4
MAX_NUMBER = 1e12  # the default bound of a number field: larger is corruption (squares overflow float32)
_MISSING = object()
PROTECT = "protect"  # the key of command_inputs' switch among the recorded (device, inode) keys
OFFER = "offer"  # the key of whether the command has --overwrite
_inputs: contextvars.ContextVar[dict | None] = contextvars.ContextVar("deik_inputs", default=None)


def max_input_bytes() -> int:
    """The largest input file read, in bytes: MAX_INPUT_BYTES unless DEIK_MAX_INPUT_BYTES says otherwise."""
    value = os.environ.get(INPUT_LIMIT_VARIABLE)
    if value is None:
        return MAX_INPUT_BYTES
    if not (value.isascii() and value.isdigit() and len(value) <= 15) or int(value) <= 0:
        raise InputError(f"{INPUT_LIMIT_VARIABLE}={value[:40]!r} must be a positive whole number of bytes")
    return int(value)


@contextlib.contextmanager
def command_inputs(protect: bool = True, overwrite_flag: bool = False) -> Iterator[None]:
    """Record every file read inside the block (see inputs_read and input_named); `protect`:
    refuse to write over any of them (check_not_input; a command's --overwrite turns it off,
    `overwrite_flag`: the command has one, which the refusal then offers)."""
    token = _inputs.set({PROTECT: protect, OFFER: overwrite_flag})
    try:
        yield
    finally:
        _inputs.reset(token)


def inputs_read() -> list[str]:
    """The paths of the files read so far inside command_inputs() (empty outside it)."""
    return [path for key, path in (_inputs.get() or {}).items() if key not in (PROTECT, OFFER)]


def input_named(path: FilePath) -> str | None:
    """The input read inside command_inputs() that `path` names (the same file, through any
    link), as it was named when read; None when `path` is not an input or does not exist."""
    recorded = _inputs.get()
    if not recorded:
        return None
    try:
        info = os.stat(path)
    except OSError:
        return None
    return recorded.get((info.st_dev, info.st_ino))


def check_not_input(path: FilePath) -> None:
    """InputError when writing `path` would replace a file the command read (inside
    command_inputs(protect=True)), naming both."""
    recorded = _inputs.get()
    source = input_named(path) if recorded and recorded[PROTECT] else None
    if source is not None:
        shown = "" if os.path.abspath(source) == os.path.abspath(path) else f" (read as {source})"
        offer = " (or add --overwrite to replace it)" if recorded.get(OFFER) else ""
        raise InputError(f"{path}: this output is also an input of the command{shown}; write it elsewhere{offer}")


def _fail_open(source: str, what: str, error: OSError) -> NoReturn:
    if isinstance(error, FileNotFoundError):
        raise FileFormatError(source, f"no such {what} file; check the path") from None
    if isinstance(error, NotADirectoryError):
        raise FileFormatError(source, f"no such {what} file: a folder on its path is a file") from None
    raise FileFormatError(source, f"cannot read the {what} file ({error.strerror or error})") from None


@contextlib.contextmanager
def open_input(path: FilePath, what: str, record: bool = True) -> Iterator[tuple[BinaryIO, int]]:
    """(binary file, size in bytes) of the `what` file (e.g. "BVH") at `path`, open for the
    block. FileFormatError naming the file when it is missing, unreadable, not a regular file
    or larger than max_input_bytes(). `record`: count it among the command's inputs (False
    for deik's own records, which a command rewrites)."""
    from deik.io.atomic import tidy  # lazily: atomic writes through this module

    source = str(path)
    tidy(os.path.dirname(os.path.abspath(path)))  # a command killed while it moved its files: finish them
    try:
        handle = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as error:
        _fail_open(source, what, error)
    try:
        info = os.fstat(handle)
        if stat.S_ISDIR(info.st_mode):
            raise FileFormatError(source, f"is a folder, not a {what} file")
        if not stat.S_ISREG(info.st_mode):
            raise FileFormatError(source, f"is a device, pipe or socket, not a {what} file; give a regular file")
        limit = max_input_bytes()
        if info.st_size > limit:
            raise FileFormatError(
                source,
                f"is {info.st_size} bytes, more than the {limit} a {what} file may have "
                f"(set {INPUT_LIMIT_VARIABLE} to raise the limit)",
            )
        recorded = _inputs.get()
        if record and recorded is not None:
            recorded.setdefault((info.st_dev, info.st_ino), source)
        file = os.fdopen(handle, "rb")
    except BaseException:
        os.close(handle)
        raise
    with file:
        try:
            yield file, info.st_size
        except OSError as error:
            _fail_open(source, what, error)


def read_input(path: FilePath, what: str, record: bool = True) -> bytes:
    """The bytes of the `what` file at `path` (see open_input), never more than max_input_bytes()
    even when the file grows while it is read."""
    limit = max_input_bytes()
    with open_input(path, what, record) as (file, _):
        data = file.read(limit + 1)
    if len(data) > limit:
        raise FileFormatError(str(path), f"grew beyond the {limit} bytes a {what} file may have while it was read")
    return data


def decode_text(data: bytes, source: str, what: str) -> str:
    """UTF-8 `data` (a byte-order mark is allowed) as text; FileFormatError naming the file and
    the line when it is not text."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        line = data.count(b"\n", 0, error.start) + 1
        raise FileFormatError(
            source, f"not a text (UTF-8) {what} file: byte {error.start} cannot be decoded", line=line
        ) from None


def read_input_text(path: FilePath, what: str, record: bool = True) -> str:
    """read_input decoded as UTF-8 (decode_text)."""
    return decode_text(read_input(path, what, record), str(path), what)


def nesting_depth(value: object) -> int:
    """How deeply lists and dicts nest in `value` (a number or string: 0), without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, depth = stack.pop()
        children = item.values() if isinstance(item, dict) else item if isinstance(item, list) else None
        if children is None:
            continue
        deepest = max(deepest, depth)
        if depth <= MAX_DEPTH:  # deeper than that is refused anyway: stop counting
            stack.extend((child, depth + 1) for child in children)
    return deepest


def _parsed(data: object, source: str, what: str, max_depth: int) -> object:
    if nesting_depth(data) > max_depth:
        raise FileFormatError(source, f"nested more than {max_depth} levels deep; this is not a {what} file")
    return data


class _Twice(Exception):
    """A JSON object that gives one key twice (args: the key)."""


def _once(pairs: list[tuple[str, object]]) -> dict:
    """The object of `pairs`; _Twice for a key given twice."""
    out = dict(pairs)
    if len(out) < len(pairs):
        seen = set()
        raise _Twice(next(key for key, _ in pairs if key in seen or seen.add(key)))
    return out


def parse_json(text: str, source: str, what: str, max_depth: int = MAX_DEPTH) -> object:
    """JSON `text` of file `source` parsed; FileFormatError naming the file (and line) when it
    is not JSON, nests deeper than `max_depth` or holds a number too long to read."""
    try:
        data = json.loads(text, object_pairs_hook=_once)
    except _Twice as error:  # json keeps the last of two, silently
        raise FileFormatError(source, f"key {error.args[0]!r} is given twice in one object; give it once") from None
    except json.JSONDecodeError as error:
        raise FileFormatError(source, f"not valid JSON ({error.msg}); give a {what} file", line=error.lineno) from None
    except RecursionError:
        raise FileFormatError(source, f"nested too deeply to be a {what} file") from None
    except ValueError as error:  # an integer of thousands of digits
        raise FileFormatError(source, f"not a {what} file: {error}") from None
    return _parsed(data, source, what, max_depth)


def parse_toml(text: str, source: str, what: str, max_depth: int = MAX_DEPTH) -> dict:
    """TOML `text` of file `source` parsed; FileFormatError naming the file when it is not TOML,
    nests deeper than `max_depth` or holds a number too long to read."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise FileFormatError(source, f"not valid TOML: {error}") from None
    except RecursionError:
        raise FileFormatError(source, f"arrays or tables nested too deeply to be a {what} file") from None
    except ValueError as error:  # an integer of thousands of digits
        raise FileFormatError(source, f"not a {what} file: {error}") from None
    return _parsed(data, source, what, max_depth)


def read_json(path: FilePath, what: str, record: bool = True, max_depth: int = MAX_DEPTH) -> object:
    """The JSON file at `path` (read_input_text, parse_json)."""
    return parse_json(read_input_text(path, what, record), str(path), what, max_depth)


def read_toml(path: FilePath, what: str, max_depth: int = MAX_DEPTH) -> dict:
    """The TOML file at `path` (read_input_text, parse_toml)."""
    return parse_toml(read_input_text(path, what), str(path), what, max_depth)


def read_json_or_toml(path: FilePath, what: str) -> object:
    """The file at `path` as JSON when its name ends in .json, else as TOML."""
    if str(path).lower().endswith(".json"):
        return read_json(path, what)
    return read_toml(path, what)


def parse_csv(text: str, source: str) -> list[tuple[int, list[str]]]:
    """[(line number, fields stripped of spaces)] of the non-blank lines of CSV `text` (commas,
    double quotes as in RFC 4180); FileFormatError naming the file and the line when malformed."""
    rows = []
    reader = csv.reader(io.StringIO(text, newline=""), strict=True, skipinitialspace=True)
    try:
        for fields in reader:
            if any(field.strip() for field in fields):
                rows.append((reader.line_num, [field.strip() for field in fields]))
    except csv.Error as error:
        raise FileFormatError(source, f"not valid CSV: {error}", line=reader.line_num) from None
    return rows


def _shown(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def number_value(value: object, source: str, field: str, low: float = -MAX_NUMBER, high: float = MAX_NUMBER) -> float:
    """`value` (parsed from file `source`) as a float within [low, high]; FileFormatError
    naming the file and `field` when it is not a number (a bool is not), not finite (however
    many digits it has) or out of range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise FileFormatError(source, f"must be a finite number, got {_shown(value)}", element=field)
    try:
        number = float(value)
    except OverflowError:  # an integer beyond the float range
        number = math.inf if value > 0 else -math.inf
    if not math.isfinite(number):
        raise FileFormatError(source, f"must be a finite number, got {_shown(value)}", element=field)
    if not low <= number <= high:
        raise FileFormatError(source, f"must lie between {low:g} and {high:g}, got {number:g}", element=field)
    return number


def integer_value(value: object, source: str, field: str, low: int = 0, high: int = 2**63 - 1) -> int:
    """`value` as an integer within [low, high]; FileFormatError naming the file and `field`."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise FileFormatError(source, f"must be a whole number, got {_shown(value)}", element=field)
    if not low <= value <= high:
        raise FileFormatError(
            source, f"must be a whole number from {low} to {high}, got {_shown(value)}", element=field
        )
    return value


def numbers_value(
    value: object, source: str, field: str, length: int, low: float = -MAX_NUMBER, high: float = MAX_NUMBER
) -> tuple[float, ...]:
    """`value` as a list of `length` numbers, each as number_value checks it."""
    if not isinstance(value, list) or len(value) != length:
        raise FileFormatError(source, f"must be a list of {length} finite numbers, got {_shown(value)}", element=field)
    return tuple(number_value(v, source, f"{field}[{k}]", low, high) for k, v in enumerate(value))


class Fields:
    """A JSON object or TOML table of file `source` with checked access by name: a missing,
    wrong-typed or out-of-range field raises FileFormatError naming the file and the field
    (`where` + the name)."""

    def __init__(self, data: object, source: str, where: str = ""):
        self.source, self.where = source, where
        if not isinstance(data, dict):
            self.fail(None, f"must be an object (a table of named fields), got {_shown(data)}")
        self.data = data

    def name(self, key: str | None) -> str:
        """The field's name as errors give it."""
        if key is None:
            return self.where or "top level"
        return f"{self.where}.{key}" if self.where else key

    def fail(self, key: str | None, problem: str) -> NoReturn:
        raise FileFormatError(self.source, problem, element=self.name(key))

    def __contains__(self, key: str) -> bool:
        return key in self.data

    def get(self, key: str, default: object = _MISSING) -> object:
        """The raw value of `key`; `default` when absent (no default: a missing field fails)."""
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            self.fail(key, "is missing")
        return default

    def number(
        self, key: str, low: float = -MAX_NUMBER, high: float = MAX_NUMBER, default: object = _MISSING
    ) -> float | None:
        """Field `key` as a float within [low, high] (number_value)."""
        value = self.get(key, default)
        return value if value is default else number_value(value, self.source, self.name(key), low, high)

    def integer(self, key: str, low: int = 0, high: int = 2**63 - 1, default: object = _MISSING) -> int | None:
        """Field `key` as an integer within [low, high] (integer_value)."""
        value = self.get(key, default)
        return value if value is default else integer_value(value, self.source, self.name(key), low, high)

    def text(self, key: str, default: object = _MISSING) -> str | None:
        """Field `key` as a string."""
        value = self.get(key, default)
        if value is not default and not isinstance(value, str):
            self.fail(key, f"must be a string, got {_shown(value)}")
        return value

    def table(self, key: str, default: object = _MISSING) -> Fields | None:
        """Field `key` as Fields (a nested object or table)."""
        value = self.get(key, default)
        return value if value is default else Fields(value, self.source, self.name(key))

    def items(self, key: str, default: object = _MISSING) -> list | None:
        """Field `key` as a list."""
        value = self.get(key, default)
        if value is not default and not isinstance(value, list):
            self.fail(key, f"must be a list, got {_shown(value)}")
        return value

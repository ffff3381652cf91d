"""Reading an input file safely: only regular files, of bounded size, with errors that name them.

Every reader (BVH, URDF, TOML problems, JSON tables, reach tracks) goes through `read_input`,
so a link to /dev/zero, a FIFO or a folder is refused at once instead of being read forever,
and a missing or unreadable file gets one line that names it and the reason.
"""

from __future__ import annotations

import json
import os
import stat

from deik.errors import FileFormatError, InputError

FilePath = str | os.PathLike  # a file a user names: a string or a pathlib.Path
MAX_INPUT_BYTES = 1 << 30  # 1 GiB: far above any motion clip or robot file
INPUT_LIMIT_VARIABLE = "DEIK_MAX_INPUT_BYTES"


def max_input_bytes() -> int:
    """The largest input file read, in bytes: MAX_INPUT_BYTES unless DEIK_MAX_INPUT_BYTES says otherwise."""
    value = os.environ.get(INPUT_LIMIT_VARIABLE)
    if value is None:
        return MAX_INPUT_BYTES
    if not value.isdigit() or int(value) <= 0:
        raise InputError(f"{INPUT_LIMIT_VARIABLE}={value!r} must be a positive whole number of bytes")
    return int(value)


def read_input(path: FilePath, what: str) -> bytes:
    """The bytes of the `what` file (e.g. "BVH") at `path`; FileFormatError naming the file when it
    is missing, unreadable, not a regular file or larger than max_input_bytes()."""
    source = str(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise FileFormatError(source, f"no such {what} file; check the path") from None
    except OSError as error:
        raise FileFormatError(source, f"cannot read the {what} file ({error.strerror})") from None
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
    try:
        with open(path, "rb") as file:
            return file.read(limit + 1)
    except OSError as error:
        raise FileFormatError(source, f"cannot read the {what} file ({error.strerror})") from None


def read_input_text(path: FilePath, what: str) -> str:
    """read_input decoded as UTF-8 (a byte-order mark is allowed); FileFormatError naming the file
    when it is not text."""
    data = read_input(path, what)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise FileFormatError(
            str(path), f"not a text (UTF-8) {what} file: byte {error.start} cannot be decoded"
        ) from None


def read_input_json(path: FilePath, what: str) -> object:
    """read_input_text parsed as JSON; FileFormatError naming the file when it is not JSON (or is
    nested too deeply to parse)."""
    text = read_input_text(path, what)
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise FileFormatError(str(path), f"not valid JSON ({error}); give a {what} file") from None
    except RecursionError:
        raise FileFormatError(str(path), f"JSON nested too deeply to be a {what} file") from None

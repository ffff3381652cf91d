"""Atomic file writes: a reader sees the old file or the complete new one, never a part.

Each write goes to a hidden temporary file beside its target, `.NAME.deik-partial-PID.EXT`, and
is then moved onto the target. A write that fails removes its temporary file; one stranded by
a killed process (its PID no longer runs) is removed by the next write to the same target.
Inside `all_or_nothing()`, the moves wait until the block ends: every file of a command
appears together, or none does.
"""

from __future__ import annotations

import contextlib
import contextvars
import glob
import json
import math
import os
from collections.abc import Callable, Iterator

from deik.io.files import FilePath

PARTIAL = ".deik-partial-"
_pending: contextvars.ContextVar[list | None] = contextvars.ContextVar("deik_pending_writes", default=None)


def _temporary_path(path: str) -> str:
    folder, name = os.path.split(os.path.abspath(path))
    stem, extension = os.path.splitext(name)
    return os.path.join(folder, f".{stem}{PARTIAL}{os.getpid()}{extension}")


def _remove_stranded(path: str) -> None:
    """Remove temporary files for `path` left by processes that no longer run."""
    folder, name = os.path.split(os.path.abspath(path))
    stem, extension = os.path.splitext(name)
    pattern = os.path.join(glob.escape(folder), f".{glob.escape(stem)}{PARTIAL}*{glob.escape(extension)}")
    for stranded in glob.glob(pattern):
        pid = stranded[len(os.path.join(folder, f".{stem}{PARTIAL}")) : len(stranded) - len(extension)]
        if pid.isdigit() and int(pid) != os.getpid() and not _running(int(pid)):
            with contextlib.suppress(OSError):
                os.unlink(stranded)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def save_atomically(path: FilePath, write: Callable[[str], object]) -> None:
    """Call write(temporary_path) to create a file beside `path`, then move it onto `path`
    (at the end of an enclosing all_or_nothing() block, if any); on failure the temporary file is
    removed and `path` is left as it was."""
    _remove_stranded(path)
    temporary = _temporary_path(path)
    try:
        write(temporary)
        pending = _pending.get()
        if pending is None:
            os.replace(temporary, path)
        else:
            pending.append((temporary, os.path.abspath(path)))
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


@contextlib.contextmanager
def all_or_nothing() -> Iterator[None]:
    """Hold every save_atomically inside the block until it ends without error, then move all the
    files into place; on an error (or Ctrl-C) remove them all and leave every target as it was."""
    pending: list = []
    token = _pending.set(pending)
    try:
        yield
    except BaseException:
        for temporary, _ in pending:
            with contextlib.suppress(OSError):
                os.unlink(temporary)
        raise
    finally:
        _pending.reset(token)
    for temporary, path in pending:
        os.replace(temporary, path)


def write_text_atomically(path: FilePath, text: str) -> None:
    """Write `text` (UTF-8) to `path` atomically."""

    def write(temporary):
        with open(temporary, "w", encoding="utf-8") as file:
            file.write(text)

    save_atomically(path, write)


def write_json_atomically(path: FilePath, data: object, missing_as_null: bool = False) -> None:
    """Write `data` as indented JSON to `path` atomically. NaN or infinity is not JSON: with
    `missing_as_null` (measurements that were not taken) it is written as null, else it is refused
    with a ValueError naming the file (a result that holds it is a bug)."""
    if missing_as_null:
        data = _nulls_for_non_finite(data)
    try:
        text = json.dumps(data, indent=2, allow_nan=False)
    except ValueError:
        raise ValueError(
            f"{path}: the results hold NaN or infinite numbers, so no JSON was written; "
            "this is a bug or an input beyond float range (report it with the command)"
        ) from None
    write_text_atomically(path, text + "\n")


def _nulls_for_non_finite(value):
    """`value` (nested dicts, lists, tuples, numbers) with every NaN or infinite float as None."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _nulls_for_non_finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_nulls_for_non_finite(v) for v in value]
    return value

"""Atomic file writes: a reader sees the old file or the complete new one, never a part, and a
command's files appear together or not at all, even when the process is killed.

Each write goes to a new hidden temporary file in the target's folder, created exclusively
(O_EXCL: a file or link already at that name is never opened, so a planted symlink cannot
redirect the write) under an unpredictable name `.deik-partial-HOST-PID-TOKEN.NAME` of at most
255 bytes, and is then moved onto the target. A write that fails removes its temporary file;
the next write into the folder removes those of processes of this machine that no longer run.

Inside `all_or_nothing()` the moves wait until the block ends. Several files then commit through
a journal: once every temporary file is complete, `.deik-commit-HOST-PID-TOKEN.json`, listing
every move, is written (atomically) into each folder that receives a file; then the files are
moved; then the journals are removed. A process killed before its journal is complete moved
nothing (its temporary files are removed later: nothing appears); one killed between the moves
left a journal, and the next deik command that writes or reads in that folder finishes the
moves first (every file appears). We chose a journal over moving one staging folder into
place because a command's outputs may lie in several folders (--out here, --json there), which
no single rename can cover.

No write may replace a file the command reads (deik.io.files.command_inputs): that is refused
with an InputError naming both, however the input was named.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import hashlib
import json
import math
import os
import re
import secrets
import socket
from collections.abc import Callable, Iterator
from typing import BinaryIO

from deik.io.files import FilePath, check_not_input, parse_json

PARTIAL = ".deik-partial-"
JOURNAL = ".deik-commit-"
NAME_MAX = 255  # bytes of one file name on every file system deik writes to
HOST = hashlib.sha256(socket.gethostname().encode()).hexdigest()[:8]  # names this machine's files
OURS = re.compile(rf"^({re.escape(PARTIAL)}|{re.escape(JOURNAL)})([0-9a-f]{{8}})-([0-9]+)-[0-9a-f]{{8}}")
_pending: contextvars.ContextVar[list | None] = contextvars.ContextVar("deik_pending_writes", default=None)
_tidied: set[str] = set()  # folders whose leftovers this process has handled


def _name(prefix: str, tail: str) -> str:
    """PREFIX + HOST-PID-TOKEN + "." + as much of `tail` as fits in NAME_MAX bytes."""
    head = f"{prefix}{HOST}-{os.getpid()}-{secrets.token_hex(4)}."
    room = NAME_MAX - len(head.encode())
    return head + tail.encode()[:room].decode("utf-8", "ignore")


def _create(folder: str, prefix: str, tail: str) -> tuple[int, str]:
    """(descriptor, path) of a new empty file in `folder`, created exclusively without following
    a link at its name."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    for _ in range(100):
        path = os.path.join(folder, _name(prefix, tail))
        try:
            return os.open(path, flags, 0o666), path
        except FileExistsError:  # a token drawn twice, or a name planted in advance: draw again
            continue
    raise FileExistsError(errno.EEXIST, "cannot create a temporary file: every name tried is taken", folder)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _dead(name: str) -> bool:
    """Whether `name` is a temporary file or journal of a process of this machine that no longer runs."""
    match = OURS.match(name)
    return bool(match) and match[2] == HOST and int(match[3]) != os.getpid() and not _running(int(match[3]))


def tidy(folder: FilePath) -> None:
    """Finish the moves of the journals that dead processes left in `folder`, then remove their
    temporary files (once per folder and process; a folder that cannot be read or changed is
    left as it is)."""
    folder = os.path.abspath(folder)
    if folder in _tidied:
        return
    _tidied.add(folder)
    with contextlib.suppress(OSError):
        names = [entry.name for entry in os.scandir(folder) if _dead(entry.name)]
        for name in sorted(names, key=lambda n: not n.startswith(JOURNAL)):  # journals first
            path = os.path.join(folder, name)
            if name.startswith(JOURNAL) and os.path.lexists(path):
                _finish(path)
            with contextlib.suppress(OSError):
                os.unlink(path)


def _finish(journal: str) -> None:
    """Do the moves a journal lists whose temporary file is still there, then remove every copy
    of the journal. Only moves of our temporary files onto a file in the same folder are done."""
    try:
        with open(journal, "rb") as file:
            record = parse_json(file.read(1 << 24).decode("utf-8", "replace"), journal, "deik journal")
        moves, journals = record["moves"], record["journals"]
        for temporary, target in moves:
            same_folder = os.path.dirname(temporary) == os.path.dirname(target)
            if same_folder and OURS.match(os.path.basename(temporary)) and os.path.lexists(temporary):
                os.replace(temporary, target)
        for path in journals:
            if OURS.match(os.path.basename(path)):
                with contextlib.suppress(OSError):
                    os.unlink(path)
    except (OSError, ValueError, TypeError, KeyError):  # a damaged journal: its files stay as they are
        return


def save_atomically(path: FilePath, write: Callable[[BinaryIO], object]) -> None:
    """Call write(file) with a new binary file beside `path`, then move it onto `path` (at the
    end of an enclosing all_or_nothing() block, if any); on failure the temporary file is
    removed and `path` is left as it was. InputError when `path` is one of the command's
    inputs; an OSError (a full disk) names `path`."""
    path = os.path.abspath(path)
    check_not_input(path)
    if len(os.path.basename(path).encode()) > NAME_MAX:  # refused before a file of the set is written
        raise OSError(errno.ENAMETOOLONG, f"cannot write it: its name is longer than {NAME_MAX} bytes", path)
    folder = os.path.dirname(path)
    tidy(folder)
    temporary = None
    try:
        handle, temporary = _create(folder, PARTIAL, os.path.basename(path))
        with os.fdopen(handle, "wb") as file:
            write(file)
        pending = _pending.get()
        if pending is None:
            os.replace(temporary, path)
        else:
            pending.append((temporary, path))
    except BaseException as error:
        if temporary is not None:
            with contextlib.suppress(OSError):
                os.unlink(temporary)
        ours = error.filename is None or os.path.basename(str(error.filename)).startswith(PARTIAL)
        if isinstance(error, OSError) and ours and error.errno is not None:  # name the target, not our file
            raise type(error)(error.errno, f"cannot write it: {error.strerror}", path) from None
        raise


def check_writable(folder: FilePath) -> None:
    """OSError naming `folder` unless a file can be created in it (as save_atomically creates
    its temporary file, then removed): permissions can say yes where the file system says no
    (a read-only mount, /proc)."""
    try:
        handle, temporary = _create(str(folder), PARTIAL, "probe")
    except OSError as error:
        raise type(error)(error.errno, error.strerror, str(folder)) from None
    os.close(handle)
    os.unlink(temporary)


def _commit(moves: list[tuple[str, str]]) -> None:
    """Move every temporary file onto its target, through journals when there are several."""
    if len(moves) == 1:
        os.replace(*moves[0])
        return
    folders = sorted({os.path.dirname(target) for _, target in moves})
    journals = []
    try:
        for folder in folders:
            handle, temporary = _create(folder, PARTIAL, "journal.json")
            journals.append((handle, temporary, os.path.join(folder, _name(JOURNAL, "json"))))
        record = {"moves": moves, "journals": [journal for _, _, journal in journals]}
        text = json.dumps(record).encode()
        for handle, temporary, journal in journals:
            with os.fdopen(handle, "wb") as file:
                file.write(text)
            os.replace(temporary, journal)
    except BaseException:
        for _, temporary, journal in journals:
            for leftover in (temporary, journal):
                with contextlib.suppress(OSError):
                    os.unlink(leftover)
        raise
    for temporary, target in moves:
        os.replace(temporary, target)
    for _, _, journal in journals:
        with contextlib.suppress(OSError):
            os.unlink(journal)


@contextlib.contextmanager
def all_or_nothing() -> Iterator[None]:
    """Hold every save_atomically inside the block until it ends without error, then move all the
    files into place together (see the module notes); on an error (or Ctrl-C) remove them all
    and leave every target as it was."""
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
    if pending:
        _commit(pending)


@contextlib.contextmanager
def scratch() -> Iterator[None]:
    """Inside the block every save_atomically moves its file into place at once, even within
    all_or_nothing(): for scratch files a command writes and reads back (a picture drawn into
    another), which are no outputs of it."""
    token = _pending.set(None)
    try:
        yield
    finally:
        _pending.reset(token)


def write_text_atomically(path: FilePath, text: str) -> None:
    """Write `text` (UTF-8) to `path` atomically."""
    save_atomically(path, lambda file: file.write(text.encode("utf-8")))


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

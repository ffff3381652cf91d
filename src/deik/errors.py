"""deik's errors, one hierarchy a caller can catch by class.

    DeikError                 anything deik raises on purpose
      InputError (ValueError) a user's input is wrong: a value, a name, a flag or a file
        FileFormatError       a malformed or unsupported input file, named with its line or element
        UsageError            a mistake on the command line (exit status 2)
        UnknownNameError      a joint, site, link, DOF or goal name that is not there (a KeyError too)
      SolveError              a solve that cannot run as asked (too large for memory, interrupted)
      DeviceError             the GPU (or its packages) cannot run the solve

InputError derives from ValueError, and UnknownNameError from KeyError as well, so code written
against ValueError or KeyError keeps working. The command line prints a DeikError's message as
one line `deik: error: ...` and exits with status 2.
"""

from __future__ import annotations

import errno


class DeikError(Exception):
    """Base class of every error deik raises on purpose (a bug raises something else)."""


class InputError(DeikError, ValueError):
    """A user's input is wrong: the message names the value, flag or file and how to fix it."""


class FileFormatError(InputError):
    """A malformed or unsupported input file. `str()` reads "FILE:LINE: problem" (or
    "FILE: element: problem" when no line applies) and says how to fix it where it can."""

    def __init__(self, source: str, problem: str, line: int | None = None, element: str | None = None):
        self.source, self.problem, self.line, self.element = source, problem, line, element
        where = f"{source}:{line}" if line is not None else source
        if element:
            where = f"{where}: {element}"
        super().__init__(f"{where}: {problem}")


class UsageError(InputError):
    """A mistake in a command line or its inputs: reported in one line, exit status 2."""


class UnknownNameError(InputError, KeyError):
    """A name that is not there (a joint, site, link, DOF or goal), with the close matches."""

    def __str__(self) -> str:  # KeyError's would quote the message
        return str(self.args[0]) if self.args else ""


class SolveError(DeikError, RuntimeError):
    """A solve that cannot run as asked: its buffers would not fit the memory limit, it was
    interrupted, or its settings contradict each other."""


class DeviceError(DeikError, RuntimeError):
    """The GPU path cannot run: no NVIDIA GPU, numba-cuda missing, or a broken package pairing."""


MESSAGE_LIMIT = 500  # characters of a one-line error message


def error_line(error: BaseException, limit: int = MESSAGE_LIMIT) -> str:
    """The message of `error` on one line, safe for a terminal (control characters such as an
    escape sequence in a joint name are shown escaped, never run) and at most `limit` characters
    (a whole echoed input is cut); a KeyError's message is its args[0] (str() would add quotes),
    an OSError about a file reads "FILE: what happened", one about a full disk and no file
    (standard output) names it and the fix."""
    message = error.args[0] if isinstance(error, KeyError) and error.args else error
    if isinstance(error, OSError) and error.filename is not None and error.strerror:
        message = f"{error.filename}: {error.strerror}"
    elif isinstance(error, OSError) and error.errno in (errno.ENOSPC, errno.EDQUOT):
        message = f"writing the standard output: {error.strerror}; free some space or redirect it elsewhere"
    line = " ".join(str(message).split())
    line = "".join(c if c.isprintable() else repr(c)[1:-1] for c in line)
    return line if len(line) <= limit else f"{line[: limit - 30]} ... ({len(line)} characters)"

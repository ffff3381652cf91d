"""The one error type for malformed input files: it names the file and the line or element."""

from __future__ import annotations


class FileFormatError(ValueError):
    """A malformed or unsupported input file. `str()` reads "FILE:LINE: problem" (or
    "FILE: element: problem" when no line applies) and says how to fix it where it can."""

    def __init__(self, source: str, problem: str, line: int | None = None, element: str | None = None):
        self.source, self.problem, self.line, self.element = source, problem, line, element
        where = f"{source}:{line}" if line is not None else source
        if element:
            where = f"{where}: {element}"
        super().__init__(f"{where}: {problem}")

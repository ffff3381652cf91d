"""Close-match hints for unknown names in error messages."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def did_you_mean(name: object, choices: Iterable[object], n: int = 3) -> str:
    """ "; did you mean 'a' or 'b'?" with up to `n` names from `choices` close to `name`, or ""."""
    close = difflib.get_close_matches(str(name), [str(c) for c in choices], n=n)
    return f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""

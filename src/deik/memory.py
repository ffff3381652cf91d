"""The memory a command may allocate, and the guard every size a user controls goes through
before anything is allocated: a population of a billion, a batch far larger than the machine or
a motion file of a gigabyte is refused with the estimate and the fix instead of running the
machine out of memory (or ending in an internal MemoryError).
"""

from __future__ import annotations

import os

from deik.errors import SolveError

MEMORY_FRACTION = 0.8  # default limit: this share of the machine's physical memory


def physical_memory() -> int:
    """Bytes of physical memory on this machine (0 when the system does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0


def gib(size: int) -> str:
    """`size` bytes in GiB to 3 digits (a size beyond the float range, from absurd inputs, too)."""
    return f"{size / 2**30:.3g}" if size < 2**1000 else "more than 1e+291"


def check_memory(needed: int, limit: int | None, what: str, fix: str = "") -> None:
    """SolveError (a command that cannot run as asked) when `needed` bytes exceed `limit`
    (default MEMORY_FRACTION of physical memory); `fix` says what to make smaller."""
    if limit is None:
        limit = int(MEMORY_FRACTION * physical_memory())
    if limit > 0 and needed > limit:
        raise SolveError(
            f"{what} needs about {gib(needed)} GiB, more than the {gib(limit)} GiB allowed; "
            + (fix or "use a smaller population, batch or generation budget")
            + ", or raise the limit (Settings(memory_limit=BYTES), --memory-limit GIB)"
        )

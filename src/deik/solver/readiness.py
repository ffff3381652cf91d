"""Whether the CPU kernels for a dtype are compiled already, so a command can say that it is
about to compile before the user waits in silence.

Numba keeps compiled kernels in memory for the process and on disk (deik.kernels.targets's cache
locators); a kernel counts as ready when the DE loop for the dtype is in either. The on-disk
check reads Numba's cache index, which is not a public API: if it cannot be read, the kernels
count as not ready (the worst outcome is a note that turns out unneeded).
"""

from __future__ import annotations

COMPILE_NOTE = (
    "deik: compiling the CPU kernels for {dtype} first (once after an install or upgrade: 1-2 minutes on "
    "2 cores, measured by `deik warmup`, which does it ahead of time)"
)


def kernels_ready(dtype: str) -> bool:
    """True when the CPU DE loop for `dtype` ("float32" or "float64") is compiled in this process
    or cached on disk."""
    from deik.kernels import cpu

    dispatcher = cpu.start.entry
    if any(dtype in str(signature) for signature in dispatcher.signatures):
        return True
    try:
        index = dispatcher._cache._cache_file._load_index()
    except Exception:  # a Numba without this private API, or an unreadable cache
        return False
    return any(dtype in str(key[0]) for key in index)


def compile_note(dtype: str) -> str:
    """The one line to print before compiling."""
    return COMPILE_NOTE.format(dtype=dtype)

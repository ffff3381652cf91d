"""Small pieces the command-line modules share: the usage error, number parsing, output checks."""

from __future__ import annotations

import argparse
import math
import os

class UsageError(Exception):
    """A mistake in the command line or its inputs: reported in one line, exit status 2."""


class Parser(argparse.ArgumentParser):
    """argparse that raises UsageError instead of printing usage and exiting."""

    def error(self, message):
        raise UsageError(f"{message} (see `{self.prog} --help`)")


def numbers(flag: str, words) -> list[float]:
    """Finite floats from command-line words; UsageError naming `flag` otherwise."""
    values = []
    for word in words:
        try:
            value = float(word)
        except ValueError:
            raise UsageError(f"{flag}: {word!r} is not a number") from None
        if not math.isfinite(value):
            raise UsageError(f"{flag}: {word!r} is not a finite number")
        values.append(value)
    return values


def check_output(flag: str, path, suffixes=None) -> None:
    """UsageError unless `path` (when given) is in an existing folder and ends in one of
    `suffixes` (when given)."""
    if path is None:
        return
    if not os.path.isdir(os.path.dirname(os.path.abspath(path))):
        raise UsageError(f"{flag}: folder {os.path.dirname(os.path.abspath(path))!r} does not exist")
    if suffixes and os.path.splitext(path)[1].lower() not in suffixes:
        raise UsageError(f"{flag}: {path!r} must end in {' or '.join(suffixes)}")


def check_device(device: str) -> None:
    """UsageError when `device` is "gpu" and no usable CUDA GPU is here."""
    if device != "gpu":
        return
    try:
        from numba import cuda
    except ImportError:
        raise UsageError('--device gpu needs numba-cuda: pip install "deik[gpu]"') from None
    if not cuda.is_available():
        raise UsageError("--device gpu: no CUDA GPU is available here; use --device cpu")

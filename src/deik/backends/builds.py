"""Which build of the CPU kernels serves a problem: the switches its term kinds need
(deik.device.compiled_kinds) and a build compiled for them or for more kinds, in this process or
cached on disk; else the problem's own, to compile.

A build for fewer kinds compiles faster (a reach-only problem leaves out the orientation,
centre of mass, support polygon and self-collision code), and one for more serves every problem
whose kinds it covers with the same answers (a problem reaches only the branches of its own
kinds): after `deik warmup`, which compiles the build for every kind, nothing compiles again.
"""

from __future__ import annotations

import glob
import os
import re
from collections.abc import Callable

import numpy as np

from deik.backends.targets import ALL_KINDS, build_suffix, cpu_entry
from deik.device.compiled_kinds import SWITCHES
from deik.objectives.kinds import TERM_KIND

_KIND_SWITCH = {kind: name for name, kinds in SWITCHES.items() for kind in kinds}
_ORDER = tuple(SWITCHES)
_switches_seen: dict[int, tuple[np.ndarray, frozenset[str]]] = {}  # id(term_int) -> (term_int, its switches)


def switches_of(term_int: np.ndarray) -> frozenset[str]:
    """The switches a term table (T, ...) needs: those of the kinds in its TERM_KIND column
    (worked out once per array: an Engine's term table never changes)."""
    seen = _switches_seen.get(id(term_int))
    if seen is None or seen[0] is not term_int:
        switches = frozenset(_KIND_SWITCH[int(kind)] for kind in term_int[:, TERM_KIND])
        seen = _switches_seen[id(term_int)] = (term_int, switches)
    return seen[1]


def name_of(switches: frozenset[str]) -> str:
    """A build's name in notes: "every kind", or its switches' kinds, e.g. "position, orientation"."""
    if switches == ALL_KINDS:
        return "every kind"
    return ", ".join(name.removesuffix("_ON").lower().replace("_", " ") for name in _ORDER if name in switches)


def switches_named(text: str) -> frozenset[str]:
    """The switches of a name_of text."""
    if text == "every kind":
        return ALL_KINDS
    return frozenset(part.strip().upper().replace(" ", "_") + "_ON" for part in text.split(","))


def _from_suffix(suffix: str) -> frozenset[str]:
    """The switches of build_suffix's "" or "_kXXX"."""
    if not suffix:
        return ALL_KINDS
    mask = int(suffix[2:], 16)
    return frozenset(name for k, name in enumerate(_ORDER) if mask >> k & 1)


def cached_builds(kernel: str) -> list[frozenset[str]]:
    """The builds whose `kernel` entry has a cache index on disk (any signature, fresh or not)."""
    folder = cpu_entry(kernel).cache_folder
    if folder is None:
        return []
    found = []
    pattern = re.compile(rf"cpu_kernels\.{kernel}(_k[0-9a-f]+)?-\d+\.py\d+.*\.nbi$")
    for path in glob.glob(os.path.join(glob.escape(folder), f"cpu_kernels.{kernel}*.nbi")):
        match = pattern.match(os.path.basename(path))
        if match:
            found.append(_from_suffix(match.group(1) or ""))
    return found


def ready_build(kernel: str, switches: frozenset[str], accepts: Callable[[tuple], bool]) -> frozenset[str] | None:
    """The build covering `switches` whose `kernel` entry is compiled in this process or cached
    for this machine with a signature `accepts` takes (the one for exactly these switches
    first, then those for the fewest more), or None."""
    candidates = {switches, *(b for b in cached_builds(kernel) if b >= switches)}
    for build in sorted(candidates, key=lambda b: (b != switches, len(b), build_suffix(b))):
        if any(accepts(signature) for signature in cpu_entry(kernel, build).ready_signatures()):
            return build
    return None

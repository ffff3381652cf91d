"""The length unit of a clip: BVH files do not say it, so it is given or guessed from the size.

A person's span (the longest path of bone offsets from the root to a joint or end site, root
translations left out) is about 1 m: a skeleton spanning under 10 units is taken to be in
metres, under 1000 in centimetres, else in millimetres (inches, 40 units for a person, read
as centimetres: give them).
"""

from __future__ import annotations

import numpy as np

from deik.errors import InputError
from deik.model.skeleton import Skeleton

METRES = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}


def span(skeleton: Skeleton) -> float:
    """The longest path of bone offsets from the root to a joint or site, length units."""
    depth = np.zeros(skeleton.n_joints)
    for k in range(1, skeleton.n_joints):
        depth[k] = depth[skeleton.parents[k]] + np.linalg.norm(skeleton.offsets[k])
    sites = depth[skeleton.site_joint] + np.linalg.norm(skeleton.site_offset, axis=1)
    return float(max(depth.max(initial=0.0), sites.max(initial=0.0)))


def guess_unit(skeleton: Skeleton) -> str:
    """The unit "m", "cm" or "mm" of `skeleton` by its span (see the module notes)."""
    size = span(skeleton)
    return "m" if size < 10 else "cm" if size < 1000 else "mm"


def metres_per_unit(unit: str) -> float:
    """Metres in one `unit` (a key of METRES); ValueError naming the choices otherwise."""
    if unit not in METRES:
        raise InputError(f"unknown length unit {unit!r}; use one of {', '.join(METRES)}")
    return METRES[unit]

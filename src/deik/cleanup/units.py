"""The length unit a clip's reports are written in: BVH files do not say it, so it is given or
taken from the body's size. Nothing but reports needs it: every size a fix uses is a share of
the body's own (cleanup/body.py).

A person spans about 2 m from one end of the body to another (cleanup/body.py, `span`; about
1 m from the root to the farthest joint or end site, skeleton `span` below): a body spanning
under 8 units (a person is 1.7-3.4 by either measure of span) is read as metres; under 70 as
"cmu", the unit of the CMU motion-capture database's BVH files (its skeletons are measured in
1/0.45 inch, 5.644 cm, and a person spans 30-60 of them: read as centimetres, a 39-unit walk was
a 39 cm doll whose gravity, in its units, was 5.6 times too strong); under 1000 as centimetres
(a body up to 10 m), else as millimetres (a child of 1.1 m spans 1,760 of them). Inches, 100
units for a person, are read as centimetres: give them.
"""

from __future__ import annotations

import numpy as np

from deik.errors import InputError
from deik.model.skeleton import Skeleton

METRES = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "cmu": 0.0254 / 0.45}


def span(skeleton: Skeleton) -> float:
    """The longest path of bone offsets from the root to a joint or site, length units."""
    depth = np.zeros(skeleton.n_joints)
    for k in range(1, skeleton.n_joints):
        depth[k] = depth[skeleton.parents[k]] + np.linalg.norm(skeleton.offsets[k])
    sites = depth[skeleton.site_joint] + np.linalg.norm(skeleton.site_offset, axis=1)
    return float(max(depth.max(initial=0.0), sites.max(initial=0.0)))


def unit_of_span(size: float) -> str:
    """The unit "m", "cmu", "cm" or "mm" of a body spanning `size` units from end to end (module notes)."""
    return "m" if size < 8 else "cmu" if size < 70 else "cm" if size < 1000 else "mm"


def guess_unit(skeleton: Skeleton) -> str:
    """The unit "m", "cmu", "cm" or "mm" of `skeleton` by its span from the root (twice that from end
    to end; module notes)."""
    return unit_of_span(2.0 * span(skeleton))


def metres_per_unit(unit: str) -> float:
    """Metres in one `unit` (a key of METRES); ValueError naming the choices otherwise."""
    if unit not in METRES:
        raise InputError(f"unknown length unit {unit!r}; use one of {', '.join(METRES)}")
    return METRES[unit]

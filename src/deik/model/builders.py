"""Builders for the paper's serial chains: `chain(n_links, dims=2 or 3)`."""

from __future__ import annotations

import math

from deik.errors import InputError
from deik.model.build import build_skeleton
from deik.model.joints import Joint, Site, euler, hinge
from deik.model.skeleton import Skeleton

MAX_CHAIN_LINKS = 100_000  # far beyond any character; a larger chain only exhausts memory


def chain(
    n_links: int,
    dims: int = 2,
    link_length: float = 1.0,
    lower: float = -math.pi,
    upper: float = math.pi,
    mass: float = 1.0,
) -> Skeleton:
    """A serial chain of `n_links` links of `link_length` along +X, rooted at the origin.

    dims=2: one hinge about Z per joint (a planar chain in XY); dims=3: two rotations per joint
    (Euler "ZY", a ball joint without twist). Joints are `link0..link{n-1}` with a point mass
    `mass` (kg) at each; the site `tip` is the end effector. Reach is n_links * link_length.
    Named "chain:N" (planar) or "chain3d:N", as the CLI spells them.
    """
    if isinstance(n_links, bool) or not isinstance(n_links, int) or not 1 <= n_links <= MAX_CHAIN_LINKS:
        raise InputError(f"n_links must be an integer from 1 to {MAX_CHAIN_LINKS}, got {n_links!r}")
    if dims not in (2, 3):
        raise InputError(f"dims must be 2 or 3, got {dims!r}")
    if not (math.isfinite(link_length) and link_length > 0):
        raise InputError(f"link_length must be a positive finite length, got {link_length!r}")
    joints = []
    for k in range(n_links):
        dofs = hinge((0, 0, 1), lower, upper, label="Zrotation") if dims == 2 else euler("ZY", lower, upper)
        offset = (0.0, 0.0, 0.0) if k == 0 else (link_length, 0.0, 0.0)
        parent = None if k == 0 else f"link{k - 1}"
        joints.append(Joint(f"link{k}", parent, offset, dofs, mass=mass))
    tip = Site("tip", f"link{n_links - 1}", (link_length, 0.0, 0.0))
    name = f"chain:{n_links}" if dims == 2 else f"chain3d:{n_links}"
    return build_skeleton(joints, sites=[tip], up=(0.0, 1.0, 0.0), name=name)

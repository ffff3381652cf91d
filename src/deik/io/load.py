"""One entry point for every skeleton a user can name: a BVH file, a URDF file or a built-in."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.io.files import FilePath
from deik.model.skeleton import Skeleton

URDF_UP = (0.0, 0.0, 1.0)
SKELETON_FORMS = "'chain:N' (planar chain of N links), 'chain3d:N' (3-D chain), 'humanoid', or a .bvh or .urdf file"


@dataclass(frozen=True)
class Loaded:
    """A skeleton, the clip it came with (BVH only, else None), where it came from (`kind`:
    "bvh", "urdf" or "builtin") and where its masses came from."""

    skeleton: Skeleton
    kind: str
    clip: object = None
    mass_source: str = ""


def load_skeleton(
    spec: str,
    *,
    base: str | None = None,
    tip: str | Sequence[str] | None = None,
    segments: FilePath | None = None,
    up: ArrayLike | None = None,
    free_translations: bool = False,
) -> Loaded:
    """Load `spec`: a path ending in .bvh or .urdf, or "chain:N", "chain3d:N", "humanoid".
    `base`/`tip` (link names) apply to URDF only, `up` (3,) to URDF and BVH; `segments` (a segment table
    path) and `free_translations` (let solves move the position channels below the first joint
    that translates, deik.io.bvh.read_bvh) to BVH only; giving one for another kind is a
    ValueError."""
    suffix = Path(str(spec)).suffix.lower()
    urdf_only = {"--base": base, "--tip": tip}
    misplaced = [flag for flag, value in urdf_only.items() if value is not None and len(value) > 0]
    if suffix != ".urdf" and misplaced:
        raise InputError(f"{', '.join(misplaced)} only apply to a URDF robot, not {spec!r}")
    if suffix not in (".urdf", ".bvh") and up is not None:
        raise InputError(f"--up only applies to a URDF robot or a BVH character, not {spec!r}")
    if suffix != ".bvh" and segments is not None:
        raise InputError(f"--segments only applies to a BVH character, not {spec!r}")
    if suffix != ".bvh" and free_translations:
        raise InputError(f"--free-translations only applies to a BVH character, not {spec!r}")
    if suffix == ".bvh":
        from deik.io.bvh import read_bvh

        clip = read_bvh(spec, segments=segments, free_translations=free_translations, up=up)
        return _loaded(Loaded(clip.skeleton, "bvh", clip, clip.mass_source))
    if suffix == ".urdf":
        from deik.io.urdf import read_urdf

        skeleton = read_urdf(spec, base=base, tip=tip or None, up=URDF_UP if up is None else up)
        return _loaded(Loaded(skeleton, "urdf", None, f"URDF <inertial> masses ({skeleton.total_mass:g} kg)"))
    skeleton = skeleton_from_spec(spec)
    return _loaded(Loaded(skeleton, "builtin", None, f"built-in {skeleton.name} ({skeleton.total_mass:g} kg)"))


def _loaded(loaded: Loaded) -> Loaded:
    """`loaded`, described on the "deik" logger's debug level."""
    sk = loaded.skeleton
    logging.getLogger(__name__).debug(
        "loaded %s (%s): %d joints, %d DOFs, %d sites; masses: %s",
        sk.name,
        loaded.kind,
        sk.n_joints,
        sk.n_dofs,
        len(sk.site_names),
        loaded.mass_source,
    )
    return loaded


def skeleton_from_spec(spec: str) -> Skeleton:
    """Built-in skeleton from "chain:N" (planar, N unit links), "chain3d:N" or "humanoid"."""
    from deik.model.builders import chain
    from deik.model.humanoid import humanoid

    kind, _, count = str(spec).partition(":")
    if kind == "humanoid" and not count:
        return humanoid()
    if kind in ("chain", "chain3d") and count.isdigit() and len(count) <= 12 and int(count) >= 1:
        return chain(int(count), dims=2 if kind == "chain" else 3)
    raise InputError(f"unknown skeleton {spec!r}; use {SKELETON_FORMS}")

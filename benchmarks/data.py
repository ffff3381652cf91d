"""Where the real data is: the BVH clips and URDF robots that live beside the checkout.

One lookup for the benchmarks and the tests (tests/helpers.py): `$DEIK_SHARED_DATA` when set,
else `shared/data` next to the project folder, as a clone beside `shared/` has it.
`DEIK_SHARED_DATA=/nonexistent` runs everything as a clone without the data would.
"""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]  # the checkout


def shared_data(*parts: str) -> Path:
    """The shared data folder, or a path inside it (not checked: see `need`)."""
    return Path(os.environ.get("DEIK_SHARED_DATA") or ROOT.parent / "shared" / "data").joinpath(*parts)


def need(*parts: str) -> Path:
    """A path inside the shared data folder that a benchmark cannot run without; stops with one
    line naming it and the fix when it is missing."""
    path = shared_data(*parts)
    if not path.exists():
        raise SystemExit(
            f"{path} is missing: this benchmark needs the shared data (clone beside shared/ or set DEIK_SHARED_DATA)"
        )
    return path

"""Shared test fixtures: the real data in ../shared/data beside the project checkout."""

from pathlib import Path

import pytest

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def shared_path(*parts: str) -> Path:
    """A path inside the real data folder; the calling test skips when the folder is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"the real test data is not at {SHARED_DATA} (clone the project beside shared/)")
    return SHARED_DATA.joinpath(*parts)


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The folder of real BVH clips and URDF robots; tests that need it skip when it is absent."""
    return shared_path()

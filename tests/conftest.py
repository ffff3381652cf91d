"""Test configuration: the `shared_data` fixture, and the markers that say what a test needs.

- shared_data: the real BVH clips and URDF robots (helpers.SHARED_DATA). Every test that uses
  the `shared_data` fixture gets the marker here; the tests skip, with the reason, when the
  folder is absent.
- gpu: a real CUDA GPU; skipped, with the reason, on a machine without one. Tests that run the
  CUDA kernels in Numba's simulator are not gpu tests.
- slow: over about 20 s on a two-core machine; `pytest -m "not slow"` leaves them out.

The suite runs the modules that hold slow tests first, and `make test` spreads the tests over the
cores (pytest-xdist, --dist loadgroup) with the tests of a module that share a module-scoped
fixture kept on one worker.
"""

from pathlib import Path

import pytest

from helpers import SHARED_DATA_REASON, _Running, shared_data_present, shared_path


def _gpu_available() -> bool:
    try:
        from numba import cuda

        return bool(cuda.is_available())
    except Exception:  # noqa: BLE001 - no numba-cuda, no driver, the simulator: no real GPU either way
        return False


def pytest_sessionstart(session):
    """Load the CPU kernels' build for every goal kind (compiling it once per checkout, side by
    side): it serves every problem (deik.backends.builds), so the suite compiles it alone instead
    of one build per set of goal kinds its tests happen to use. The tests of the per-kind builds
    choose theirs (tests/backends/test_compiling.py)."""
    from deik.solver.warmup import warmup

    warmup(["float32", "float64"], progress=False)


def _module(item) -> str:
    return item.nodeid.split("::", 1)[0]


def _shares_a_module_fixture(item) -> bool:
    info = getattr(item, "_fixtureinfo", None)
    return info is not None and any(defs[-1].scope == "module" for defs in info.name2fixturedefs.values() if defs)


def _slow_first(items) -> None:
    """Put the modules that hold a slow test first, and inside them the slow tests first unless
    the module's tests share a module fixture (those stay in order, so a run builds it once):
    `make test`'s workers (pytest-xdist) take the tests in this order, and the longest ones
    started early leave the short ones to fill both workers at the end."""
    slow_modules = {_module(item) for item in items if item.get_closest_marker("slow") is not None}
    kept_together = {_module(item) for item in items if _shares_a_module_fixture(item)}

    def order(item):
        in_place = _module(item) in kept_together or item.get_closest_marker("slow") is not None
        return _module(item) not in slow_modules, not in_place

    items.sort(key=order)


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the xdist_group marks
def pytest_collection_modifyitems(config, items):
    """Mark the shared_data tests and skip them without the data, skip the gpu tests without a
    GPU, run the slow tests first, and keep the tests that share a module fixture on one worker
    (one xdist_group per module) so that the fixture is built once."""
    for item in items:
        if _shares_a_module_fixture(item):
            item.add_marker(pytest.mark.xdist_group(_module(item)))
    _slow_first(items)
    for item in items:
        if "shared_data" in getattr(item, "fixturenames", ()) and item.get_closest_marker("shared_data") is None:
            item.add_marker(pytest.mark.shared_data)
    if not shared_data_present():
        for item in items:
            if item.get_closest_marker("shared_data") is not None:
                item.add_marker(pytest.mark.skip(reason=SHARED_DATA_REASON))
    gpu_tests = [item for item in items if item.get_closest_marker("gpu") is not None]
    if gpu_tests and not _gpu_available():
        for item in gpu_tests:
            item.add_marker(pytest.mark.skip(reason="no CUDA GPU on this machine: run the gpu tests on one"))


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    _Running.test = item.nodeid
    _Running.marked = item.get_closest_marker("shared_data") is not None


def pytest_runtest_teardown(item):
    _Running.test = None
    _Running.marked = False


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The folder of real BVH clips and URDF robots; the tests that use it are marked shared_data."""
    return shared_path()

"""Test configuration: the `shared_data` fixture, and the markers that say what a test needs.

- shared_data: the real BVH clips and URDF robots (helpers.SHARED_DATA). Every test that uses
  the `shared_data` fixture gets the marker here; the tests skip, with the reason, when the
  folder is absent.
- gpu: a real CUDA GPU; skipped, with the reason, on a machine without one. Tests that run the
  CUDA kernels in Numba's simulator are not gpu tests.
- slow: over about 20 s on a two-core machine; `pytest -m "not slow"` leaves them out.

The suite runs the modules that hold slow tests first; `make test` spreads the modules over the
cores (pytest-xdist, --dist loadfile: a module's tests share one worker and its module fixtures).
"""

import signal
from pathlib import Path

import pytest

from helpers import SHARED_DATA_REASON, _Running, shared_data_present, shared_path


def _gpu_available() -> bool:
    try:
        from numba import cuda

        return bool(cuda.is_available())
    except Exception:  # noqa: BLE001 - no numba-cuda, no driver, the simulator: no real GPU either way
        return False


def pytest_configure(config):
    """A suite started as a background job of a shell without job control (`make test &` in a
    script) inherits SIGINT ignored, and so would every process its tests start: the tests that
    stop `deik view` or a solve with Ctrl-C would wait on them. Python's own Ctrl-C handling is
    put back (the tests' subprocesses then start with the default)."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_sessionstart(session):
    """Load the CPU kernels' build for every goal kind (compiling it once per checkout, side by
    side): it serves every problem (deik.backends.builds), so the suite compiles it alone instead
    of one build per set of goal kinds its tests happen to use. The tests of the per-kind builds
    choose theirs (tests/backends/test_compiling.py)."""
    from deik.solver.warmup import warmup

    warmup(["float32", "float64"], progress=False)


def _slow_first(items) -> None:
    """Put the modules that hold a slow test first, each module's tests together and in order:
    `make test`'s workers (pytest-xdist, --dist loadfile) take the modules in this order, and the
    longest started early leave the short ones to fill both workers at the end."""
    slow_modules = {item.path for item in items if item.get_closest_marker("slow") is not None}
    items.sort(key=lambda item: item.path not in slow_modules)


def pytest_collection_modifyitems(config, items):
    """Run the modules with slow tests first, mark the shared_data tests and skip them without
    the data, skip the gpu tests without a GPU."""
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

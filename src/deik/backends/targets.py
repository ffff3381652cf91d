"""Compile the one-source device maths (deik.device) for each target.

`cpu` is the device maths as linked functions (deik.backends.linking; without NRT, the helpers
each source lists in INLINE inlined by Numba); `cuda_device()` compiles the same sources with
numba.cuda.jit(device=True) on first use. Each puts copies of the functions into one fresh
module (compile_namespace), so every call between device functions resolves to the same
target's compiled function.

Numba's on-disk cache checks only the file a function lives in; the CPU kernels also depend on
the device files, so kernel files get a locator whose stamp hashes every source in this folder
and the values of the constants the device files import from outside it (Numba freezes them
into the machine code): a change to any of them recompiles all kernels instead of loading a
stale one.
"""

from __future__ import annotations

import hashlib
import importlib
import inspect
import re
import sys
import types
from functools import lru_cache
from pathlib import Path

from numba.core import caching

from deik.backends.linking import linked

DEVICE_DIR = Path(__file__).resolve().parent.parent / "device"
BACKEND_DIR = Path(__file__).resolve().parent
# every file whose compiled kernels depend on the device maths: the back-ends and the paper's
# compiled serial DE beside its experiments
SERIAL_KERNEL = BACKEND_DIR.parent / "experiments" / "serial_compiled.py"


@lru_cache(maxsize=1)
def _kernel_files() -> tuple[Path, ...]:
    """Every source the kernels' cache stamp covers, sorted."""
    return tuple(sorted([*DEVICE_DIR.glob("*.py"), *BACKEND_DIR.glob("*.py"), SERIAL_KERNEL]))


@lru_cache(maxsize=1)
def _outside_constants() -> bytes:
    """The module-level numbers of the deik modules outside this folder that the device files and
    layout.py import (term kinds, motion kinds): their values, not their files, so that an edit
    elsewhere in those modules keeps the cache."""
    modules = set()
    for path in DEVICE_DIR.glob("*.py"):
        modules |= set(re.findall(r"^from (deik\.[\w.]+) import", path.read_text(), re.MULTILINE))
    modules = {module for module in modules if not module.startswith("deik.device")}
    return repr(
        [
            (module, key, value)
            for module in sorted(modules)
            for key, value in sorted(vars(importlib.import_module(module)).items())
            if isinstance(value, (int, float))
        ]
    ).encode()


@lru_cache(maxsize=1)
def _kernel_sources_stamp() -> bytes:
    """Hash of every kernel source and of the outside constants they use (read once a process)."""
    digest = hashlib.sha256()
    for path in _kernel_files():
        digest.update(path.read_bytes())
    digest.update(_outside_constants())
    return digest.digest()


class _KernelStampMixin:
    """Use the hash of all kernel sources as the cache stamp; only for the kernel files."""

    def get_source_stamp(self):
        return _kernel_sources_stamp()

    @classmethod
    def from_function(cls, py_func, py_file):
        if Path(py_file).resolve() not in _kernel_files():
            return None
        return super().from_function(py_func, py_file)


def _register(locator_classes: list, bases: tuple) -> None:
    """Put the stamped kernel locators first in a cache implementation's locator list. Numba tries
    locators in order and takes the first whose folder it can write: NUMBA_CACHE_DIR when set,
    else the package's __pycache__, else (a read-only install) the user's cache folder."""
    for base in bases:
        name = f"_Stamped{base.__name__}"
        if not any(cls.__name__ == name and issubclass(cls, base) for cls in locator_classes):
            locator_classes.insert(0, type(name, (_KernelStampMixin, base), {}))


_register(
    caching.CacheImpl._locator_classes,
    (caching.UserWideCacheLocator, caching.InTreeCacheLocator, caching.UserProvidedCacheLocator),
)


@lru_cache(maxsize=1)
def register_cuda_kernel_cache() -> None:
    """The same stamped locators for numba-cuda's own cache (`cuda.jit(cache=True)` kernels):
    the CUDA kernels follow the CPU kernels' NUMBA_CACHE_DIR, read-only-install and
    invalidation rules. Nothing to do in the CUDA simulator, which caches nothing."""
    from deik.backends.gpu import simulated

    if simulated():
        return
    from numba.cuda.core import caching as cuda_caching

    _register(
        cuda_caching.CacheImpl._locator_classes,
        (cuda_caching._UserWideCacheLocator, cuda_caching._InTreeCacheLocator, cuda_caching._UserProvidedCacheLocator),
    )


def compile_namespace(sources, name: str, decorate, decorate_inline=None) -> types.ModuleType:
    """One new module `name` with the names of the modules `sources` and a copy of every
    function they define, bound to it and wrapped in `decorate`, or in `decorate_inline` for
    those a source lists in its INLINE tuple (when given): a call between device functions
    (imported from each other for linters and readers) resolves to the same target's compiled
    function, and other names (layout and term-kind constants) are the modules' own. Copies of
    the functions, not the sources run again: no parsing or compiling per process."""
    module = types.ModuleType(name)
    namespace = vars(module)
    for source in sources:
        namespace.update({key: value for key, value in vars(source).items() if not key.startswith("__")})
    namespace.pop("INLINE", None)
    for source in sources:
        inline = set(getattr(source, "INLINE", ())) if decorate_inline else set()
        for key, value in vars(source).items():
            if inspect.isfunction(value) and value.__module__ == source.__name__:
                copy = types.FunctionType(value.__code__, namespace, key, value.__defaults__, value.__closure__)
                copy.__qualname__, copy.__doc__ = value.__qualname__, value.__doc__
                namespace[key] = (decorate_inline if key in inline else decorate)(copy)
    sys.modules[name] = module
    return module


from deik.device import collision as device_collision  # noqa: E402
from deik.device import driver as device_driver  # noqa: E402
from deik.device import evolution as device_evolution  # noqa: E402
from deik.device import lanes as device_lanes  # noqa: E402
from deik.device import lm as device_lm  # noqa: E402
from deik.device import maths as device_maths  # noqa: E402
from deik.device import polish as device_polish  # noqa: E402
from deik.device import terms as device_terms  # noqa: E402

DEVICE_SOURCES = (
    device_maths,
    device_collision,
    device_terms,
    device_evolution,
    device_polish,
    device_lm,
    device_driver,
    device_lanes,
)
# The device maths never allocates, so it is compiled without Numba's reference counting: every
# array taken from a tuple or sliced would otherwise cost an atomic increment and decrement, which
# doubled the time of a small robot's fitness evaluation. The kernels in cpu.py that call it keep
# NRT (they allocate scratch); the device functions only borrow their arrays.
# The loops over SIMD lanes (device/lanes.py) call helpers inlined by Numba itself (INLINE):
# LLVM does not inline a helper whose vectorised loop makes it large, and the call would cost
# more than its lanes of work.
cpu = compile_namespace(
    DEVICE_SOURCES,
    "deik.backends._device_cpu",
    linked(nogil=True, _nrt=False),
    linked(nogil=True, _nrt=False, inline="always"),
)


@lru_cache(maxsize=1)
def cuda_device() -> types.ModuleType:
    """The device maths compiled for numba-cuda (or its simulator); loads numba-cuda lazily."""
    from deik.backends.gpu import numba_cuda

    cuda = numba_cuda()
    return compile_namespace(DEVICE_SOURCES, "deik.backends._device_cuda", cuda.jit(device=True))

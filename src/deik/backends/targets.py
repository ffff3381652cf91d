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
from functools import cache, lru_cache
from pathlib import Path

from numba.core import caching

from deik.backends.entries import Entry
from deik.backends.linking import LinkOnlyDispatcher
from deik.device.compiled_kinds import CENTRE_OF_MASS_SWITCHES, SWITCHES

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


def compile_namespace(sources, name: str, wrap, overrides: dict | None = None) -> types.ModuleType:
    """One new module `name` with the names of the modules `sources` and a copy of every
    function they define, bound to it and wrapped by `wrap(copy, original, inline)` (inline:
    the source lists it in its INLINE tuple): a call between device functions (imported from
    each other for linters and readers) resolves to the same target's compiled function, a
    source's name for another source module (`from deik.device import driver as device_driver`)
    names the new module, and other names (layout and term-kind constants) are the modules' own,
    except `overrides` (the switches of deik.device.compiled_kinds). Copies of the functions,
    not the sources run again: no parsing or compiling per process."""
    module = sys.modules.get(name) or types.ModuleType(name)  # cpu_entry may have named it already
    namespace = vars(module)
    for source in sources:
        namespace.update({key: value for key, value in vars(source).items() if not key.startswith("__")})
    namespace.pop("INLINE", None)
    for source in sources:
        inline = set(getattr(source, "INLINE", ()))
        for key, value in vars(source).items():
            if inspect.isfunction(value) and value.__module__ == source.__name__:
                copy = types.FunctionType(value.__code__, namespace, key, value.__defaults__, value.__closure__)
                copy.__qualname__, copy.__doc__ = value.__qualname__, value.__doc__
                namespace[key] = wrap(copy, value, key in inline)
    for key, value in list(namespace.items()):
        if isinstance(value, types.ModuleType) and value in sources:
            namespace[key] = module
    namespace.update(overrides or {})
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
# every switch of deik.device.compiled_kinds: a build with all of them serves every problem
ALL_KINDS = frozenset(SWITCHES)


def build_suffix(switches: frozenset[str]) -> str:
    """What a build's module and cache files are named with: "" for every kind, else "_k" and the
    switches as a hexadecimal mask in SWITCHES' order (names, so that two builds' machine code
    never shares a symbol in one process)."""
    if switches == ALL_KINDS:
        return ""
    return f"_k{sum(1 << k for k, name in enumerate(SWITCHES) if name in switches):03x}"


def _cpu_wrap(suffix: str):
    """compile_namespace's `wrap` for the CPU: every function a LinkOnlyDispatcher, with the
    options its `linked` mark gives (the kernels of deik.backends.cpu_kernels) or the device
    maths' own. The device maths never allocates, so it is compiled without Numba's reference
    counting: every array taken from a tuple or sliced would otherwise cost an atomic increment
    and decrement, which doubled the time of a small robot's fitness evaluation; the kernels
    that call it keep NRT (they allocate scratch). The loops over SIMD lanes (device/lanes.py)
    call helpers inlined by Numba itself (INLINE): LLVM does not inline a helper whose
    vectorised loop makes it large, and the call would cost more than its lanes of work."""

    def wrap(copy, original, inline: bool) -> LinkOnlyDispatcher:
        options = getattr(original, "linked_options", None)
        if options is None:
            options = {"nopython": True, "nogil": True, "_nrt": False, "forceinline": inline}
        else:  # explicit: a function compiled inside another's compile inherits the caller's
            options = {"forceinline": False, **options}
        return LinkOnlyDispatcher(copy, options, original, copy.__qualname__ + suffix)

    return wrap


@cache
def cpu_build(switches: frozenset[str] = ALL_KINDS) -> types.ModuleType:
    """The device maths and the CPU kernels (deik.backends.cpu_kernels, cpu_pose_kernels) compiled
    for the term kinds of `switches` (names of deik.device.compiled_kinds.SWITCHES; the others off), as one
    namespace of link-only functions. Nothing compiles until a kernel's entry point needs it."""
    from deik.backends import cpu_kernels, cpu_pose_kernels

    overrides = {name: name in switches for name in SWITCHES}
    overrides["CENTRE_OF_MASS_ON"] = bool(switches & CENTRE_OF_MASS_SWITCHES)
    overrides["COLUMNS_SPLIT"] = False  # one CPU thread forms every Jacobian column (device/polish.py)
    suffix = build_suffix(switches)
    sources = DEVICE_SOURCES + (cpu_kernels, cpu_pose_kernels)
    return compile_namespace(sources, f"deik.backends._cpu{suffix}", _cpu_wrap(suffix), overrides)


def cpu_entry(name: str, switches: frozenset[str] = ALL_KINDS) -> Entry:
    """The entry point of kernel `name` (a function of deik.backends.cpu_kernels or
    cpu_pose_kernels) in the build for `switches`: loading it from the cache builds nothing else
    (deik.backends.entries)."""
    from deik.backends import cpu_kernels, cpu_pose_kernels

    suffix = build_suffix(switches)
    # the build's module, empty until the build is made: what a cached kernel's environment
    # (its globals, for Numba) is loaded from
    module = f"deik.backends._cpu{suffix}"
    sys.modules.setdefault(module, types.ModuleType(module))
    source = cpu_kernels if hasattr(cpu_kernels, name) else cpu_pose_kernels
    return Entry.of(getattr(source, name), name + suffix, lambda: getattr(cpu_build(switches), name))


def __getattr__(attribute: str):
    """`cpu`: the build for every kind (the device maths and kernels as compiled for the CPU),
    made on first use."""
    if attribute == "cpu":
        return cpu_build()
    raise AttributeError(f"module {__name__!r} has no attribute {attribute!r}")


@lru_cache(maxsize=1)
def cuda_device() -> types.ModuleType:
    """The device maths compiled for numba-cuda (or its simulator); loads numba-cuda lazily."""
    from deik.backends.gpu import numba_cuda

    cuda = numba_cuda()
    device = cuda.jit(device=True)
    return compile_namespace(DEVICE_SOURCES, "deik.backends._device_cuda", lambda copy, original, inline: device(copy))

"""Loading numba-cuda, and every GPU failure turned into one DeviceError line.

Everything in deik that touches numba-cuda gets it from `numba_cuda()`: the NumPy guard below is
applied first, and a failure to load becomes a DeviceError that says what to do. `on_gpu(what)`
wraps every compile, copy and launch: a missing driver, a broken package, an NVVM or ptxas
error, an out-of-memory or a failed launch reaches the caller as `DeviceError("the GPU ...:
reason; fix")`, one line, with the original exception chained for a debugger.

The NumPy guard (docs/gpu.md, "NumPy 2.5"): numba-cuda 0.30.4 registers an overload for
`np.row_stack`, which NumPy 2.5 removed (it was an alias of `np.vstack`, deprecated since 2.0),
so the first CUDA compile fails with AttributeError. When the name is missing, and only then,
it is set to `np.vstack` before numba-cuda builds its typing registries; NumPy versions that
have it are left untouched.
"""

from __future__ import annotations

from contextlib import contextmanager
from functools import cache

import numpy as np

from deik.errors import DeikError, DeviceError

# names numba-cuda 0.30 registers overloads for that newer NumPy removed: name -> the function it aliased
NUMPY_ALIASES = {"row_stack": "vstack"}
INSTALL_HINT = 'pip install "deik[gpu]"'
CPU_HINT = "device='cpu' (--device cpu) runs the same solve on the CPU"


def guard_numpy() -> list[str]:
    """Put back the NumPy aliases numba-cuda needs where this NumPy lacks them; returns the names
    added (empty on a NumPy that has them all)."""
    added = [name for name in NUMPY_ALIASES if name not in vars(np)]
    for name in added:
        setattr(np, name, getattr(np, NUMPY_ALIASES[name]))
    return added


@cache
def numba_cuda():
    """The numba.cuda module, the NumPy guard applied first; DeviceError if it cannot be loaded."""
    guard_numpy()
    try:
        from numba import cuda
    except Exception as error:  # ImportError, or a package pairing that fails while loading
        raise DeviceError(
            f"the GPU path needs numba-cuda, which could not be loaded ({_reason(error)}): {INSTALL_HINT}, "
            f"or use {CPU_HINT}"
        ) from error
    return cuda


def simulated() -> bool:
    """Whether numba-cuda runs in its CUDA simulator (NUMBA_ENABLE_CUDASIM=1)."""
    from numba import config

    return bool(config.ENABLE_CUDASIM)


def gpu_available() -> bool:
    """Whether a GPU (or the simulator) can run the kernels here; never raises."""
    try:
        return bool(numba_cuda().is_available())
    except Exception:  # noqa: BLE001 - a missing or broken numba-cuda: no GPU
        return False


def require_gpu():
    """numba.cuda when an NVIDIA GPU (or the simulator) is usable, else DeviceError naming the fix."""
    cuda = numba_cuda()
    try:
        available = bool(cuda.is_available())
    except Exception as error:  # noqa: BLE001 - a broken driver or runtime
        raise DeviceError(f"the CUDA driver could not be queried ({_reason(error)}); use {CPU_HINT}") from error
    if not available:
        raise DeviceError(
            f"device='gpu' needs an NVIDIA GPU and its driver, and none is usable here; {CPU_HINT} "
            f"(numba-cuda is installed: {INSTALL_HINT} gives the CUDA runtime wheels)"
        )
    return cuda


def device_error(error: BaseException, what: str) -> DeviceError:
    """The DeviceError for `error` raised while `what` ("compiling the CUDA kernels", ...)."""
    text = _reason(error)
    lowered = text.lower()
    if "out_of_memory" in lowered or "out of memory" in lowered:
        return DeviceError(f"the GPU ran out of memory {what}: use a smaller batch or population, or {CPU_HINT}")
    if "row_stack" in text:
        return DeviceError(
            f"numba-cuda does not work with NumPy {np.__version__} ({text}); upgrade numba-cuda or {CPU_HINT}"
        )
    if "nvvm" in lowered or "ptxas" in lowered or "libdevice" in lowered:
        return DeviceError(
            f"the CUDA compiler failed {what} ({text}): reinstall the CUDA wheels ({INSTALL_HINT}) or {CPU_HINT}"
        )
    return DeviceError(f"the GPU failed {what} ({text}); {CPU_HINT}")


@contextmanager
def on_gpu(what: str):
    """Run a block of GPU work; any failure but deik's own errors and Ctrl-C leaves it as a
    DeviceError (device_error)."""
    try:
        yield
    except DeikError:
        raise
    except Exception as error:
        raise device_error(error, what) from error


def _reason(error: BaseException) -> str:
    """`Type: first line of the message` of an exception, at most 200 characters."""
    lines = str(error).strip().splitlines()
    line = lines[0] if lines else ""
    text = f"{type(error).__name__}: {line}" if line else type(error).__name__
    return text if len(text) <= 200 else text[:197] + "..."

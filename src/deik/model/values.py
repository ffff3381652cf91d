"""Numbers a caller gives, as float64 arrays: `real_array` refuses what NumPy would convert with
a loss (complex numbers, whose imaginary part would silently vanish) or cannot convert."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError


def real_array(value: ArrayLike, what: str) -> np.ndarray:
    """`value` as a float64 array; InputError naming `what` for complex numbers, booleans, strings,
    objects or ragged nesting (shape and finiteness are the caller's to check)."""
    if isinstance(value, np.ndarray) and value.dtype.kind in "fiu":
        return value.astype(np.float64, copy=False)
    try:
        raw = np.asarray(value)
    except ValueError:  # ragged nesting
        raise InputError(
            f"{what} must be numbers in a regular array (lists of equal length), got {value!r:.80}"
        ) from None
    if raw.dtype.kind == "c":
        raise InputError(f"{what} holds complex numbers; give real ones (deik drops no imaginary part silently)")
    if raw.dtype.kind == "b":
        raise InputError(f"{what} holds True/False, not numbers; give numbers, got {value!r:.80}")
    if raw.dtype.kind not in "fiu":
        raise InputError(f"{what} must be real numbers, got {value!r:.80}")
    try:
        return raw.astype(np.float64)
    except OverflowError:  # Python integers beyond the float range
        raise InputError(f"{what} holds a number too large for a 64-bit float") from None

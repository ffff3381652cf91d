"""deik.device.maths.sin_cos, the kernels' own sine and cosine, against NumPy.

The documented bound (device_maths.sin_cos, docs/performance.md): within 2.5 ulp of the
correctly rounded value for |x| <= 1e4 in float32 and float64, where an ulp is the spacing of
the dtype at the exact result. The reference is NumPy's sine of the same input in extended
precision (np.longdouble) where the platform has it, else in float64 (then float64 is held to
2.5 ulp plus NumPy's own error, one ulp).
"""

import math
import platform

import numpy as np
import pytest
from numba import njit

from deik.backends.targets import cpu as dev
from deik.device import maths as device_maths

EXTENDED = np.finfo(np.longdouble).nmant >= 63
BOUND_ULP = 2.5


@njit
def _sin_cos_all(x, s, c):
    for i in range(x.shape[0]):
        s[i], c[i] = dev.sin_cos(x[i], x)


def _inputs(dtype, limit, n, seed):
    """Random inputs in [-limit, limit] and the edge cases: zeros, tiny values, multiples of
    pi/4 (where the reduction switches quadrant and sine or cosine is near zero) and their
    neighbours one spacing away."""
    rng = np.random.default_rng(seed)
    quarters = np.arange(-int(limit / (math.pi / 4)), int(limit / (math.pi / 4)) + 1) * (math.pi / 4)
    quarters = quarters[:: max(1, len(quarters) // 4000)].astype(dtype)
    edges = np.concatenate(
        [
            [0.0, -0.0, 1e-30, -1e-30, 1e-8, math.pi, -math.pi, limit, -limit],
            quarters,
            np.nextafter(quarters, np.inf),
            np.nextafter(quarters, -np.inf),
        ]
    )
    return np.concatenate([rng.uniform(-limit, limit, n), edges]).astype(dtype)


def _ulp_errors(got, x, function, dtype):
    """|got - exact| in spacings of dtype at the exact value."""
    wide = np.longdouble if EXTENDED else np.float64
    exact = function(x.astype(wide))
    spacing = np.spacing(np.abs(exact.astype(dtype))).astype(wide)
    spacing = np.maximum(spacing, np.finfo(dtype).smallest_subnormal)
    return np.abs(got.astype(wide) - exact) / spacing


@pytest.mark.parametrize("limit", [math.pi, 100.0, 1e4])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_sin_cos_is_within_the_documented_ulps_of_numpy(dtype, limit):
    x = _inputs(dtype, limit, 100_000, 3)
    s, c = np.empty_like(x), np.empty_like(x)
    _sin_cos_all(x, s, c)
    bound = BOUND_ULP + (0 if EXTENDED or dtype == np.float32 else 1.0)
    for name, got, function in (("sin", s, np.sin), ("cos", c, np.cos)):
        errors = _ulp_errors(got, x, function, dtype)
        worst = int(np.argmax(errors))
        assert errors[worst] <= bound, f"{name}({x[worst]!r}) off by {errors[worst]:.2f} ulp"
    assert s.dtype == dtype and c.dtype == dtype


def test_exact_points_and_symmetries():
    x = np.array([0.0, -0.0, 1e-30], np.float64)
    s, c = np.empty_like(x), np.empty_like(x)
    _sin_cos_all(x, s, c)
    assert list(s) == [0.0, 0.0, 1e-30] and list(c) == [1.0, 1.0, 1.0]
    x = np.random.default_rng(5).uniform(-50, 50, 1000)
    s, c, s_neg, c_neg = (np.empty_like(x) for _ in range(4))
    _sin_cos_all(x, s, c)
    _sin_cos_all(-x, s_neg, c_neg)
    np.testing.assert_array_equal(s_neg, -s)  # odd and even, exactly: the reduction is symmetric
    np.testing.assert_array_equal(c_neg, c)
    np.testing.assert_allclose(s * s + c * c, 1.0, rtol=0, atol=4e-16)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_plain_python_gives_the_compiled_bits(dtype):
    """The CUDA simulator runs the device maths as Python on NumPy scalars: the same bits."""
    x = _inputs(dtype, 1e3, 300, 8)
    s, c = np.empty_like(x), np.empty_like(x)
    _sin_cos_all(x, s, c)
    with np.errstate(all="ignore"):
        plain = [device_maths.sin_cos(v, x) for v in x]
    np.testing.assert_array_equal(np.array([p[0] for p in plain], dtype), s)
    np.testing.assert_array_equal(np.array([p[1] for p in plain], dtype), c)
    assert all(type(p[0]) is dtype for p in plain)  # float32 stays float32


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="checks x86 SIMD instructions")
def test_the_lane_loops_compile_to_packed_float32_instructions():
    """The turn of a frame (sine, cosine, two columns) compiles to packed single-precision
    multiplies and a packed conversion for the quadrant: the loop over the lanes vectorised."""
    frames = np.zeros((12, 32), np.float32)
    gene = np.zeros(32, np.float32)
    one = np.float32(1.0)

    @njit
    def turn_frames(frames, gene):
        dev._turn(frames, 0, 1, gene, one, one, one)

    turn_frames(frames, gene)
    asm = next(iter(turn_frames.inspect_asm().values()))
    assert "vmulps" in asm or "mulps" in asm
    assert "cvttps2dq" in asm  # the quadrant of 4 to 16 lanes at once

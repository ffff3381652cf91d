"""This CPU's floating-point peak as Numba reaches it: independent fused multiply-adds in SIMD lanes.

    python -m benchmarks.peak [--seconds 0.005] [--repeats 200] [--out DIR]

Each thread keeps CHAINS x N values (32 KiB of float32: in the first-level cache) and applies
DEPTH fused multiply-adds, v = v * a + b, to each of the CHAINS values of a column in turn: the
loop over the columns vectorises (16 float32 or 8 float64 per 512-bit register), the CHAINS
chains and consecutive columns are independent, so the core overlaps enough of them to keep its
FMA units busy (with one chain per column the FMA's latency bound it to a third of this); one
load and one store per DEPTH FMAs keep memory out of the way. Compiled with fastmath={"contract"}
(multiply and add may fuse, nothing is reordered). GFLOP/s counts 2 per FMA, best of --repeats
short runs of about --seconds each (on the shared machine a long run measures its share of the
cores, a short one mostly runs whole between other processes' turns), on 1 thread and on as
many threads as Numba has (one array each). The DE kernel's rate is set against it in
docs/performance.md ("How close to the hardware").
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numba import njit

from benchmarks import harness

N, CHAINS, DEPTH = 2048, 4, 8  # values per chain and thread; independent chains per value; FMAs per chain and pass


@njit(fastmath={"contract"}, nogil=True)  # not cached: packed_fma reads its machine code
def _passes(v, a, b, passes):
    """`passes` passes over v (CHAINS, N) in place: CHAINS independent chains of DEPTH
    multiply-adds per column (one chain per column is bound by the FMA's latency)."""
    v0, v1, v2, v3 = v[0], v[1], v[2], v[3]  # rows: a 2-D index would carry the row length's stride
    for _ in range(passes):
        for i in range(v.shape[1]):
            x, y, z, w = v0[i], v1[i], v2[i], v3[i]
            for _ in range(DEPTH):
                x = x * a + b
                y = y * a + b
                z = z * a + b
                w = w * a + b
            v0[i], v1[i], v2[i], v3[i] = x, y, z, w


def _run(pool, values, a, b, passes) -> float:
    """Seconds of _passes on every values[t] (threads, CHAINS, N) at once, one thread of `pool`
    each (the kernel releases the GIL; a prange loop around it lost the rows' unit stride)."""
    t = time.perf_counter()
    list(pool.map(lambda v: _passes(v, a, b, passes), values))
    return time.perf_counter() - t


def gflops(dtype, threads: int, seconds: float, repeats: int) -> dict:
    """Best GFLOP/s of `threads` threads running _passes, calibrated to about `seconds` a run."""
    values = np.full((threads, CHAINS, N), 0.5, dtype)
    a, b = dtype(0.999999), dtype(1e-6)  # a fixed point at b / (1 - a) = 1: no overflow or subnormals
    with ThreadPoolExecutor(threads) as pool:
        _run(pool, values, a, b, 1)
        passes, elapsed = 1, 0.0
        while elapsed < seconds / 4:
            passes *= 2
            elapsed = min(_run(pool, values, a, b, passes) for _ in range(5))
        passes = max(1, int(passes * seconds / elapsed))
        runs = [_run(pool, values, a, b, passes) for _ in range(repeats)]
    flops = 2.0 * CHAINS * DEPTH * N * threads * passes
    return {
        "dtype": np.dtype(dtype).name,
        "threads": threads,
        "passes": passes,
        "seconds": runs,
        "gflops": flops / min(runs) / 1e9,
    }


def packed_fma(dtype) -> str:
    """The packed FMA instruction in _passes' machine code for dtype (register width), if any."""
    asm = next(asm for sig, asm in _passes.inspect_asm().items() if str(sig[0].dtype) == np.dtype(dtype).name)
    for register in ("zmm", "ymm", "xmm"):
        suffix = "ps" if dtype == np.float32 else "pd"
        if any(
            line.strip().startswith("vfmadd") and line.strip()[9:].startswith(suffix) and register in line
            for line in asm.splitlines()
        ):
            return f"vfmadd...{suffix} on {register}"
    return "none"


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--seconds", type=float, help="target seconds of one timed run (default 0.005)")
    p.add_argument("--repeats", type=int, help="timed runs, best kept (default 200)")
    run = harness.start("peak", p, argv, {"seconds": 0.005, "repeats": 200}, {"seconds": 0.002, "repeats": 3})
    args = run.args
    rows = [
        gflops(d, t, args.seconds, args.repeats)
        for d in (np.float32, np.float64)
        for t in sorted(set(harness.thread_counts("cpu")))
    ]
    instructions = {np.dtype(d).name: packed_fma(d) for d in (np.float32, np.float64)}
    fig, axes = harness.figure()
    for dtype, instruction in instructions.items():
        line = [(r["threads"], r["gflops"]) for r in rows if r["dtype"] == dtype]
        axes[0, 0].plot(*zip(*line), "o-", label=f"{dtype} ({instruction})")
    harness.style_axes(axes[0, 0], "threads", "GFLOP/s (2 per FMA)", "FMA peak as Numba reaches it")
    cells = [[r["dtype"], r["threads"], f"{r['gflops']:.1f}", instructions[r["dtype"]]] for r in rows]
    body = harness.md_table(["dtype", "threads", "GFLOP/s", "instruction"], cells)
    figures = {f"{r['dtype']}, {r['threads']} thread(s), GFLOP/s": r["gflops"] for r in rows}
    result = {
        "values_per_chain": N,
        "chains": CHAINS,
        "fmas_per_chain": DEPTH,
        "instructions": instructions,
        "rows": rows,
    }
    return run.finish(result, body, fig, figures)


if __name__ == "__main__":
    main()

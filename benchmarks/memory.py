"""Peak host and device memory of the parallel DE engine vs population and batch size.

    PYTHONPATH=src python -m benchmarks.memory [--device cpu|gpu] [--quick] [--out DIR]
        [--populations 1000 10000 100000] [--batches 1 100 1000 10000] [--generations 3]

Each configuration builds its problem, initialises an Engine (polish and restarts off, every
generation runs) and runs --generations generations, measured on its own:
- host, NumPy: the tracemalloc peak above the start (NumPy reports its buffers to tracemalloc);
- host, process: the peak resident set size (VmHWM, reset through /proc/self/clear_refs) above
  the resident size at the start; where the reset is refused, the process-lifetime peak;
- device (--device gpu): numba.cuda's free memory at the start minus the least free memory
  seen after Engine.init and after Engine.run, each inside cuda.defer_cleanup() so nothing
  they allocated has been released yet.
"state bytes" is one copy of the population state (pop, levels, total, raw, rates). Rows vs
population: the 100-link chain, one problem; vs batch: the 20-link chain, population 64. The
target: population 100,000 on the 100-link chain fits in 1 GiB (host, and device on the GPU).
Writes memory.json and memory.png into --out.
"""

from __future__ import annotations

import gc
import math
import time
import tracemalloc

import deik
from benchmarks import harness

GIB = 2**30
TARGET_POPULATION, TARGET_LINKS = 100_000, 100


def mib(size) -> str:
    """Bytes as MiB with one decimal; "-" for None (not measured)."""
    return "-" if size is None else f"{size / 2**20:.1f}"


def process_memory() -> dict:
    """{"VmRSS": bytes, "VmHWM": bytes} of this process (Linux /proc/self/status)."""
    out = {}
    with open("/proc/self/status", encoding="ascii") as status:
        for line in status:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                out[key] = int(value.split()[0]) * 1024
    return out


def reset_peak_rss() -> bool:
    """Reset VmHWM to the current resident size; False where the kernel refuses."""
    try:
        with open("/proc/self/clear_refs", "w", encoding="ascii") as refs:
            refs.write("5")
        return True
    except OSError:
        return False


class DeviceMeter:
    """Least free device memory seen (bytes), from a starting point; inert on the CPU."""

    def __init__(self, device: str):
        self.cuda = None
        if device == "gpu":
            from numba import cuda

            self.cuda = cuda
            self.flush()
            self.start = self.least = cuda.current_context().get_memory_info()[0]

    def during(self, step):
        """step() with device frees deferred, so everything it allocated is still held when the
        free memory is read after it; then those frees run. Returns step()'s value."""
        if not self.cuda:
            return step()
        context = self.cuda.current_context()
        with self.cuda.defer_cleanup():
            out = step()
            self.cuda.synchronize()
            self.least = min(self.least, context.get_memory_info()[0])
        self.flush()
        return out

    def flush(self) -> None:
        """Free what numba.cuda has queued for freeing (the CUDA simulator queues nothing)."""
        pending = getattr(self.cuda.current_context(), "deallocations", None)
        if pending is not None:
            pending.clear()

    @property
    def used(self):
        """Peak device bytes used above the start, None on the CPU (or when not reported)."""
        used = self.start - self.least if self.cuda else math.nan
        return float(used) if math.isfinite(used) else None


def measure(links: int, population: int, batch: int, args) -> dict:
    """Peak memory (bytes) and seconds of one configuration."""
    gc.collect()
    reset = reset_peak_rss()
    rss = process_memory()["VmRSS"]
    tracemalloc.start()
    meter = DeviceMeter(args.device)
    t = time.perf_counter()
    engine = deik.Engine(
        harness.chain_problem(links, batch, args.seed),
        # a budget of the generations it runs: the history of a million-generation budget is
        # what the memory check refuses on a small machine (16 bytes per problem and generation)
        harness.evaluation_settings(population, args.device, args.dtype, args.seed, args.generations),
    )
    state = meter.during(engine.init)
    state = meter.during(lambda: engine.run(state, args.generations))
    seconds = time.perf_counter() - t
    numpy_peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    state_bytes = sum(a.nbytes for a in state.buffers)
    return {
        "links": links,
        "population": population,
        "batch": batch,
        "generations": args.generations,
        "seconds": seconds,
        "state_bytes": state_bytes,
        "host_numpy_peak_bytes": numpy_peak,
        "host_rss_peak_above_start_bytes": process_memory()["VmHWM"] - rss,
        "rss_peak_reset": reset,
        "device_peak_bytes": meter.used,
    }


def plot(rows: list[dict], device: str):
    fig, axes = harness.figure(2)
    for ax, key, label, _other in (
        (axes[0, 0], "population", "population (100-link chain, 1 problem)", "batch"),
        (axes[0, 1], "batch", "batch size (20-link chain, population 64)", "population"),
    ):
        part = sorted((r for r in rows if r["sweep"] == key), key=lambda r: r[key])
        x = [r[key] for r in part]
        ax.plot(x, [r["host_numpy_peak_bytes"] for r in part], "o-", label="host: NumPy peak (tracemalloc)")
        ax.plot(
            x, [max(r["host_rss_peak_above_start_bytes"], 1) for r in part], "s-", label="host: peak RSS above start"
        )
        ax.plot(x, [r["state_bytes"] for r in part], ":", color="grey", label="one copy of the state")
        if device == "gpu":
            ax.plot(x, [r["device_peak_bytes"] or 1 for r in part], "^-", label="device: peak used")
        ax.axhline(GIB, color="k", linestyle="--", linewidth=1, label="1 GiB")
        harness.style_axes(ax, label, "bytes", f"Peak memory vs {key} ({device.upper()})")
    fig.tight_layout()
    return fig


def main(argv=None) -> int:
    p = harness.parser(__doc__)
    p.add_argument("--populations", type=int, nargs="+", help="populations on the 100-link chain")
    p.add_argument("--batches", type=int, nargs="+", help="batch sizes on the 20-link chain, population 64")
    p.add_argument("--generations", type=int, help="generations run per configuration (default 3)")
    args = p.parse_args(argv)
    sizes = (
        {"populations": [200, 2000], "batches": [1, 10], "generations": 1}
        if args.quick
        else {"populations": [1000, 10_000, TARGET_POPULATION], "batches": [1, 100, 1000, 10_000], "generations": 3}
    )
    opening = harness.start(args, sizes)
    deik.solve(
        harness.chain_problem(5, 2, args.seed), population=8, generations=2, device=args.device, dtype=args.dtype
    )  # compile / load the kernels before measuring

    configs = [("population", TARGET_LINKS, pop, 1) for pop in args.populations]
    configs += [("batch", 20, 64, b) for b in args.batches]
    rows = []
    for sweep, links, population, batch in configs:
        row = {"sweep": sweep, **measure(links, population, batch, args)}
        rows.append(row)
        print(
            f"links {links:3d} population {population:6d} batch {batch:6d}: NumPy peak "
            f"{mib(row['host_numpy_peak_bytes'])} MiB, RSS peak +{mib(row['host_rss_peak_above_start_bytes'])} MiB, "
            f"device {mib(row['device_peak_bytes'])} MiB",
            flush=True,
        )

    big = max((r for r in rows if r["sweep"] == "population"), key=lambda r: r["population"])
    peak = max(big["host_numpy_peak_bytes"], big["host_rss_peak_above_start_bytes"], big["device_peak_bytes"] or 0)
    applies = big["population"] >= TARGET_POPULATION and (args.device == "cpu" or big["device_peak_bytes"] is not None)
    result = harness.finish(
        "memory",
        args,
        opening,
        {
            "settings": {
                "generations": args.generations,
                "dtype": args.dtype,
                "device": args.device,
                "quick": args.quick,
                "problem": "deik.chain(n), Position('tip', FK of random in-limit poses); polish and restarts off",
            },
            "rows": rows,
            "targets": [
                harness.target(
                    f"peak memory (host and {args.device}), population {big['population']}, {TARGET_LINKS} links",
                    GIB,
                    peak,
                    "bytes",
                    applies,
                    at_most=True,
                )
            ],
        },
        plot(rows, args.device),
    )
    harness.print_report(
        result,
        ["links", "population", "batch", "state MiB", "NumPy peak MiB", "RSS peak + MiB", "device MiB", "seconds"],
        [
            [
                r["links"],
                r["population"],
                r["batch"],
                mib(r["state_bytes"]),
                mib(r["host_numpy_peak_bytes"]),
                mib(r["host_rss_peak_above_start_bytes"]),
                mib(r["device_peak_bytes"]),
                f"{r['seconds']:.2f}",
            ]
            for r in rows
        ],
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

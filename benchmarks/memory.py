"""Peak host and device memory of the parallel DE engine against population and batch size.

    python -m benchmarks.memory [--device cpu|gpu] [--quick] [--populations 1000 10000 100000]
        [--batches 1 100 1000 10000] [--generations 3]

Each configuration builds its problem, initialises an Engine (polish and restarts off) and
runs --generations generations, measured on its own:
- host, NumPy: the tracemalloc peak (NumPy reports its buffers to tracemalloc);
- host, process: the peak resident set size (VmHWM, reset through /proc/self/clear_refs) above
  the resident size at the start; where the reset is refused, the process-lifetime peak;
- device (--device gpu): numba.cuda's free memory at the start minus the least free memory
  after Engine.init and after Engine.run, each inside cuda.defer_cleanup() so that nothing
  they allocated has been released yet.
"state bytes" is one copy of the population state (the engine holds three while it runs).
Against population: the 100-link chain, one problem; against batch: the 20-link chain,
population 64. Target: population 100,000 on the 100-link chain within 1 GiB.
"""

from __future__ import annotations

import gc
import tracemalloc

import deik
from benchmarks import harness

GIB = 2**30
TARGET_POPULATION, TARGET_LINKS = 100_000, 100


def process_memory(key: str) -> int:
    """VmRSS or VmHWM of this process in bytes (Linux /proc/self/status)."""
    with open("/proc/self/status", encoding="ascii") as status:
        return next(int(line.split()[1]) * 1024 for line in status if line.startswith(key + ":"))


def reset_peak_rss() -> bool:
    """Reset VmHWM to the current resident size; False where the kernel refuses."""
    try:
        with open("/proc/self/clear_refs", "w", encoding="ascii") as refs:
            refs.write("5")
        return True
    except OSError:
        return False


def device_peak(device: str, steps) -> tuple[object, float | None]:
    """Run each of `steps` (a function of the previous one's value) with device frees deferred,
    reading the free device memory after each; (last value, peak bytes used above the start, or
    None on the CPU)."""
    value = None
    if device != "gpu":
        for step in steps:
            value = step(value)
        return value, None
    from numba import cuda

    context = cuda.current_context()
    pending = getattr(context, "deallocations", None)  # what numba.cuda has queued for freeing
    flush = pending.clear if pending is not None else lambda: None
    flush()
    start = least = context.get_memory_info()[0]
    for step in steps:
        with cuda.defer_cleanup():
            value = step(value)
            cuda.synchronize()
            least = min(least, context.get_memory_info()[0])
        flush()
    return value, float(start - least)


def measure(links: int, population: int, batch: int, args) -> dict:
    """Peak memory (bytes) of one configuration."""
    gc.collect()
    reset = reset_peak_rss()
    rss = process_memory("VmRSS")
    tracemalloc.start()
    # a budget of the generations it runs: the history of a million-generation budget is what
    # the memory check refuses on a small machine (16 bytes per problem and generation)
    settings = harness.evaluation_settings(population, args.device, args.dtype, args.seed, args.generations)
    engine = deik.Engine(harness.chain_problem(links, batch, args.seed), settings)
    state, device = device_peak(args.device, [lambda _: engine.init(), lambda s: engine.run(s, args.generations)])
    numpy_peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return {
        "links": links,
        "population": population,
        "batch": batch,
        "state_bytes": sum(a.nbytes for a in state.buffers),
        "host_numpy_peak_bytes": numpy_peak,
        "host_rss_peak_above_start_bytes": process_memory("VmHWM") - rss,
        "rss_peak_reset": reset,
        "device_peak_bytes": device,
    }


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--populations", type=int, nargs="+", help="populations on the 100-link chain")
    p.add_argument("--batches", type=int, nargs="+", help="batch sizes on the 20-link chain, population 64")
    p.add_argument("--generations", type=int, help="generations run per configuration (default 3)")
    full = {"populations": [1000, 10_000, TARGET_POPULATION], "batches": [1, 100, 1000, 10_000], "generations": 3}
    run = harness.start("memory", p, argv, full, {"populations": [200, 2000], "batches": [1, 10], "generations": 1})
    args = run.args
    problem = harness.chain_problem(5, 2, args.seed)  # compile or load the kernels before measuring
    deik.solve(problem, population=8, generations=2, device=args.device, dtype=args.dtype)
    configs = [("population", TARGET_LINKS, pop, 1) for pop in args.populations]
    configs += [("batch", 20, 64, b) for b in args.batches]
    rows = [{"sweep": sweep, **measure(links, pop, batch, args)} for sweep, links, pop, batch in configs]

    big = max((r for r in rows if r["sweep"] == "population"), key=lambda r: r["population"])
    peak = max(big["host_numpy_peak_bytes"], big["host_rss_peak_above_start_bytes"], big["device_peak_bytes"] or 0)
    what = f"peak memory (host and {args.device}), population {big['population']}, {TARGET_LINKS} links"
    run.target(what, GIB, peak, "bytes", big["population"] >= TARGET_POPULATION, at_most=True)
    keys = {"host_numpy_peak_bytes": "NumPy peak", "host_rss_peak_above_start_bytes": "peak RSS above start"}
    keys |= {"state_bytes": "one copy of the state"} | (
        {"device_peak_bytes": "device peak"} if args.device == "gpu" else {}
    )
    fig, axes = harness.figure(2)
    for ax, sweep in zip(axes[0], ("population", "batch")):
        part = [r for r in rows if r["sweep"] == sweep]
        for key, label in keys.items():
            ax.plot([r[sweep] for r in part], [max(r[key] or 1, 1) for r in part], "o-", label=label)
        ax.axhline(GIB, color="k", linestyle="--", linewidth=1, label="1 GiB")
        harness.style_axes(ax, sweep, "bytes", f"peak memory against {sweep} ({args.device})")

    def mib(size) -> str:
        return "-" if size is None else f"{size / 2**20:.1f}"

    header = ["links", "population", "batch", *(f"{label} MiB" for label in keys.values())]
    cells = [[r["links"], r["population"], r["batch"], *(mib(r[key]) for key in keys)] for r in rows]
    figures = {f"{r['sweep']} {r[r['sweep']]}, {label}, bytes": r[key] for r in rows for key, label in keys.items()}
    settings = {"generations": args.generations, "dtype": args.dtype, "quick": args.quick}
    return run.finish({"settings": settings, "rows": rows}, harness.md_table(header, cells), fig, figures)


if __name__ == "__main__":
    main()

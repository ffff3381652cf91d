"""What the GPU kernels cost the hardware: registers, local and shared memory, occupancy.

    python -m benchmarks.gpu_kernels --device gpu [--quick] [--ncu] [--out DIR]

For each case (a 100-link chain batch in DE-only mode, the Panda with the default memetic
settings) the engine runs two generations so Numba compiles the kernels, then each kernel
reports registers per thread, local memory per thread (the polish's D x D matrix lives
there), shared memory per block, and the theoretical occupancy at the launch's block size:
resident blocks per multiprocessor from the thread, register, shared-memory and block limits
(`blocks_per_multiprocessor`), and which of them binds. With --ncu, Nsight Compute (when on
PATH) profiles one `run` launch of the throughput benchmark for achieved occupancy and compute
and memory throughput; its text goes to gpu_kernels_ncu.txt. In Numba's CUDA simulator the
resource queries do not exist and are reported as unavailable.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from dataclasses import dataclass

import deik
from benchmarks import harness, robot_targets

KERNELS = ("initialise", "start", "run")  # kernels_for's order
NCU_METRICS = (
    "sm__warps_active.avg.pct_of_peak_sustained_active,"
    "sm__throughput.avg.pct_of_peak_sustained_elapsed,"
    "dram__throughput.avg.pct_of_peak_sustained_elapsed,"
    "launch__registers_per_thread,launch__occupancy_limit_registers"
)


@dataclass(frozen=True)
class Multiprocessor:
    """Per-multiprocessor limits of a GPU (Hopper values as defaults)."""

    threads: int = 2048
    registers: int = 65536
    shared_bytes: int = 228 * 1024
    blocks: int = 32


def blocks_per_multiprocessor(threads: int, registers: int, shared_bytes: int, sm: Multiprocessor) -> tuple[int, str]:
    """(resident blocks per multiprocessor, the binding limit) for blocks of `threads` threads
    using `registers` per thread and `shared_bytes` per block. Registers are allocated per warp
    in units of 256."""
    warps = -(-threads // 32)
    per_warp = -(-registers * 32 // 256) * 256
    limits = {"threads": sm.threads // (warps * 32), "blocks": sm.blocks}
    if registers:
        limits["registers"] = sm.registers // (per_warp * warps)
    if shared_bytes:
        limits["shared memory"] = sm.shared_bytes // shared_bytes
    binding = min(limits, key=limits.get)
    return limits[binding], binding


def device_limits() -> Multiprocessor:
    """The current GPU's per-multiprocessor limits (defaults where Numba does not say)."""
    from numba import cuda

    dev = cuda.get_current_device()
    default = Multiprocessor()
    return Multiprocessor(
        threads=getattr(dev, "MAX_THREADS_PER_MULTIPROCESSOR", default.threads),
        registers=getattr(dev, "MAX_REGISTERS_PER_MULTIPROCESSOR", default.registers),
        shared_bytes=getattr(dev, "MAX_SHARED_MEMORY_PER_MULTIPROCESSOR", default.shared_bytes),
        blocks=getattr(dev, "MAX_BLOCKS_PER_MULTIPROCESSOR", default.blocks),
    )


def _resource(kernel, method: str):
    """One compiled signature's value of a Numba resource query, or None (simulator, or a
    kernel the case never launched)."""
    query = getattr(kernel, method, None)
    if query is None:
        return None
    value = query()
    return next(iter(value.values()), None) if isinstance(value, dict) else value


def cases(quick: bool) -> list[tuple[str, deik.Problem, deik.Settings]]:
    """(name, problem, settings) of each profiled case."""
    links, batch, population = (10, 4, 64) if quick else (100, 64, 500)
    chain = harness.chain_problem(links, batch, 0)
    out = [
        (
            f"chain {links} links x {batch} problems, DE only",
            chain,
            harness.evaluation_settings(population, "gpu", "float32", 0),
        )
    ]
    try:
        skeleton, case, _ = robot_targets.load_case("panda")
    except (SystemExit, OSError) as error:
        print(f"Panda case skipped: {error}", file=sys.stderr)
        return out
    targets = robot_targets.make_targets("panda", 4 if quick else 1024, seed=0)
    panda = deik.Problem(
        skeleton,
        [
            deik.Position(case.tip, targets["positions"], tolerance=5e-3),
            deik.Orientation(case.tip, targets["rotations"], tolerance=0.05),
        ],
    )
    return out + [
        (
            f"Panda x {len(targets['positions'])}, memetic defaults",
            panda,
            deik.Settings(population=32, device="gpu", dtype="float32"),
        )
    ]


def profile_case(name: str, problem: deik.Problem, settings: deik.Settings, sm: Multiprocessor) -> list[dict]:
    """One row per kernel of the case: resources and theoretical occupancy."""
    from deik.backends.cuda import CudaBackend, kernels_for

    engine = deik.Engine(problem, settings)
    state = engine.run(engine.init(), 2)
    engine.start(2)  # the lazy first population's kernel, where the settings use it
    threads = CudaBackend()._threads(settings.population)
    rows = []
    for label, kernel in zip(KERNELS, kernels_for(engine.skel, state.buffers)):
        regs = _resource(kernel, "get_regs_per_thread")
        local = _resource(kernel, "get_local_mem_per_thread")
        shared = _resource(kernel, "get_shared_mem_per_block")
        row = {
            "case": name,
            "kernel": label,
            "threads_per_block": threads,
            "registers_per_thread": regs,
            "local_bytes_per_thread": local,
            "shared_bytes_per_block": shared,
        }
        if regs is not None:
            blocks, binding = blocks_per_multiprocessor(threads, regs, shared or 0, sm)
            row.update(
                blocks_per_multiprocessor=blocks,
                binding_limit=binding,
                theoretical_occupancy=blocks * threads / sm.threads,
                local_bytes_resident=(local or 0) * blocks * threads,
            )
        rows.append(row)
    return rows


def run_ncu(args) -> dict:
    """Nsight Compute on one `run` launch of the throughput benchmark, or why it did not run."""
    ncu = shutil.which("ncu")
    if ncu is None:
        return {"ran": False, "why": "ncu is not on PATH"}
    command = [
        ncu,
        "--metrics",
        NCU_METRICS,
        "-k",
        "regex:run",
        "-c",
        "1",
        sys.executable,
        "-m",
        "benchmarks.throughput",
        "--device",
        "gpu",
        "--links",
        "100",
        "--configs",
        "chain100x1024",
        "--populations",
        "500",
        "--seconds",
        "0.05",
        "--repeats",
        "1",
        "--out",
        str(args.out / "ncu_run"),
    ]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=600)
    except subprocess.TimeoutExpired:
        return {"ran": False, "why": "ncu took over 600 s", "command": " ".join(command)}
    (args.out / "gpu_kernels_ncu.txt").write_text(done.stdout + done.stderr)
    return {
        "ran": done.returncode == 0,
        "returncode": done.returncode,
        "command": " ".join(command),
        "text": "gpu_kernels_ncu.txt",
    }


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--ncu", action="store_true", help="also profile one launch with Nsight Compute")
    run = harness.start("gpu_kernels", p, argv)
    args = run.args
    if args.device != "gpu":
        raise SystemExit("gpu_kernels profiles the CUDA kernels: run it with --device gpu")
    sm = device_limits()
    rows = [row for name, problem, settings in cases(args.quick) for row in profile_case(name, problem, settings, sm)]
    ncu = run_ncu(args) if args.ncu else {"ran": False, "why": "no --ncu"}
    shown = [r for r in rows if "theoretical_occupancy" in r]
    fig, axes = harness.figure()
    harness.bars(
        axes[0, 0],
        [f"{r['case']}: {r['kernel']}" for r in shown],
        [100 * r["theoretical_occupancy"] for r in shown],
        True,
    )
    harness.style_axes(
        axes[0, 0], "theoretical occupancy, %", "", "GPU kernels at the launch's block size", False, False
    )
    keys = ["threads_per_block", "registers_per_thread", "local_bytes_per_thread", "shared_bytes_per_block"]
    keys += ["blocks_per_multiprocessor", "binding_limit", "theoretical_occupancy"]
    cells = [[r["case"], r["kernel"], *("-" if r.get(k) is None else r[k] for k in keys)] for r in rows]
    body = harness.md_table(["case", "kernel", *keys], cells)
    figures = {f"{r['case']} {r['kernel']} {k}": r.get(k) for r in rows for k in keys[1:4] + keys[-1:]}
    return run.finish({"multiprocessor": vars(sm), "rows": rows, "ncu": ncu}, body, fig, figures)


if __name__ == "__main__":
    main()

"""The GPU benchmarks' code paths, run in Numba's CUDA simulator (no timing is meaningful
there), and the occupancy arithmetic of benchmarks.gpu_kernels."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks.gpu_kernels import Multiprocessor, blocks_per_multiprocessor

ROOT = Path(__file__).resolve().parents[2]
HOPPER = Multiprocessor(threads=2048, registers=65536, shared_bytes=228 * 1024, blocks=32)


@pytest.mark.parametrize(
    "threads, registers, shared, blocks, binding",
    [
        (128, 64, 0, 8, "registers"),  # 64 registers per thread: half the resident threads
        (128, 32, 0, 16, "threads"),  # full occupancy: threads and registers both allow 16 blocks
        (256, 255, 0, 1, "registers"),  # 255 registers round up to 8192 per warp
        (64, 16, 100 * 1024, 2, "shared memory"),
        (32, 16, 0, 32, "blocks"),  # 32-thread blocks: the 32-block limit leaves half the threads idle
    ],
)
def test_blocks_per_multiprocessor_matches_the_occupancy_calculator(threads, registers, shared, blocks, binding):
    assert blocks_per_multiprocessor(threads, registers, shared, HOPPER) == (blocks, binding)


def _simulated(module: str, out: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": f"{ROOT / 'src'}{os.pathsep}{ROOT}", "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run(
        [sys.executable, "-W", "ignore", "-m", f"benchmarks.{module}", "--device", "gpu", "--quick", "--out", str(out)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads((out / f"{module}.json").read_text())


def test_gpu_kernel_report_runs_in_the_simulator(tmp_path):
    result = _simulated("gpu_kernels", tmp_path)
    assert "simulator" in result["environment"]["gpu_name"]
    rows = result["rows"]
    assert {r["kernel"] for r in rows} == {"initialise", "start", "run"}  # start: the lazy first population
    for r in rows:  # the simulator has no resource queries: reported as unknown, never made up
        assert r["threads_per_block"] % 32 == 0 and r["registers_per_thread"] is None
        assert "theoretical_occupancy" not in r


@pytest.mark.slow
def test_gpu_throughput_benchmark_runs_in_the_simulator(tmp_path):
    result = _simulated("throughput", tmp_path)
    rows = result["rows"]
    assert any(not r["config"].endswith("x1") for r in rows) and {r["threads"] for r in rows} == {rows[0]["threads"]}
    assert all(r["rate"] > 0 and "cpu_time_rate" not in r for r in rows)
    assert result["targets"][0]["met"] is None  # quick sizes give no verdict

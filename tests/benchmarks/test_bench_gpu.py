"""The GPU benchmarks' code paths, run in Numba's CUDA simulator (no timing is meaningful there):
benchmarks/gpu_check.py end to end at --quick sizes (every stage, on the smallest batches), so that
a GPU run does not fail on a bug, and the throughput benchmark."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from helpers import simulator_env

ROOT = Path(__file__).resolve().parents[2]


def _simulated(module: str, out: Path) -> dict:
    done = subprocess.run(
        [sys.executable, "-W", "ignore", "-m", f"benchmarks.{module}", "--device", "gpu", "--quick", "--out", str(out)],
        cwd=ROOT,
        env=simulator_env(),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads((out / f"{module}.json").read_text())


@pytest.mark.slow
def test_gpu_check_runs_every_stage_in_the_simulator(tmp_path, shared_data):
    done = subprocess.run(
        [sys.executable, "-W", "ignore", "benchmarks/gpu_check.py", str(tmp_path), "--quick", "--keep-cache"],
        cwd=ROOT,
        env=simulator_env(),
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gpu_check.json", "gpu_check.md"]
    result = json.loads((tmp_path / "gpu_check.json").read_text())
    for stage in ("environment", "first_solve", "panda", "polish", "evolution", "profile", "kernels", "crossover"):
        assert "error" not in result[stage] and "skipped" not in result[stage], (stage, result[stage])
    assert result["environment"]["gpu"] == "CUDA simulator"
    rows = result["panda"]["rows"]
    assert set(rows) == {"gpu/1", "gpu/2", "cpu/1", "cpu/2"}
    assert all(row["strict"] == 1.0 for row in rows.values())  # every answer re-scored in float64
    assert rows["gpu/1"]["launches"] >= 1 and rows["gpu/1"]["bytes_to_host"] > 0
    assert result["first_solve"]["second_process"]["first_s"] > 0
    polish = result["polish"]["rows"]["gpu/2"]  # the team polish against the thread per problem, taking turns
    assert polish["team_kernel"] == "first_polish_team" and polish["team_strict"] == polish["thread_strict"] == 1.0
    assert polish["team_ms"] > 0 and polish["thread_ms"] > 0
    profile = result["profile"]["gpu/2"]  # deik's own functions, ms per solve, the solve itself among them
    assert profile["ms_per_solve"]["reusable.py:solve"] > 0 and sum(profile["generations"]) == 2
    assert result["environment"]["cpu_model"]
    table = (tmp_path / "gpu_check.md").read_text()
    assert "CUDA simulator" in table and "Panda 2,000 strict targets" in table and "speed-up" in table


@pytest.mark.slow
def test_gpu_throughput_benchmark_runs_in_the_simulator(tmp_path):
    result = _simulated("throughput", tmp_path)
    rows = result["rows"]
    assert any(not r["config"].endswith("x1") for r in rows) and {r["threads"] for r in rows} == {rows[0]["threads"]}
    assert all(r["rate"] > 0 and "cpu_time_rate" not in r for r in rows)
    assert result["targets"][0]["met"] is None  # quick sizes give no verdict

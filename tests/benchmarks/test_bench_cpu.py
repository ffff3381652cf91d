"""Smoke runs of the CPU benchmarks (`python -m benchmarks.run_all --quick`) and a count of
kernel compilations across solves that change only values. No timing is asserted."""

import json
import math

import numpy as np
import pytest

import deik
from benchmarks import run_all
from deik.backends import cpu_kernels as cpu

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def results(tmp_path_factory, shared_data):
    """The folder of one quick CPU run of every benchmark, and its printed output (the batch
    benchmark's Panda needs the shared robots: skipped without them)."""
    out = tmp_path_factory.mktemp("bench")
    assert run_all.main(["--quick", "--out", str(out)]) == 0
    return out


def load(results, name: str) -> dict:
    assert (results / f"{name}.png").read_bytes()[:8] == PNG
    return json.loads((results / f"{name}.json").read_text())


def positive(x) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x) and x > 0


@pytest.mark.slow
@pytest.mark.parametrize("name", ["throughput", "headline", "batch", "memory"])
def test_each_benchmark_records_the_machine_settings_and_targets(results, name):
    result = load(results, name)
    assert result["benchmark"] == name and result["settings"]["quick"] is True
    assert result["command"].startswith(f"PYTHONPATH=src python -m benchmarks.{name} --device cpu --quick")
    env = result["environment"]
    assert env["cpu_count"] >= 1 and env["numba_threads"] >= 1 and env["numba_threading_layer"]
    assert len(env["load_average_before"]) == 3 and env["numpy"] and env["numba"] and env["device"] == "cpu"
    assert positive(result["seconds"]) and result["rows"]
    for t in result["targets"]:
        assert t["met"] is None and positive(t["goal"]) and positive(t["reached"])  # quick: no verdict


@pytest.mark.slow
def test_throughput_rows_are_joint_evaluations_per_second(results):
    rows = load(results, "throughput")["rows"]
    assert {r["threads"] for r in rows} >= {1} and any(r["batch"] > 1 for r in rows)
    for r in rows:
        assert r["generations"] >= 1 and len(r["seconds"]) >= 1 and positive(r["one_generation_seconds"])
        rate = r["population"] * r["links"] * r["batch"] / r["seconds_per_generation"]
        assert positive(r["joint_evaluations_per_second"]) and r["joint_evaluations_per_second"] == pytest.approx(rate)


@pytest.mark.slow
def test_headline_compares_the_engine_with_the_serial_reference(results):
    rows = load(results, "headline")["rows"]
    assert [r["engine"].split(" (")[0] for r in rows] == ["serial", "parallel CPU"]
    assert rows[0]["speedup"] == 1.0 and all(
        positive(r["seconds_per_generation"]) and positive(r["speedup"]) for r in rows
    )


@pytest.mark.slow
def test_batch_rows_solve_both_problem_sets(results):
    result = load(results, "batch")
    rows = result["rows"]
    assert {r["problem"] for r in rows} == {"chain20", "panda"}
    for r in rows:
        assert r["population"] == result["settings"]["population"][r["problem"]]
        assert r["population"] in result["settings"]["populations_tried"]
        assert positive(r["problems_per_second"]) and positive(r["seconds"]) and 0 <= r["success"] <= 1
        assert r["problems_per_second"] == pytest.approx(r["batch"] / r["seconds"])
    assert result["population_trials"] and result["published_panda_problems_per_second"]["PyRoki"] == 7e4


@pytest.mark.slow
def test_memory_rows_cover_population_and_batch(results):
    rows = load(results, "memory")["rows"]
    assert {r["sweep"] for r in rows} == {"population", "batch"}
    for r in rows:
        assert positive(r["state_bytes"]) and r["host_numpy_peak_bytes"] >= r["state_bytes"]
        assert r["host_rss_peak_above_start_bytes"] >= 0 and r["device_peak_bytes"] is None


@pytest.mark.slow
def test_run_all_summarises_every_stage(results):
    summary = json.loads((results / "run_all.json").read_text())
    assert [s["name"] for s in summary["stages"]] == ["serial_vs_parallel", "throughput", "headline", "batch", "memory"]
    assert all(s["status"] == "ok" and s["seconds"] >= 0 for s in summary["stages"])
    assert "| benchmark | target |" in (results / "run_all.md").read_text()


def test_changing_values_never_recompiles_the_cpu_kernels():
    kernels = (cpu.launch.entry, cpu.evaluate_poses.entry)  # what Python calls, compiled or loaded
    sk = deik.chain(6)
    rng = np.random.default_rng(0)

    def problem(batch=1, weight=1.0):
        targets = deik.forward_kinematics(sk, rng.uniform(sk.lower, sk.upper, (batch, sk.n_dofs))).position("tip")
        return deik.Problem(
            sk, [deik.Position("tip", targets if batch > 1 else targets[0], weight=weight, tolerance=0.01 * sk.reach)]
        )

    def solve(p=None, **changes):
        return deik.solve(p or problem(), **{"population": 16, "generations": 20, "seed": 0, **changes})

    solve()  # compiles or loads the float32 kernels
    counts = [len(k.signatures) for k in kernels]
    solve()  # other targets
    solve(problem(weight=0.5))
    solve(seed=7)
    solve(population=40)
    solve(generations=55)
    solve(problem(batch=3))
    assert [len(k.signatures) for k in kernels] == counts
    solve(dtype="float64")
    solve(problem(weight=0.25), dtype="float64", seed=3, population=24)
    assert all(len(k.signatures) - before <= 1 for k, before in zip(kernels, counts))

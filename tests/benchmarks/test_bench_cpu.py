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
@pytest.mark.parametrize("name", ["serial_vs_parallel", "throughput", "batch", "memory"])
def test_each_benchmark_records_the_machine_settings_and_targets(results, name):
    result = load(results, name)
    assert result["benchmark"] == name and "--quick" in result["command"].split()
    assert result["command"].startswith(f"python -m benchmarks.{name} --out ")
    env = result["environment"]
    assert env["cpu_count"] >= 1 and env["numba_threads"] >= 1 and env["numba_threading_layer"] and env["cpu_model"]
    assert isinstance(env["cpu_flags"], list) and env["device"] == "cpu"
    assert len(env["load_average_before"]) == 3 and len(env["load_average_after"]) == 3 and env["numba"]
    assert positive(result["seconds"]) and result["rows"] and result["figures"]
    assert all(positive(v) or v == 0 for v in result["figures"].values())
    for t in result["targets"]:  # quick sizes: no verdict
        assert t["met"] is None and positive(t["goal"]) and (t["reached"] is None or positive(t["reached"]))
    text = (results / f"{name}.md").read_text()
    assert text.startswith(f"# {name}") and result["command"] in text
    assert all(f"Target: {t['what']}" in text for t in result["targets"])


@pytest.mark.slow
def test_serial_vs_parallel_times_every_engine_against_the_numpy_serial(results):
    rows = load(results, "serial_vs_parallel")["rows"]
    assert [r["links"] for r in rows] == [5, 10, 20]
    for r in rows:
        assert r["speedup"]["serial"] == 1.0 and set(r["speedup"]) == {"serial", "serial_compiled", "parallel"}
        expected = r["serial"]["seconds_per_generation"] / r["parallel"]["seconds_per_generation"]
        assert r["speedup"]["parallel"] == pytest.approx(expected)
        assert r["parallel"]["seconds_per_generation"] == min(r["parallel"]["all_seconds_per_generation"])


@pytest.mark.slow
def test_throughput_rows_are_joint_evaluations_per_second(results):
    rows = load(results, "throughput")["rows"]
    assert {r["threads"] for r in rows} >= {1} and any(not r["config"].endswith("x1") for r in rows)
    for r in rows:
        links, batch = (int(v) for v in r["config"].removeprefix("chain").split("x"))
        rate = r["population"] * links * batch * r["generations"] / min(r["seconds"])
        assert r["generations"] >= 1 and positive(r["one_generation_seconds"]) and r["rate"] == pytest.approx(rate)
        assert ("cpu_time_rate" in r) == (r["threads"] == 1) and positive(r.get("cpu_time_rate", 1))


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
    assert [s["name"] for s in summary["stages"]] == ["serial_vs_parallel", "throughput", "batch", "memory"]
    assert all(s["status"] == "ok" and s["seconds"] >= 0 for s in summary["stages"])
    assert sum(len(s["targets"]) for s in summary["stages"]) == len(summary["figures"]) == 5
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

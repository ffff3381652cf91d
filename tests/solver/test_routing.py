"""device="auto" (deik.solver.routing): the CPU without a usable GPU; with one, the GPU from the
crossover up, in each regime, from this machine's measured crossovers when it has them."""

import numpy as np
import pytest

import deik
from deik.solver import routing


def _targets(n):
    chain = deik.chain(4, dims=3)
    q = np.random.default_rng(0).uniform(-1, 1, (n, chain.n_dofs))
    return chain, deik.forward_kinematics(chain, q).position("tip")


@pytest.fixture
def gpu_here(monkeypatch, tmp_path):
    """A machine that has a GPU, and its crossover record in a folder of the test's own."""
    import deik.backends.gpu as gpu

    monkeypatch.setattr(gpu, "gpu_available", lambda: True)
    monkeypatch.setattr(routing, "crossover_path", lambda: str(tmp_path / routing.CROSSOVER_FILE))
    routing.crossover.cache_clear()
    yield tmp_path
    routing.crossover.cache_clear()


def test_auto_runs_on_the_cpu_without_a_gpu():
    chain, tips = _targets(3)
    problem = deik.Problem(chain, [deik.Position("tip", tips, tolerance=1e-4)])
    result = deik.solve(problem, population=16, device="auto")
    assert result.device == "cpu" and result.converged.all()


def test_auto_sends_robot_batches_to_the_gpu_from_the_crossover_up(gpu_here):
    settings = deik.Settings(population=32, device="auto")
    start = int(routing.DEFAULT_CROSSOVER["polish_problems"])
    for n, device in ((1, "cpu"), (start - 1, "cpu"), (start, "gpu")):
        chain, tips = _targets(n)
        problem = deik.Problem(chain, [deik.Position("tip", tips, tolerance=1e-4)])
        assert routing.polish_regime(problem, settings)
        assert routing.choose_device(problem, settings) == device, n


def test_auto_sends_evolution_by_its_work_per_generation(gpu_here):
    chain = deik.chain(100)
    target = deik.forward_kinematics(chain, np.full(chain.n_dofs, 0.01)).position("tip")
    problem = deik.Problem(chain, [deik.Position("tip", target), deik.Comfort(level=1)])  # no stop: evolution
    small, large = deik.Settings(population=16, device="auto"), deik.Settings(population=4000, device="auto")
    assert not routing.polish_regime(problem, small)
    assert routing.choose_device(problem, small) == "cpu"  # 16 x 101 frames
    assert routing.choose_device(problem, large) == "gpu"  # 4000 x 101 frames


def test_a_machines_measured_crossover_replaces_the_default(gpu_here):
    chain, tips = _targets(50)
    problem = deik.Problem(chain, [deik.Position("tip", tips, tolerance=1e-4)])
    settings = deik.Settings(population=32, device="auto")
    assert routing.choose_device(problem, settings) == "cpu"
    path = routing.store_crossover({"polish_problems": 40, "evolution_work": 1e9, "ignored": 1})
    assert path == str(gpu_here / routing.CROSSOVER_FILE)
    assert routing.crossover() == {"polish_problems": 40.0, "evolution_work": 1e9}
    assert routing.choose_device(problem, settings) == "gpu"
    (gpu_here / routing.CROSSOVER_FILE).write_text("not json")  # a damaged record: the defaults
    routing.crossover.cache_clear()
    assert routing.crossover() == routing.DEFAULT_CROSSOVER


def test_the_default_crossovers_are_the_committed_gpu_measurement():
    """routing's defaults are the crossovers benchmarks/gpu_check.py measured on a real GPU
    (benchmarks/results/gpu/gpu_check.json), to within the rounding its docstring gives."""
    import json
    from pathlib import Path

    record = json.loads((Path(__file__).parents[2] / "benchmarks/results/gpu/gpu_check.json").read_text())
    assert record["environment"]["gpu"].startswith("NVIDIA") and not record["quick"]
    for name, default in routing.DEFAULT_CROSSOVER.items():
        assert default == pytest.approx(record["crossover"][name], rel=0.02), name

"""Compiling side by side (deik.backends.compiling): how the missing kernels are shared among
worker processes (a DE kernel with a helper when workers are to spare), what the estimate is, the
DEIK_COMPILE_WORKERS setting, and the bar that moves while a compile runs."""

import time

import pytest

from deik.backends import compiling
from deik.backends.compiling import KernelJob, PartJob, expected_seconds, shares, time_bar
from deik.errors import UsageError


def _jobs(*seconds: float, kernel: str = "launch") -> list[KernelJob]:
    return [KernelJob(kernel, frozenset(), (), f"{kernel} {k}", s) for k, s in enumerate(seconds)]


def test_each_job_goes_once_the_longest_first_to_the_least_loaded_worker():
    jobs = _jobs(3.0, 10.0, 4.0, 5.0, 1.0, kernel="evaluate_poses")
    split = shares(jobs, 2)
    assert sorted(j.label for share in split for j in share) == sorted(j.label for j in jobs)
    # 10 and 5 open the two workers, 4 and 3 go to the lighter (5, then 9), 1 to the 10
    assert [[j.seconds for j in share] for share in split] == [[10.0, 1.0], [5.0, 4.0, 3.0]]
    assert len(shares(jobs, 8)) == len(jobs) and len(shares(jobs[:1], 4)) == 1 and len(shares(jobs, 0)) == 1


def test_the_estimate_is_the_busiest_workers_share_slowed_while_another_compiles_beside_it(monkeypatch):
    monkeypatch.setattr(compiling, "cores", lambda: 8)
    jobs = _jobs(18.0, 5.0, 2.0)
    monkeypatch.setenv("DEIK_COMPILE_WORKERS", "2")  # 18 | 5 + 2: the 18 slowed for the 7 s beside it
    assert expected_seconds(jobs) == pytest.approx(18.0 + 7.0 * (compiling.SIDE_BY_SIDE - 1.0))
    assert expected_seconds(_jobs(10.0, 10.0)) == pytest.approx(10.0 * compiling.SIDE_BY_SIDE)
    assert expected_seconds(jobs[:1]) == pytest.approx(18.0 * compiling.SPLIT + 18.0 * compiling.HELPER * 0.12)
    monkeypatch.setenv("DEIK_COMPILE_WORKERS", "1")
    assert expected_seconds(jobs) == 25.0
    monkeypatch.setenv("DEIK_COMPILE_WORKERS", "0")  # none: this process compiles them one after another
    assert expected_seconds(jobs) == 25.0 and compiling.workers() == 0
    monkeypatch.delenv("DEIK_COMPILE_WORKERS")
    assert compiling.workers() == compiling.cores() == 8
    monkeypatch.setattr(compiling, "cores", lambda: 1)  # more workers than cores: they take turns
    monkeypatch.setenv("DEIK_COMPILE_WORKERS", "2")
    assert expected_seconds(jobs) == 25.0


def test_a_lone_de_kernel_gets_a_helper_that_compiles_its_generations_loop_first(monkeypatch):
    launch, report, jacobians = _jobs(20.0) + _jobs(2.5, 2.0, kernel="evaluate_poses")
    split = shares([report, launch, jacobians], 2)
    assert split == [[launch], [PartJob(launch, "run_generations"), report, jacobians]]
    assert split[1][0].label == "launch 0: run_generations"
    # two DE kernels on two workers: no helper; on four: one each, the others to the least loaded
    two = _jobs(20.0, 19.0)
    assert shares(two, 2) == [[two[0]], [two[1]]]
    four = shares([*two, report], 4)
    # the report to the least loaded: the helper of the shorter kernel
    assert four == [
        [two[0]],
        [PartJob(two[0], "run_generations")],
        [two[1]],
        [PartJob(two[1], "run_generations"), report],
    ]
    monkeypatch.setattr(compiling, "cores", lambda: 2)
    monkeypatch.setenv("DEIK_COMPILE_WORKERS", "2")  # the kernel's share against its helper's, beside it
    kernel, helper = 20.0 * compiling.SPLIT, 20.0 * compiling.HELPER + 4.5
    expected = max(kernel, helper) + (compiling.SIDE_BY_SIDE - 1.0) * min(kernel, helper)
    assert expected_seconds([launch, report, jacobians]) == pytest.approx(expected)


def test_a_bad_worker_count_names_the_variable(monkeypatch):
    monkeypatch.setenv("DEIK_COMPILE_WORKERS", "two")
    with pytest.raises(UsageError, match="DEIK_COMPILE_WORKERS must be a whole number"):
        compiling.workers()


def test_the_compile_bar_moves_while_the_body_runs_and_ends_full(capsys, monkeypatch):
    monkeypatch.setattr(compiling, "TICK", 0.01)
    with time_bar("compiling DE float32", 5.0, show=True):
        moved = ""
        deadline = time.monotonic() + 60  # a loaded machine's thread switches, not a timing
        while "1/5" not in moved and time.monotonic() < deadline:
            time.sleep(0.05)
            moved += capsys.readouterr().err
    assert "compiling DE float32" in moved and "1/5" in moved  # drawn at once, then moving
    assert "5/5" in capsys.readouterr().err  # filled when the compile is done
    with time_bar("compiling nothing", 5.0, show=False):
        pass
    assert capsys.readouterr().err == ""

"""Progress from the Python API: nothing by default, a tqdm bar on stderr with progress=True
(for single solves, batches and the reused Solver), a callable's reports that follow the run."""

import numpy as np
import pytest

import deik

TARGETS = np.array([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [-1.0, 2.5, 0.0]])
SETTINGS = {"population": 24, "generations": 250, "seed": 0}
CHAIN = deik.chain(4)


def problem(target=TARGETS[0]):
    return deik.Problem(CHAIN, [deik.Position("tip", target)])


def test_a_solve_prints_nothing_unless_asked(capsys):
    deik.solve(problem(), **SETTINGS)
    assert capsys.readouterr().err == ""


def test_progress_true_draws_a_bar_over_generations(capsys):
    result = deik.solve(problem(), progress=True, **SETTINGS)
    err = capsys.readouterr().err
    assert "deik solve:" in err and "gen" in err and "best fitness" in err
    assert f"{int(result.generations)}/250" in err  # the bar ends where the solve stopped


def test_a_batch_bar_says_how_many_problems_still_run(capsys):
    result = deik.solve_batch([problem(t) for t in TARGETS], progress=True, **SETTINGS)
    assert result.angles.shape == (3, 4)
    assert "/3 problems running" in capsys.readouterr().err


def test_the_reused_solver_draws_the_bar_too(capsys):
    ik = deik.Solver(problem(), **SETTINGS)
    ik.solve({"position tip": TARGETS[1]}, progress=True)
    assert "deik solve:" in capsys.readouterr().err


def test_a_callable_gets_rising_generations_and_the_best_fitness(capsys):
    seen = []
    result = deik.solve(problem(TARGETS[2]), progress=lambda g, best: seen.append((g, best)), **SETTINGS)
    generations = [g for g, _ in seen]
    assert generations == sorted(generations) and generations[-1] == int(result.generations)
    # the last report is the final population's best, which the Result re-evaluates in float64
    assert seen[-1][1] == pytest.approx(float(result.fitness), rel=1e-3, abs=1e-6)
    assert capsys.readouterr().err == ""


def test_progress_of_another_kind_is_refused():
    with pytest.raises(TypeError, match="progress must be True, False, None or a callable"):
        deik.solve(problem(), progress="yes", **SETTINGS)

"""The time limit and Ctrl-C reach inside a kernel launch (deik.solver.halting), and a Solver
refuses a second thread instead of mixing two solves in its buffers.

The large-skeleton cases are issue 29's: with a comfort goal the polish solves D x D normal
equations (D^3 / 6 per LM iteration), so on a 450-DOF chain one launch used to run for many
seconds past a 1 s limit, and Ctrl-C waited for it."""

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import deik
from deik.errors import SolveError

SRC = Path(__file__).resolve().parents[2] / "src"
LONG_SOLVE = """
import sys, time
import numpy as np
import deik
chain = deik.chain(225, dims=3)  # 450 DOFs
goals = [deik.Position("tip", (40.0, 60.0, 30.0), tolerance=1e-9), deik.Comfort(level=1)]
problem = deik.Problem(chain, goals)
small = [deik.Position("tip", (1.0, 1.0, 0.5), tolerance=1e-9), deik.Comfort(level=1)]
deik.solve(deik.Problem(deik.chain(3, dims=3), small), population=8, generations=2)  # kernels loaded
limit = float(sys.argv[1]) if len(sys.argv) > 1 else None
print("ready", flush=True)
began = time.perf_counter()
try:
    deik.solve(problem, population=16, polish_count=16, time_limit=limit, seed=1)
except KeyboardInterrupt:
    print(f"interrupted at {time.time():.3f}", flush=True)
    raise
print(f"done {time.perf_counter() - began:.3f}", flush=True)
"""


def _start(*args):
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    process = subprocess.Popen(
        [sys.executable, "-W", "ignore", "-c", LONG_SOLVE, *args],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout.readline().strip() == "ready", process.stderr.read()[-2000:]
    return process


@pytest.mark.slow
def test_time_limit_stops_the_polish_of_a_large_skeleton_inside_the_launch():
    process = _start("0.5")
    out, err = process.communicate(timeout=600)
    assert process.returncode == 0, err[-2000:]
    seconds = float(out.split()[-1])
    assert seconds < 0.5 + 2.0, f"a 0.5 s limit took {seconds:.1f} s"


@pytest.mark.slow
def test_ctrl_c_stops_a_large_solve_inside_the_launch():
    process = _start()
    time.sleep(1.0)  # well inside the first launch's polish
    sent = time.time()
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=600)
    assert process.returncode != 0 and "KeyboardInterrupt" in err
    waited = float(out.split()[-1]) - sent  # from the signal to the solve giving up (the exit is slower)
    assert waited < 1.0, f"Ctrl-C took {waited:.1f} s to stop the solve"


def test_the_watchdog_sets_the_stop_flag_at_the_deadline_only_when_guarded():
    from deik.solver.halting import guarded

    halt = np.zeros(1, np.int64)
    with guarded(halt, time.perf_counter() + 0.05, 1.0):
        waited = time.perf_counter()
        while halt[0] == 0 and time.perf_counter() - waited < 5:  # a stand-in for a kernel's loop
            time.sleep(0.005)
    assert halt[0] == 1 and time.perf_counter() - waited < 1.0
    with guarded(halt, time.perf_counter() + 60, 0.001):  # a short launch, far from its deadline
        assert halt[0] == 0  # cleared for the launch, and never armed
    time.sleep(0.1)
    assert halt[0] == 0


def test_a_solver_refuses_a_second_thread_while_it_solves():
    chain = deik.chain(4, dims=3)
    rng = np.random.default_rng(0)
    targets = deik.forward_kinematics(chain, rng.uniform(-1, 1, (2, chain.n_dofs))).position("tip")
    solver = deik.Solver(deik.Problem(chain, [deik.Position("tip", targets[0], tolerance=1e-4)]), population=16)
    inside, release = threading.Event(), threading.Event()

    def slow_progress(generation, best):  # holds the first solve open while the second is tried
        inside.set()
        release.wait(30)

    first = threading.Thread(target=lambda: solver.solve(progress=slow_progress, seed=1))
    first.start()
    assert inside.wait(60)
    with pytest.raises(SolveError, match="another thread"):
        solver.solve({"position tip": targets[1]})
    release.set()
    first.join(60)
    # once the first is done the Solver serves the next, with the right answer
    result = solver.solve({"position tip": targets[1]})
    tip = deik.forward_kinematics(chain, result.angles).position("tip")
    assert result.converged and np.linalg.norm(tip - targets[1]) <= 1e-4


def test_one_solver_per_thread_gives_every_thread_its_own_right_answers():
    chain = deik.chain(4, dims=3)
    rng = np.random.default_rng(1)
    targets = deik.forward_kinematics(chain, rng.uniform(-1, 1, (8, chain.n_dofs))).position("tip")
    problem = deik.Problem(chain, [deik.Position("tip", targets[0], tolerance=1e-4)])
    errors = []

    def work(k):
        solver = deik.Solver(problem, population=16)
        for t in targets[k::2]:
            result = solver.solve({"position tip": t})
            tip = deik.forward_kinematics(chain, result.angles).position("tip")
            errors.append((bool(result.converged), float(np.linalg.norm(tip - t))))

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(120)
    assert len(errors) == 8 and all(converged == (error <= 1e-4) for converged, error in errors)

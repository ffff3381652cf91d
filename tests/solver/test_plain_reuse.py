"""A plain deik.solve in a loop reuses what the last problem of its structure left (the kept
structure's token, the kept engine and buffers, a Result's history joined on first read): its
answer to a target is bit for bit that of a fresh process solving that target alone, whatever
was solved before it, and a Result stays as it was while later solves reuse its buffers."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

import deik
from deik.solver.kept import _structure

SRC = str(Path(__file__).resolve().parents[2] / "src")
SETTINGS = dict(population=24, dtype="float64", polish_count=8, patience=40)

SCRIPT = """
import sys, numpy as np, deik
sk = deik.chain(6, dims=3)
q = np.random.default_rng(21).uniform(sk.lower, sk.upper, (6, sk.n_dofs))
kin = deik.forward_kinematics(sk, q)
P, R = kin.position("tip"), kin.rotation("tip")
k = int(sys.argv[1])
problem = deik.Problem(sk, [deik.Position("tip", P[k], tolerance=1e-5), deik.Orientation("tip", R[k], tolerance=1e-4)])
r = deik.solve(problem, seed=100 + k, initial=np.zeros(sk.n_dofs), **SETTINGS)
print(r.angles.tobytes().hex(), r.history.tobytes().hex(), int(r.generations), sep="|")
"""


def _arm():
    """The script's arm and its FK targets of six random in-limit poses."""
    sk = deik.chain(6, dims=3)
    q = np.random.default_rng(21).uniform(sk.lower, sk.upper, (6, sk.n_dofs))
    kin = deik.forward_kinematics(sk, q)
    return sk, kin.position("tip"), kin.rotation("tip")


def _problem(sk, p, R, tolerance=1e-5):
    return deik.Problem(sk, [deik.Position("tip", p, tolerance=tolerance), deik.Orientation("tip", R, tolerance=1e-4)])


def _fresh_process(k: int) -> tuple[str, str, int]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([SRC] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    script = f"SETTINGS = {SETTINGS!r}\n" + SCRIPT
    out = subprocess.run(
        [sys.executable, "-c", script, str(k)], env=env, capture_output=True, text=True, timeout=300, check=False
    )
    assert out.returncode == 0, out.stderr
    angles, history, generations = out.stdout.strip().split("|")
    return angles, history, int(generations)


def test_a_loop_of_plain_solves_answers_each_target_as_a_fresh_process_does():
    sk, P, R = _arm()
    start = np.zeros(sk.n_dofs)
    # other structures and other targets of this one first: a looser tolerance, then targets 0-3
    deik.solve(_problem(sk, P[5], R[5], tolerance=1e-3), seed=7, initial=start, **SETTINGS)
    results = [deik.solve(_problem(sk, P[k], R[k]), seed=100 + k, initial=start, **SETTINGS) for k in range(5)]
    for k in (0, 4):  # the structure's first problem and one solved after four others
        angles, history, generations = _fresh_process(k)
        assert results[k].angles.tobytes().hex() == angles
        assert results[k].history.tobytes().hex() == history  # read after the later solves
        assert int(results[k].generations) == generations
        tip = deik.forward_kinematics(sk, results[k].angles)
        assert np.linalg.norm(tip.position("tip") - P[k]) <= 1e-5


def test_problems_of_one_structure_share_a_token_and_find_one_kept_engine():
    sk, P, R = _arm()
    settings = deik.Settings(**SETTINGS)
    first, second = _problem(sk, P[0], R[0]), _problem(sk, P[1], R[1])
    assert first.compiled.structure is not None and first.compiled.structure is second.compiled.structure
    assert _structure(first, settings) == _structure(second, settings.with_seed(9))  # the seed is set per call
    looser = _problem(sk, P[1], R[1], tolerance=1e-3)
    assert looser.compiled.structure is not first.compiled.structure
    assert _structure(looser, settings) != _structure(first, settings)
    stacked = deik.Problem.stack([first, second])
    assert stacked.compiled.structure is None and stacked.batch_shape == (2,)
    comfort = deik.Problem(sk, [deik.Position("tip", P[0]), deik.Comfort(reference=np.zeros(sk.n_dofs))])
    assert comfort.compiled.structure is None  # an array field: no plain structure, tables compared


def test_a_results_history_is_its_own_solves_after_later_solves_reuse_the_buffers():
    sk, P, R = _arm()
    start = np.zeros(sk.n_dofs)
    de_only = dict(SETTINGS, polish=0, generations=60)  # DE generations, each a history row
    lazy = deik.solve(_problem(sk, P[2], R[2]), seed=3, initial=start, **de_only)
    for k in range(4):
        deik.solve(_problem(sk, P[k], R[k]), seed=50 + k, initial=start, **de_only)
    read_at_once = deik.solve(_problem(sk, P[2], R[2]), seed=3, initial=start, **de_only)
    expected = read_at_once.history.copy()
    np.testing.assert_array_equal(lazy.history, expected)
    assert lazy.history.shape == (int(lazy.generations), 2) and not lazy.history.flags.writeable
    assert int(lazy.generations) > 10 and np.isfinite(expected).all()
    assert (np.diff(expected[:, 0]) <= 0).all()  # the best total never worsens

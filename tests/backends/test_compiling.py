"""Each kernel is compiled once (deik/backends/linking.py): every way of solving runs the one DE
kernel of its dtype, the device maths exists only inside the kernels that call it, a solve without
the polish compiles no LM, and a second process loads what the first compiled."""

import glob
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import deik
from deik.backends import cpu as cpu_backend
from deik.backends import entries


def test_every_way_of_solving_runs_one_kernel_per_dtype():
    chain, human = deik.chain(5, dims=3), deik.humanoid()
    target = deik.forward_kinematics(chain, np.full(chain.n_dofs, 0.3)).position("tip")
    problem = deik.Problem(chain, [deik.Position("tip", target, tolerance=1e-3)])
    run = {"population": 16, "generations": 3, "dtype": "float64"}
    deik.solve(problem, **run)
    # a read-only or strided start pose, a stack, a reused Solver, stepping by hand, another skeleton
    start = np.broadcast_to(np.zeros(chain.n_dofs), (2, chain.n_dofs))
    deik.solve(problem, initial=start, **run)
    deik.solve(problem, initial=np.zeros((4, 2 * chain.n_dofs))[:, ::2], **run)
    deik.solve_batch([problem, problem], **run)
    solver = deik.Solver(problem, **run)
    solver.solve({"position tip": target}, initial=np.zeros((1, chain.n_dofs)))
    engine = deik.Engine(problem, deik.Settings(**run))
    engine.step(engine.init())
    deik.solve(deik.Problem(human, [deik.Position(human.site_names[0], [0.1, 0.2, 0.3])]), **run)
    launches = [entry for (_, name), entry in entries._ENTRIES.items() if name.startswith("launch")]
    # one float64 polish kernel in each build that ran (a warm cache may hold a smaller build
    # for the position-only problems beside the full one), and at least one build ran
    per_build = [[cpu_backend.launch_kind(signature) for signature in entry.overloads] for entry in launches]
    assert all(kinds.count(("float64", True)) <= 1 for kinds in per_build), per_build
    assert any(("float64", True) in kinds for kinds in per_build), per_build


def _run(code: str, cache: str, argv: list = (), **env: str) -> subprocess.CompletedProcess:
    done = subprocess.run(
        [sys.executable, "-c", code, *map(str, argv)],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "NUMBA_CACHE_DIR": cache, **env},
    )
    assert done.returncode == 0, done.stderr
    return done


SOLVE_WITHOUT_POLISH = (
    "from deik.cli.app import main\n"
    "main(['solve', 'chain:3', '--reach', 'tip', '1', '1', '0.5', '--dtype', 'float64', '--polish', '0'])\n"
    "from deik.backends.targets import cpu_build, cpu_entry\n"
    "position = frozenset({'POSITION_ON'})\n"
    "dev, entry = cpu_build(position), cpu_entry('launch', position)\n"
    "print('LM', len(dev.polish.overloads), 'compiled', sum(entry._cache_misses.values()))\n"
    "functions = (dev.breed_lanes, dev.forward_kinematics_lanes, dev.run_generations)\n"
    "linked = [r.library for f in functions for r in f.overloads.values()]\n"
    "print('linked', len(linked), all(type(library).__name__ == 'LinkOnlyLibrary' for library in linked))\n"
)


@pytest.mark.slow  # a real cold compile (about 25 s on 2 cores)
def test_a_solve_without_polish_compiles_no_lm_and_a_second_process_compiles_nothing(tmp_path):
    first = _run(SOLVE_WITHOUT_POLISH, str(tmp_path), DEIK_COMPILE_WORKERS="1")  # compiled here, to look into
    assert "compiling the CPU kernels first (DE float64 without polish [position]): about" in first.stderr
    assert "LM 0 compiled 1" in first.stdout
    # the device maths was lowered only to be linked into the kernel: no machine code of its own
    assert "linked 3 True" in first.stdout
    (record,) = glob.glob(str(tmp_path / "**" / "deik-compile-seconds.json"), recursive=True)
    with open(record) as file:
        assert json.load(file)["DE float64 without polish [position]"] > 0
    second = _run(SOLVE_WITHOUT_POLISH, str(tmp_path))
    assert "compiling" not in second.stderr and "LM 0 compiled 0" in second.stdout
    note = _run("from deik.solver import readiness as r; print(r.compile_note(r.pending('float64')))", str(tmp_path))
    assert "(DE float64)" in note.stdout and "on this machine, scaled from its earlier compiles" in note.stdout
    again = "from deik.solver import readiness as r; print(r.compile_note(['DE float64 without polish [position]']))"
    assert "on this machine, as measured here before" in _run(again, str(tmp_path)).stdout


@pytest.mark.slow  # compiles a build of its own the first time (about 30 s on 2 cores)
def test_the_build_for_a_problems_own_kinds_gives_the_answers_of_the_build_for_every_kind(monkeypatch):
    from deik.backends import builds
    from deik.backends.targets import ALL_KINDS, cpu_entry

    sk = deik.chain(6, dims=3)
    pose = np.random.default_rng(5).uniform(sk.lower, sk.upper)
    kinematics = deik.forward_kinematics(sk, pose)
    goals = [
        deik.Position("tip", kinematics.position("tip"), tolerance=1e-6),
        deik.Orientation("tip", kinematics.rotation("tip"), tolerance=1e-5),
    ]
    problem = deik.Problem(sk, goals)
    run = {"population": 16, "generations": 40, "dtype": "float64", "seed": 2}
    switches = builds.switches_of(deik.Engine(problem, deik.Settings(**run)).inputs.terms.term_int)
    assert switches == {"POSITION_ON", "ORIENTATION_ON"}
    answers = []
    for build in (switches, ALL_KINDS):  # which build serves the solve: the one chosen, then the other
        monkeypatch.setattr(cpu_backend, "_LAUNCHES", {("float64", True, switches): (build, True)})
        monkeypatch.setattr(cpu_backend, "_ENTRY_POINTS", {})
        answers.append(deik.solve(problem, **run))
    own, every = answers
    np.testing.assert_array_equal(own.angles, every.angles)
    assert float(own.fitness) == float(every.fitness) and int(own.generations) == int(every.generations)
    assert cpu_entry("launch", switches).overloads and cpu_entry("launch", ALL_KINDS).overloads  # both ran


FIRST_FLOAT32_SOLVE = (
    "import sys\n"
    "from deik.cli.app import main\n"
    "main(['solve', 'chain:6', '--reach', 'tip', '1', '1', '0.5', '--polish', '0', '--generations', '30',\n"
    "      '--tolerance', '1e-9', '--out', sys.argv[1], '--verbose'])\n"
    "from deik.backends.targets import cpu_entry\n"
    "position = frozenset({'POSITION_ON'})\n"
    "kernels = (cpu_entry('launch', position), cpu_entry('evaluate_poses', position))\n"
    "print('compiled here', sum(sum(k._cache_misses.values()) for k in kernels))\n"
    "print('loaded', sum(sum(k._cache_hits.values()) for k in kernels))\n"
)


def _worker_reports(stderr: str) -> list[dict]:
    marker = "a compile worker reported "
    return [json.loads(line.split(marker)[1]) for line in stderr.splitlines() if marker in line]


@pytest.mark.slow  # two real cold compiles of two kernels (about 20 s on 2 cores)
def test_a_first_float32_solve_compiles_its_two_kernels_in_workers_for_its_goal_kinds_only(tmp_path):
    cache = tmp_path / "cache"
    first = _run(FIRST_FLOAT32_SOLVE, str(cache), DEIK_COMPILE_WORKERS="2", argv=[tmp_path / "split.json"])
    note = "compiling the CPU kernels first (DE float32 without polish [position], report float64 [position])"
    assert note in first.stderr
    # the workers compiled both into the cache; this process loaded them
    assert "compiled here 0" in first.stdout and "loaded 2" in first.stdout
    cached = sorted(
        os.path.basename(path).split("-")[0] for path in glob.glob(str(cache / "**" / "*.nbi"), recursive=True)
    )
    assert cached == ["cpu_kernels.evaluate_poses_k001", "cpu_kernels.launch_k001"]  # no other kind, no other kernel
    (record,) = glob.glob(str(cache / "**" / "deik-compile-seconds.json"), recursive=True)
    with open(record) as file:
        assert set(json.load(file)) == {"DE float32 without polish [position]", "report float64 [position]"}
    # one worker compiled the DE kernel, loading its generations loop from the other, which
    # compiled that loop first (deik.backends.sharing), then the report
    kernel, helper = sorted(_worker_reports(first.stderr), key=lambda report: len(report["seconds"]))
    assert set(kernel["seconds"]) == {"DE float32 without polish [position]"} and "run_generations" in kernel["loaded"]
    assert list(helper["seconds"]) == [
        "DE float32 without polish [position]: run_generations",
        "report float64 [position]",
    ]
    # the kernel compiled in one process gives the same answers, bit for bit
    _run(FIRST_FLOAT32_SOLVE, str(tmp_path / "alone"), DEIK_COMPILE_WORKERS="1", argv=[tmp_path / "alone.json"])
    split, alone = (json.loads((tmp_path / name).read_text()) for name in ("split.json", "alone.json"))
    assert split["generations"] == alone["generations"] == 30
    assert split["angles"] == alone["angles"] and split["fitness"] == alone["fitness"]


WARMUP_THEN_SOLVE = (
    "import logging, sys\n"
    "logging.basicConfig(stream=sys.stderr, level=logging.INFO, format='%(message)s')\n"
    "from deik.solver.warmup import warmup\n"
    "print('warmup compiled', warmup(['float64'])['compiled'])\n"
    "print('after warmup', file=sys.stderr)\n"
    "from deik.cli.app import main\n"
    "main(['solve', 'chain:3', '--reach', 'tip', '1', '1', '0.5', '--dtype', 'float64'])\n"
    "from deik.backends.targets import cpu_entry\n"
    "print('position build used', bool(cpu_entry('launch', frozenset({'POSITION_ON'})).overloads))\n"
)


@pytest.mark.slow  # a real cold compile of the build for every kind (about 40 s on 2 cores)
def test_after_a_cold_warmup_a_solve_in_the_same_process_runs_the_build_it_compiled(tmp_path):
    run = _run(WARMUP_THEN_SOLVE, str(tmp_path))
    assert "warmup compiled ['DE float64', 'report float64', 'clip warm start float64']" in run.stdout
    assert "compiling" not in run.stderr.split("after warmup")[1]
    assert "position build used False" in run.stdout

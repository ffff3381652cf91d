"""The GPU path: the CUDA kernels against the CPU kernels (simulator), what a reused Solver moves
between host and device, the kernels compiled to PTX and SASS for sm_90 and loaded from the disk
cache by another process (no GPU needed), the NumPy 2.5 guard, every GPU failure as one
DeviceError line, and a real-GPU check that is skipped, with its reason shown, without one."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import deik
from helpers import simulator_env

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
SRC = Path(__file__).resolve().parents[2] / "src"


# what ptxas may use per thread for each kernel (sm_90, float32 and float64): evolve and
# first_polish_team are capped at 128 registers (four 128-thread blocks per multiprocessor),
# first_polish is not (docs/gpu.md); any spill or stack frame (local memory) would be scratch the
# pools were meant to hold; first_polish_team's shared array (cuda_team.TEAM_SHARED_FLOATS) stays
# under the 48 KB a block may hold without opting in
# (benchmarks/results/gpu/kernel_resources.json records the last compile)
KERNELS = ["evolve", "first_polish", "first_polish_team"]
REGISTER_BUDGET = {"evolve": 128, "first_polish": 255, "first_polish_team": 128}
LOCAL_BUDGET = {"spill_store_bytes": 0, "spill_load_bytes": 0, "stack_frame_bytes": 0}
SHARED_BUDGET = {"evolve": 1024, "first_polish": 0, "first_polish_team": 48 * 1024}


def _within_budget(name, kernel):
    assert kernel["registers"] is not None and kernel["registers"] <= REGISTER_BUDGET[name], (name, kernel)
    for field, limit in LOCAL_BUDGET.items():
        assert kernel[field] is not None and kernel[field] <= limit, (name, field, kernel[field])
    assert (kernel["shared_bytes"] or 0) <= SHARED_BUDGET[name], (name, kernel["shared_bytes"])


def _run(script, *args, simulator=False, env=None, timeout=600):
    if simulator:
        env = simulator_env(**(env or {}))
    else:
        env = {**os.environ, "PYTHONPATH": str(SRC), **(env or {})}
        env.pop("NUMBA_ENABLE_CUDASIM", None)
    out = subprocess.run(
        [sys.executable, "-W", "ignore", str(SCRIPTS / script), *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout


def _gpu_available():
    try:
        from numba import cuda

        return cuda.is_available()
    except Exception:
        return False


def test_simulated_cuda_kernel_equals_cpu_kernel_bit_for_bit_in_float64():
    cpu = json.loads(_run("small_run.py", "cpu", "float64", "10"))
    sim = json.loads(_run("small_run.py", "gpu", "float64", "10", simulator=True))
    assert cpu["restarts"][2] > 0, "the unreachable problem should have restarted"
    assert cpu["restarts"] == sim["restarts"]
    np.testing.assert_array_equal(np.array(cpu["rates"]), np.array(sim["rates"]))
    assert cpu["generations"] == sim["generations"]
    assert cpu["best"] == sim["best"]
    assert cpu["generation"] == sim["generation"]
    np.testing.assert_array_equal(np.array(cpu["pop"]), np.array(sim["pop"]))
    np.testing.assert_array_equal(np.array(cpu["history"]), np.array(sim["history"]))
    np.testing.assert_array_equal(np.array(cpu["raw"]), np.array(sim["raw"]))


def test_simulated_cuda_start_equals_cpu_bit_for_bit_in_float64():
    # the lazy first population and the polish that converges on a copy (normal equations and
    # the dual step), then generations, polish rounds and a restart for the unreachable problem
    cpu = json.loads(_run("start_run.py", "cpu"))
    sim = json.loads(_run("start_run.py", "gpu", simulator=True))
    assert cpu["converged"] == [True, True, False] and cpu["generations"][:2] == [0, 0]
    assert cpu["restarts"][2] == 1
    for key in ("generations", "converged", "restarts"):
        assert cpu[key] == sim[key], key
    for key in ("pop", "raw", "history"):
        np.testing.assert_array_equal(np.array(cpu[key]), np.array(sim[key]), err_msg=key)


def _team_runs(case, dtype="float64", paths=("team", "thread", "cpu")):
    """tests/scripts/team_polish_run.py's answers per path: the GPU's team per problem, its thread
    per problem (both in the simulator) and the CPU."""
    return {path: json.loads(_run("team_polish_run.py", case, path, dtype, simulator=path != "cpu")) for path in paths}


def _meets_strict_targets(run):
    """Every problem met by the first polish, inside the limits, every goal within its strict
    tolerance (1e-5 m, 1e-4 rad) by NumPy's forward kinematics of the answer."""
    n = len(run["pose"])
    assert run["converged"] == [True] * n and run["generations"] == [0] * n and run["inside_limits"]
    for label, error in run["errors"].items():
        assert error <= (1e-5 if label.startswith("position") else 1e-4), (label, error)


@pytest.mark.parametrize(("case", "dofs"), [("arm", 7), ("chain", 24), ("turns", 7)])
def test_team_polish_meets_strict_targets_in_the_bits_of_the_thread_kernel_and_the_cpu(case, dofs):
    # a 7-DOF arm's 6-D targets (the dual step) and a 24-DOF chain's (the dual step, and on one
    # problem 36 rows: the normal equations, three DOFs a lane), random in-limit poses' FK
    runs = _team_runs(case)
    assert runs["team"]["ran"] == "first_polish_team" and runs["thread"]["ran"] == "first_polish"
    assert runs["team"]["dofs"] == dofs and len(runs["team"]["errors"]) >= 2
    _meets_strict_targets(runs["team"])
    for other in ("thread", "cpu"):
        for key in ("pose", "raw"):
            np.testing.assert_array_equal(np.array(runs["team"][key]), np.array(runs[other][key]), err_msg=other)


def test_team_polish_agrees_with_the_thread_kernel_in_float32():
    runs = _team_runs("arm", "float32", ("team", "thread"))
    assert runs["team"]["ran"] == "first_polish_team"
    _meets_strict_targets(runs["team"])
    np.testing.assert_allclose(np.array(runs["team"]["pose"]), np.array(runs["thread"]["pose"]), atol=1e-3)


def test_skeletons_beyond_a_teams_shared_slab_keep_the_thread_per_problem_polish():
    run = _team_runs("wide", paths=("team",))["team"]
    assert run["dofs"] == 34 and run["ran"] == "first_polish"
    _meets_strict_targets(run)


def test_simulated_cuda_kernel_agrees_with_cpu_in_float32():
    # Without the LM polish: Numba evaluates float32 * float-literal in float64 on the CPU while
    # the simulator (NumPy 2 scalars) stays in float32, and the polish's accept/reject steps
    # turn those last-bit differences into different paths. The float64 test covers the polish.
    cpu = json.loads(_run("small_run.py", "cpu", "float32", "0"))
    sim = json.loads(_run("small_run.py", "gpu", "float32", "0", simulator=True))
    assert cpu["generations"] == sim["generations"]
    np.testing.assert_allclose(np.array(cpu["pop"]), np.array(sim["pop"]), atol=1e-5)


def test_simulated_cuda_self_collision_equals_cpu_and_the_oracle():
    from deik.objectives import reference

    cpu = json.loads(_run("self_collision_run.py", "cpu"))
    sim = json.loads(_run("self_collision_run.py", "gpu", simulator=True))
    np.testing.assert_array_equal(np.array(cpu["pop"]), np.array(sim["pop"]))
    np.testing.assert_array_equal(np.array(cpu["raw"]), np.array(sim["raw"]))
    h = deik.humanoid()
    problem = deik.Problem(h, [deik.SelfCollision(margin=0.01)])
    pop, raw = np.array(sim["pop"])[0], np.array(sim["raw"])[0, :, 0]
    assert (raw > 0).any()  # random in-limit poses collide: the comparison is not of zeros
    np.testing.assert_allclose(raw, reference.raw_errors(problem, pop)[:, 0], rtol=0, atol=1e-9)


def test_reused_solver_on_the_gpu_moves_only_targets_in_and_answers_out():
    # the second solve of a Solver: the new targets and seed poses in (and the 8-byte count of
    # unmet problems), one answer row per problem out, one launch; the answers are the CPU's bits
    sim = json.loads(_run("traffic_run.py", "gpu", simulator=True))
    cpu = json.loads(_run("traffic_run.py", "cpu"))
    assert sim["converged"] == [True] * 6 and sim["generations"] == [[0, 0, 0], [0, 0, 0]]
    assert sim["moved"] == {
        "launches": 1,
        "bytes_to_device": sim["target_bytes"] + sim["seed_bytes"] + 8,
        "bytes_to_host": sim["answer_bytes"],
    }
    assert sim["answer_bytes"] == (3 + 1) * (7 + 14 + 2) * 8  # B + 1 rows of 7 fields, D angles, T errors
    np.testing.assert_array_equal(np.array(sim["angles"]), np.array(cpu["angles"]))
    # a batch whose first polish leaves one problem unmet: after the first launch's whole-batch
    # answers, the unmet list (8 bytes) and, per launch of generations, that problem's row and
    # the history rows of the generations it ran, nothing of the other two
    third, row = sim["third"], sim["answer_bytes"] // 4
    assert third["converged"] == [True, True, False] == cpu["third"]["converged"]
    assert third["generations"] == cpu["third"]["generations"] and third["generations"][2] > 0
    launches = third["moved"]["launches"]
    assert launches >= 2
    assert third["moved"]["bytes_to_host"] == 4 * row + 8 + (launches - 1) * row + 16 * third["generations"][2]
    np.testing.assert_array_equal(np.array(third["angles"]), np.array(cpu["third"]["angles"]))


def _nvvm_or_skip():
    pytest.importorskip("cuda.bindings", reason="numba-cuda's CUDA bindings are not installed")
    try:
        from cuda.pathfinder import load_nvidia_dynamic_lib

        load_nvidia_dynamic_lib("nvvm")
    except Exception as error:  # noqa: BLE001 - any failure to find NVVM means: skip, and say why
        pytest.skip(f"NVVM not found ({error}); pip install 'numba-cuda[cu13]' to compile PTX")


def test_numpy_without_row_stack_breaks_numba_cuda_and_deiks_guard_fixes_it(tmp_path):
    # NumPy 2.5 removed np.row_stack, which numba-cuda 0.30.4 registers an overload for: its
    # first compile then fails. deik.backends.gpu.numba_cuda() puts the alias back first.
    _nvvm_or_skip()
    probe = tmp_path / "probe.py"
    probe.write_text(
        "import sys\n"
        "import numpy as np\n"
        "del np.row_stack\n"
        "if sys.argv[1] == 'guarded':\n"
        "    from deik.backends.gpu import numba_cuda\n"
        "    cuda = numba_cuda()\n"
        "else:\n"
        "    from numba import cuda\n"
        "from numba import float32\n"
        "def twice(a):\n"
        "    i = cuda.grid(1)\n"
        "    if i < a.size:\n"
        "        a[i] *= 2\n"
        "ptx, _ = cuda.compile_ptx(twice, (float32[:],), cc=(9, 0))\n"
        "print('entry' if '.entry' in ptx else 'missing')\n"
    )
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    env.pop("NUMBA_ENABLE_CUDASIM", None)
    runs = {
        how: subprocess.run([sys.executable, "-W", "ignore", str(probe), how], env=env, capture_output=True, text=True)
        for how in ("plain", "guarded")
    }
    assert runs["plain"].returncode != 0 and "has no attribute 'row_stack'" in runs["plain"].stderr
    assert runs["guarded"].returncode == 0 and runs["guarded"].stdout.strip() == "entry", runs["guarded"].stderr


@pytest.mark.slow
def test_cuda_kernels_compile_once_for_hopper_within_budget_and_load_from_the_cache(tmp_path):
    # The real numba-cuda compile (NVVM to PTX, nvJitLink's ptxas to sm_90a SASS) of the three
    # kernels, driven by the CUDA back-end's own launches, with numpy.row_stack deleted as NumPy
    # 2.5 did; then a second process, on another robot, population, batch and goal mix, loads
    # them from the disk cache instead of compiling.
    _nvvm_or_skip()
    cache = {"NUMBA_CACHE_DIR": str(tmp_path)}
    # a first compile takes about 150 CPU seconds on a 2-core machine, far more wall time under load
    first = json.loads(_run("compile_cuda.py", "float32", "humanoid", "--without-row-stack", env=cache, timeout=2400))
    second = json.loads(_run("compile_cuda.py", "float32", "arm", env=cache, timeout=600))
    assert sorted(first["kernels"]) == sorted(second["kernels"]) == KERNELS
    for name, kernel in first["kernels"].items():
        again = second["kernels"][name]
        assert not kernel["from_cache"] and again["from_cache"], name
        assert again["seconds"] < 0.2 * kernel["seconds"], name
        assert kernel["ptx_bytes"] > 0 and kernel["sass_bytes"] > 0
        _within_budget(name, kernel)


def test_recorded_kernel_resources_are_within_budget():
    record = json.loads(
        (Path(__file__).resolve().parents[2] / "benchmarks/results/gpu/kernel_resources.json").read_text()
    )
    assert {row["dtype"] for row in record["compiles"]} == {"float32", "float64"}
    for row in record["compiles"]:
        assert sorted(row["kernels"]) == KERNELS
        for name, kernel in row["kernels"].items():
            _within_budget(name, kernel)


def test_every_gpu_failure_is_one_device_error_line():
    from deik.backends.gpu import device_error, on_gpu
    from deik.errors import DeviceError

    failures = {
        "CudaAPIError: [2] Call to cuMemAlloc results in CUDA_ERROR_OUT_OF_MEMORY": "ran out of memory",
        "NvvmError: Failed to compile\n<unnamed>:1: error: bad IR": "CUDA compiler failed",
        "AttributeError: module 'numpy' has no attribute 'row_stack'": "does not work with NumPy",
        "CudaSupportError: Error at driver init:\n\nCUDA driver library cannot be found": "the GPU failed",
    }
    for message, meaning in failures.items():
        error = device_error(RuntimeError(message), "running the first polish")
        assert isinstance(error, DeviceError) and meaning in str(error), message
        assert "\n" not in str(error) and "device='cpu'" in str(error)
    with pytest.raises(DeviceError, match="ran out of memory copying") as raised:
        with on_gpu("copying the answers"):
            raise MemoryError("out of memory")
    assert isinstance(raised.value.__cause__, MemoryError)
    with pytest.raises(KeyboardInterrupt):  # Ctrl-C is not a GPU failure
        with on_gpu("running the generations"):
            raise KeyboardInterrupt


def test_gpu_errors_reach_the_command_line_as_one_line(monkeypatch, capsys):
    import deik.backends.gpu as gpu
    from deik.cli.app import main

    def broken():
        raise gpu.device_error(RuntimeError("CUDA_ERROR_NO_DEVICE: no CUDA-capable device\nmore"), "starting")

    monkeypatch.setattr(gpu, "require_gpu", broken)
    status = main(["solve", "chain:3", "--reach", "tip", "1", "1", "0", "--device", "gpu"])
    err = capsys.readouterr().err
    assert status == 2 and err.startswith("deik: error: the GPU failed starting") and err.count("\n") == 1


@pytest.mark.gpu  # skipped, with the reason, without a GPU (conftest)
def test_real_gpu_solves_like_the_cpu():
    chain = deik.chain(12, dims=3)
    rng = np.random.default_rng(3)
    target = deik.forward_kinematics(chain, rng.uniform(-1, 1, chain.n_dofs)).position("tip")
    problem = deik.Problem(chain, [deik.Position("tip", target)])
    gpu = deik.solve(problem, population=128, seed=5, device="gpu", dtype="float64")
    cpu = deik.solve(problem, population=128, seed=5, device="cpu", dtype="float64")
    assert gpu.converged and cpu.converged
    assert gpu.device == "gpu"
    assert abs(int(gpu.generations) - int(cpu.generations)) <= max(5, int(cpu.generations) // 5)


@pytest.mark.skipif(_gpu_available(), reason="this machine has a GPU")
def test_gpu_device_without_a_gpu_says_how_to_fix():
    from deik.errors import DeviceError

    problem = deik.Problem(deik.chain(3), [deik.Position("tip", (1.0, 1.0, 0.0))])
    with pytest.raises(DeviceError, match="needs an NVIDIA GPU.*device='cpu'"):
        deik.solve(problem, device="gpu")

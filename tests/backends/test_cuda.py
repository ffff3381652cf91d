"""The GPU path: the CUDA kernels against the CPU kernels (simulator), PTX compilation, and a
real-GPU check that is skipped, with its reason shown, on machines without one."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import deik

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
SRC = Path(__file__).resolve().parents[2] / "src"


def _run(script, *args, simulator=False):
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    env.pop("NUMBA_ENABLE_CUDASIM", None)
    if simulator:
        env["NUMBA_ENABLE_CUDASIM"] = "1"
    out = subprocess.run(
        [sys.executable, "-W", "ignore", str(SCRIPTS / script), *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
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


@pytest.mark.slow
def test_cuda_kernels_compile_to_ptx_for_hopper():
    pytest.importorskip("cuda.bindings", reason="numba-cuda's CUDA bindings are not installed")
    try:
        from cuda.pathfinder import load_nvidia_dynamic_lib

        load_nvidia_dynamic_lib("nvvm")
    except Exception as error:  # noqa: BLE001 - any failure to find NVVM means: skip, and say why
        pytest.skip(f"NVVM not found ({error}); pip install 'numba-cuda[cu13]' to compile PTX")
    lines = _run("compile_ptx.py").split("\n")
    kernels = [line.split()[:2] for line in lines if line]
    assert kernels == [["run", "entry"], ["initialise", "entry"], ["start", "entry"]]


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
    problem = deik.Problem(deik.chain(3), [deik.Position("tip", (1.0, 1.0, 0.0))])
    with pytest.raises(RuntimeError, match="needs an NVIDIA GPU.*device='cpu'"):
        deik.solve(problem, device="gpu")

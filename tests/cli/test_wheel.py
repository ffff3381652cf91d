"""A fresh wheel install gives a user what the README promises: deik's wheel, built from this
checkout and installed into a new virtual environment, brings at most 10 packages, deik's
additions beyond Numba's own stack stay under 20 MB, the README's figures for both hold, and
every README `deik` command and example script runs against it (in one process of its python;
its `deik` console script runs `deik warmup` and `deik --version`), from a folder laid out like a
clone beside shared/. Skipped with the reason when the package index is unreachable.

Compiling the kernels, the minutes every user waits once after an install, is measured by
tests/cli/test_warmup.py; here the installed copy's kernel cache starts as a copy of this
checkout's (the same kernel sources and Numba, so the same machine code), and the installed
`deik warmup` compiles only what that copy lacks."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest
from readme_commands import (
    bash_lines,
    clone_beside_shared,
    gpu_available,
    run_line,
    run_lines,
    runnable,
)
from readme_figures import FIGURES, check

import deik
from benchmarks.wheel_install import (
    MAX_ADDITIONS_MEGABYTES,
    MAX_PACKAGES,
    index_reachable,
    install,
    measure,
    outside_env,
)
from deik.backends import cpu_kernels as cpu

CACHE_PATH = (
    "from deik.backends import cpu_kernels as cpu; print(cpu.launch.entry._cache._cache_path)"  # Numba's, private
)


@pytest.fixture(scope="module")
def installed_wheel(tmp_path_factory):
    """The install record of deik's wheel in a fresh venv (benchmarks.wheel_install.measure)."""
    reachable, why = index_reachable()
    if not reachable:
        pytest.skip(f"the package index is unreachable, and installing the wheel needs it: {why}")
    return measure(tmp_path_factory.mktemp("wheel"))


def seed_kernel_cache(python: str, env: dict) -> int:
    """Copy this checkout's compiled kernels (Numba's .nbi/.nbc files) into the cache folder the
    installed deik of `python` uses; returns the number of files copied."""
    source = Path(cpu.launch.entry._cache._cache_path)
    target = Path(
        subprocess.run([python, "-c", CACHE_PATH], env=env, check=True, capture_output=True, text=True).stdout.strip()
    )
    target.mkdir(parents=True, exist_ok=True)
    files = [p for p in source.glob("*.nb[ic]")]
    for path in files:
        shutil.copy2(path, target / path.name)
    return len(files)


@pytest.mark.slow
def test_the_wheel_brings_what_the_readme_says(installed_wheel):
    names = {row["name"].lower() for row in installed_wheel["packages"]}
    assert names == {"deik", "numpy", "numba", "llvmlite", "lxml", "tqdm"}
    assert installed_wheel["package_count"] <= MAX_PACKAGES
    assert set(installed_wheel["numba_stack"]["packages"]) == {"numba", "llvmlite", "numpy"}
    assert installed_wheel["deik_additions"]["megabytes"] <= MAX_ADDITIONS_MEGABYTES
    # the README's figures, which tests/cli/test_readme_figures.py checks against the committed
    # results file, hold for this install too
    figures = [figure for figure in FIGURES if figure.source.endswith("/wheel_install.json")]
    assert figures, "the README no longer states the install's weight"
    assert [problem for figure in figures for problem in check(figure, installed_wheel)] == []


@pytest.mark.slow
@pytest.mark.shared_data
def test_every_readme_command_runs_against_the_installed_wheel(installed_wheel, tmp_path, shared_data):
    python = installed_wheel["python"]
    install(python, Path(installed_wheel["wheel_path"]), "viz")  # the README's second line: pictures
    command = [os.path.join(os.path.dirname(python), "deik")]  # the console script pip installed
    env = outside_env()
    seed_kernel_cache(python, env)
    warm = run_line("deik warmup --quiet", tmp_path, command, python, env)
    assert warm.returncode == 0, warm.stderr[-2000:]
    clone = clone_beside_shared(tmp_path, shared_data)
    lines = [line for line in bash_lines() if runnable(line, gpu_available(python))]
    records = run_lines(lines, clone, python, env)  # all in one process of the installed python
    for record in records:
        assert record["status"] == 0, f"{record['line']}\n{record['stderr']}"
        assert record.get("converged", True), f"{record['line']}: a README solve misses a goal"
    assert len(records) == len(lines) >= 13
    assert run_line("deik --version", clone, command, python, env).stdout.strip() == f"deik {deik.__version__}"

"""Cold start: the kernel cache follows NUMBA_CACHE_DIR and survives a read-only install, a command
says when it must compile first, and `deik warmup` compiles ahead of time."""

import os
import subprocess
import sys

import deik.solver.readiness as readiness
from deik.cli.app import main

CHECK_LOCATION = "from deik.backends import cpu_kernels as cpu; print(cpu.run_generations.entry._cache._cache_path)"


def _python(code: str, **env) -> str:
    run = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env={**os.environ, **env}
    )
    assert run.returncode == 0, run.stderr
    return run.stdout.strip()


def test_kernel_cache_goes_to_numba_cache_dir_when_set(tmp_path):
    assert _python(CHECK_LOCATION, NUMBA_CACHE_DIR=str(tmp_path)).startswith(str(tmp_path))
    assert _python(CHECK_LOCATION).endswith(os.path.join("deik", "backends", "__pycache__"))


def test_import_deik_loads_no_numpy_or_numba_and_a_name_loads_only_its_module():
    """`import deik` stays light: each public name loads its module on first use."""
    heavy = "('numpy', 'numba', 'scipy', 'deik.backends.cpu_kernels', 'deik.solver.solve', 'deik.io.bvh')"
    code = f"import sys, deik; print(sorted(m for m in {heavy} if m in sys.modules))"
    assert _python(code) == "[]"
    code = f"import sys, deik; deik.chain(3); print(sorted(m for m in {heavy} if m in sys.modules))"
    assert _python(code) == "['numpy']"
    code = "import deik, deik.retargeting.api; from deik import retarget as r; print(r is deik.retarget, callable(r))"
    assert _python(code) == "True True"  # the function, not the subpackage of the same name


def test_a_read_only_install_caches_in_the_user_folder(tmp_path):
    # as root every folder is writable, so the package folder is made to refuse the cache
    code = (
        "from numba.core import caching\n"
        "from deik.backends import targets\n"
        "def refuse(self): raise PermissionError('read-only')\n"
        "in_tree = [c for c in caching.CacheImpl._locator_classes if c.__name__ == '_StampedInTreeCacheLocator']\n"
        "in_tree[0].ensure_cache_path = refuse\n" + CHECK_LOCATION
    )
    path = _python(code, NUMBA_CACHE_DIR="", XDG_CACHE_HOME=str(tmp_path), HOME=str(tmp_path))
    assert path.startswith(str(tmp_path)) and "backends" in path


def test_no_compile_note_once_the_kernels_are_compiled(capsys):
    assert main(["warmup", "--dtype", "float64", "--quiet"]) == 0
    assert "CPU kernels for float64" in capsys.readouterr().out
    assert readiness.pending("float64", clip=True) == []
    assert main(["solve", "chain:3", "--reach", "tip", "1", "1", "0", "--dtype", "float64"]) == 0
    assert "compiling" not in capsys.readouterr().err


def test_a_fresh_cache_folder_gets_the_compile_note_before_any_compiling(tmp_path):
    code = (
        "import deik.solver.readiness as r\n"
        "print(r.compile_note(r.pending('float32')))\n"
        "print(r.compile_note(r.pending('float32', polish=False, clip=True), certain=False))"
    )
    solve, clip = _python(code, NUMBA_CACHE_DIR=str(tmp_path)).splitlines()
    assert solve.startswith("deik: compiling the CPU kernels first (DE float32, report float64): about ")
    assert "deik warmup" in solve and not any(tmp_path.rglob("*.nbc"))  # nothing was compiled
    # a clip fix may need no DE pass at all: it says "may" and "up to"
    assert clip.startswith(
        "deik: may compile the CPU kernels first (DE float32 without polish, report float64, "
        "clip warm start float64): up to about "
    )

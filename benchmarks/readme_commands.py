"""README.md's code blocks, and how to run their lines as a user would: from a folder laid out
like a clone beside shared/, with `deik` either from a checkout or from an installed wheel.

Used by tests/cli/test_readme.py (the clone) and tests/cli/test_wheel.py with
benchmarks.wheel_install (a fresh wheel install). A bash line that is neither a `deik` command
nor an example script is listed in EXCLUDED with the reason it cannot run in a test and what
runs it instead; SLOW names the `deik` commands left out and where they are tested.
"""

from __future__ import annotations

import re
import shlex
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

EXCLUDED = {
    "make demo": "creates .venv and installs from the package index, then compiles for minutes; its steps run "
    "as `deik warmup` (tests/cli/test_warmup.py) and the demo scenarios (tests/cli/test_cli.py)",
    "make test": "runs the test suite itself",
    "pip install .": "would change the test environment; tests/cli/test_wheel.py installs the wheel in a fresh venv",
    'pip install ".[viz]"': "would change the test environment; the test venv has the viz extra",
    'pip install -e ".[gpu]"': "needs the CUDA 13 wheels and a GPU; the GPU kernels are tested in the simulator",
}
SLOW = {
    "deik demo": "the demo's scenarios have their own tests (tests/cli/test_cli.py); make demo runs it",
    "deik warmup": "compiles both dtypes (minutes); tests/cli/test_warmup.py runs it for one",
}


def blocks(language: str, text: str | None = None) -> list[str]:
    """The code blocks of `language` in README.md (or `text`), in order."""
    return re.findall(rf"```{language}\n(.*?)```", README.read_text() if text is None else text, flags=re.S)


def bash_lines(text: str | None = None) -> list[str]:
    """Every line of the bash blocks, continuation lines joined, comments and blank lines dropped."""
    lines = []
    for block in blocks("bash", text):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split("  #")[0].strip()
            if line and not line.startswith("#"):
                lines.append(" ".join(line.split()))
    return lines


def runnable(line: str, gpu: bool) -> bool:
    """Whether a test runs this README bash line: a `deik` command (not SLOW, not GPU work
    without a GPU) or an example script."""
    if line.startswith("deik "):
        return not line.startswith(tuple(SLOW)) and ("--device gpu" not in line or gpu)
    return line.startswith("python examples/")


def clone_beside_shared(folder: Path, shared_data: Path) -> Path:
    """folder/deik laid out like a clone beside shared/: examples/ in it, shared/data beside it."""
    clone = folder / "deik"
    clone.mkdir()
    (folder / "shared").symlink_to(Path(shared_data).resolve().parent)
    (clone / "examples").symlink_to(ROOT / "examples")
    return clone


def run_line(line: str, clone: Path, deik: list[str], python: str, env: dict) -> subprocess.CompletedProcess:
    """Run README line `line` in `clone`: `deik ...` through the argv prefix `deik`, `python
    examples/...` through `python`."""
    words = shlex.split(line)
    argv = deik + words[1:] if words[0] == "deik" else [python, *words[1:]]
    return subprocess.run(argv, cwd=clone, capture_output=True, text=True, timeout=900, env=env)


def gpu_available(python: str) -> bool:
    """Whether `python` sees a CUDA GPU (numba-cuda installed and a device present)."""
    probe = "from numba import cuda; print(cuda.is_available())"
    return subprocess.run([python, "-c", probe], capture_output=True, text=True).stdout.strip() == "True"

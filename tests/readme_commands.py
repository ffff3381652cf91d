"""README.md's code blocks, and how to run their lines as a user would: from a folder laid out
like a clone beside shared/, with `deik` either from a checkout or from an installed wheel.
The README's commands write into one folder, OUTPUTS, made by its `mkdir -p` line.

Used by tests/cli/test_readme.py (the clone) and tests/cli/test_wheel.py (a fresh wheel
install, benchmarks.wheel_install's steps). A bash line that is neither a `deik` command
nor an example script is listed in EXCLUDED with the reason it cannot run in a test and what
runs it instead; SLOW names the `deik` commands left out and where they are tested.
"""

from __future__ import annotations

import json
import re
import shlex
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
OUTPUTS = "out"  # the folder every README command writes into
MKDIR = f"mkdir -p {OUTPUTS}"

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
    without a GPU), an example script, or the line making the outputs' folder."""
    if line.startswith("deik "):
        return not line.startswith(tuple(SLOW)) and ("--device gpu" not in line or gpu)
    return line.startswith("python examples/") or line == MKDIR


def clone_beside_shared(folder: Path, shared_data: Path) -> Path:
    """folder/deik laid out like a clone beside shared/: examples/ in it, shared/data beside it."""
    clone = folder / "deik"
    clone.mkdir()
    (folder / "shared").symlink_to(Path(shared_data).resolve().parent)
    (clone / "examples").symlink_to(ROOT / "examples")
    return clone


def run_line(line: str, clone: Path, deik: list[str], python: str, env: dict) -> subprocess.CompletedProcess:
    """Run README line `line` in `clone` in a process of its own: `deik ...` through the argv
    prefix `deik` (e.g. an installed console script), `python examples/...` through `python`,
    `mkdir -p ...` as it is."""
    words = shlex.split(line)
    argv = deik + words[1:] if words[0] == "deik" else words if words[0] == "mkdir" else [python, *words[1:]]
    return subprocess.run(argv, cwd=clone, capture_output=True, text=True, timeout=900, env=env)


# Runs README lines one after another in one process of the Python under test: each `deik` line
# through deik.cli.main, each example through runpy as `python examples/X.py` would. One line of
# JSON per README line: its exit status, the ends of its stderr and stdout, and for a solve that
# wrote a pose JSON whether it met every goal and the length unit it names. (A process per line
# costs seconds of imports and kernel loads.)
DRIVER = r"""
import contextlib, io, json, os, runpy, shlex, sys
from deik.cli.app import main
for line in json.load(sys.stdin):
    words, err, out = shlex.split(line), io.StringIO(), io.StringIO()
    record = {"line": line}
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            if words[:2] == ["mkdir", "-p"]:
                for folder in words[2:]:
                    os.makedirs(folder, exist_ok=True)
                record["status"] = 0
            elif words[0] == "deik":
                record["status"] = main(words[1:])
            else:
                sys.argv = words[1:]
                try:
                    runpy.run_path(words[1], run_name="__main__")
                    record["status"] = 0
                except SystemExit as done:
                    record["status"] = done.code or 0
        except BaseException as error:
            record["status"] = f"{type(error).__name__}: {error}"
    written = words[words.index("--out") + 1] if "--out" in words else ""
    if words[:2] == ["deik", "solve"] and written.endswith(".json") and record["status"] == 0:
        pose = json.load(open(written))
        record["converged"], record["length_unit"] = pose["converged"], pose.get("length_unit")
    record["stderr"] = err.getvalue()[-2000:]
    record["stdout"] = out.getvalue()[-20000:]
    print(json.dumps(record), flush=True)
"""


def run_lines(lines: list[str], clone: Path, python: str, env: dict) -> list[dict]:
    """Run README `lines` in order in `clone`, all in one process of `python` (DRIVER): one
    record per line that ran ({"line", "status", "stderr", "stdout"}, "converged" and
    "length_unit" for a solve that wrote a pose JSON); a line missing from the end means the process died there."""
    run = subprocess.run(
        [python, "-c", DRIVER], input=json.dumps(lines), cwd=clone, env=env, capture_output=True, text=True
    )
    records = [json.loads(text) for text in run.stdout.splitlines() if text.startswith("{")]
    if len(records) < len(lines):
        records.append({"line": lines[len(records)], "status": "the process died", "stderr": run.stderr[-2000:]})
    return records


def gpu_available(python: str) -> bool:
    """Whether `python` sees a CUDA GPU (numba-cuda installed and a device present)."""
    probe = "from numba import cuda; print(cuda.is_available())"
    return subprocess.run([python, "-c", probe], capture_output=True, text=True).stdout.strip() == "True"

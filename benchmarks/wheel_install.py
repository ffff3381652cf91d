"""A fresh wheel install, as a user gets one: deik's wheel built from the checkout, installed into a
new virtual environment, and every package that came with it measured, with its version and its
size on disk (its installed files, compiled .pyc included; MB of 10^6 bytes), against issue
19's targets of at most 10 packages and 200 MB; and split into what Numba brings for itself
(numba and its own dependencies, llvmlite and NumPy: the engine deik compiles its kernels with)
and deik's additions beyond them (deik itself and its other dependencies), against issue 30's
target of at most 20 MB for the additions.

    python -m benchmarks.wheel_install                   # results/wheel_install.{json,md,png}
    python -m benchmarks.wheel_install --extras view     # what `deik[view]` adds: results/wheel_install_view.*

With --extras the plain wheel is installed first and then `deik[EXTRAS]` into the same
environment: the record holds both, and what the extras add, package by package. Needs the
package index (the build fetches setuptools, the install deik's requirements) and stops with a
one-line reason without it. tests/cli/test_wheel.py uses the same steps and then runs the
README's commands against the installed `deik`.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks import harness

ROOT = Path(__file__).resolve().parents[1]
MAX_PACKAGES, MAX_MEGABYTES = 10, 200.0  # issue 19 item 1
MAX_ADDITIONS_MEGABYTES = 20.0  # issue 30: deik's additions beyond Numba's own dependencies
ENGINE = "numba"  # what deik compiles its kernels with; its dependency closure is "Numba's stack"
MB = 1e6
BUILD_FILES = ("pyproject.toml", "README.md", "LICENSE")  # with src/: all a build of deik reads

# run inside the new environment: each installed distribution's name, version, bytes on disk and
# the names it requires (extras' requirements left out)
SIZES = """
import json, re
from importlib import metadata
rows = []
for dist in metadata.distributions():
    files = [f.locate() for f in dist.files or ()]
    needs = [re.match(r"[A-Za-z0-9._-]+", r)[0] for r in dist.requires or () if "extra ==" not in r]
    rows.append({"name": dist.metadata["Name"], "version": dist.version,
                 "bytes": sum(p.stat().st_size for p in files if p.is_file()), "requires": needs})
print(json.dumps(rows))
"""


def _key(name: str) -> str:
    """A distribution name as pip compares them (PEP 503): lower case, runs of -_. as one -."""
    return re.sub(r"[-_.]+", "-", name).lower()


def split_engine(packages: list[dict]) -> dict:
    """Of the installed `packages` (rows with "name", "bytes", "requires"), Numba's stack (numba
    and every package it requires, directly or not) and deik's additions (the rest), each
    {"packages": names, "megabytes"}."""
    by_key = {_key(row["name"]): row for row in packages}
    stack, todo = set(), [ENGINE]
    while todo:
        key = _key(todo.pop())
        if key in by_key and key not in stack:
            stack.add(key)
            todo += by_key[key]["requires"]
    parts = {"numba_stack": [r for k, r in by_key.items() if k in stack]}
    parts["deik_additions"] = [r for k, r in by_key.items() if k not in stack]
    return {
        part: {"packages": [row["name"] for row in rows], "megabytes": sum(row["bytes"] for row in rows) / MB}
        for part, rows in parts.items()
    }


def outside_env() -> dict:
    """This process's environment without what would let another Python see this checkout
    (PYTHONPATH: its src/ and egg-info) or share its kernel cache (NUMBA_CACHE_DIR)."""
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "NUMBA_CACHE_DIR")}


def pip(python: str, *arguments: str) -> subprocess.CompletedProcess:
    """`python -m pip ARGUMENTS`, quiet, outside this checkout; raises CalledProcessError with
    pip's output on failure."""
    command = [python, "-m", "pip", "--disable-pip-version-check", *arguments, "--quiet"]
    return subprocess.run(command, check=True, capture_output=True, text=True, env=outside_env())


def index_reachable(python: str = sys.executable) -> tuple[bool, str]:
    """(whether pip can fetch a small package from the package index, pip's last line if not)."""
    with tempfile.TemporaryDirectory() as folder:
        try:
            pip(python, "download", "--no-deps", "--dest", folder, "--timeout", "20", "--retries", "0", "tqdm")
        except subprocess.CalledProcessError as error:
            lines = (error.stderr or error.stdout or "no output").strip().splitlines()
            return False, lines[-1] if lines else "no output"
    return True, ""


def build_wheel(folder: Path) -> Path:
    """deik's wheel, built into `folder` from a copy of what the build reads (no build/ or
    egg-info left in the checkout, no stale build/ slipping a deleted module into the wheel), an
    isolated build as `pip install .` makes."""
    source = folder / "source"
    source.mkdir(parents=True)
    for name in BUILD_FILES:
        shutil.copy2(ROOT / name, source / name)
    shutil.copytree(ROOT / "src", source / "src", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    pip(sys.executable, "wheel", "--no-deps", "--wheel-dir", str(folder), str(source))
    (wheel,) = folder.glob("deik-*.whl")
    return wheel


def installed(python: str) -> list[dict]:
    """Every distribution in the environment of `python`: name, version, bytes; largest first."""
    out = subprocess.run([python, "-c", SIZES], check=True, capture_output=True, text=True, env=outside_env()).stdout
    return sorted(json.loads(out), key=lambda row: -row["bytes"])


def install(python: str, wheel: Path, extras: str = "") -> dict:
    """Install `wheel` (with `extras`, e.g. "viz") into the environment of `python`: the packages
    it brought (those not there before), their count and MB, and the install's seconds."""
    before = {row["name"].lower() for row in installed(python)}
    began = time.perf_counter()
    pip(python, "install", f"{wheel}[{extras}]" if extras else str(wheel))
    seconds = time.perf_counter() - began
    brought = [row for row in installed(python) if row["name"].lower() not in before]
    megabytes = sum(row["bytes"] for row in brought) / MB
    return {"packages": brought, "package_count": len(brought), "megabytes": megabytes, "install_seconds": seconds}


def measure(folder: Path, extras: str = "") -> dict:
    """Build, make a fresh environment in `folder` and install the wheel (then its `extras`):
    the install's record (the plain install split into Numba's stack and deik's additions,
    split_engine), the environment's python and the wheel's path and size."""
    wheel = build_wheel(folder / "dist")
    subprocess.run([sys.executable, "-m", "venv", str(folder / "venv")], check=True, env=outside_env())
    python = str(folder / "venv" / "bin" / "python")
    bootstrap = sorted(row["name"] for row in installed(python))
    record = {"python": python, "wheel_path": str(wheel), "wheel": wheel.name, "wheel_bytes": wheel.stat().st_size}
    plain = install(python, wheel)
    record |= {**plain, **split_engine(plain["packages"]), "bootstrap_left_out": bootstrap}
    if extras:
        record["extras"] = {"name": extras, **install(python, wheel, extras)}
    return record


def main(argv=None) -> dict:
    p = harness.parser(__doc__)
    p.add_argument("--extras", default="", help='install deik[EXTRAS] too, e.g. "view" (default: none)')
    run = harness.start("wheel_install", p, argv)
    extras = run.args.extras
    run.name += f"_{extras}" if extras else ""
    reachable, why = index_reachable()
    if not reachable:
        raise SystemExit(f"the package index is unreachable ({why}); this benchmark installs from it")
    with tempfile.TemporaryDirectory() as folder:
        record = measure(Path(folder), extras)
    del record["python"], record["wheel_path"]  # in a temporary folder, gone
    run.target("packages a plain install brings", MAX_PACKAGES, record["package_count"], "packages", at_most=True)
    run.target("MB a plain install brings", MAX_MEGABYTES, record["megabytes"], "MB", at_most=True)
    additions = record["deik_additions"]["megabytes"]
    run.target("MB deik adds beyond Numba's stack", MAX_ADDITIONS_MEGABYTES, additions, "MB", at_most=True)
    shown = record["extras"]["packages"] if extras else record["packages"]
    fig, axes = harness.figure()
    harness.bars(axes[0, 0], [row["name"] for row in shown], [row["bytes"] / MB for row in shown], horizontal=True)
    what = f"deik[{extras}] adds" if extras else "a plain install brings"
    harness.style_axes(axes[0, 0], "MB on disk", "", f"{what} {len(shown)} packages", xlog=False, ylog=False)
    header = ["package", "version", "MB", "with"]
    cells = [[row["name"], row["version"], f"{row['bytes'] / MB:.1f}", "deik"] for row in record["packages"]]
    cells += [
        [row["name"], row["version"], f"{row['bytes'] / MB:.1f}", f"[{extras}]"]
        for row in record.get("extras", {}).get("packages", [])
    ]
    figures = {
        "packages": record["package_count"],
        "MB": record["megabytes"],
        "Numba's stack MB": record["numba_stack"]["megabytes"],
        "deik's additions MB": additions,
    }
    if extras:
        figures |= {
            f"[{extras}] adds packages": record["extras"]["package_count"],
            f"[{extras}] adds MB": record["extras"]["megabytes"],
        }
    return run.finish(record, harness.md_table(header, cells), fig, figures)


if __name__ == "__main__":
    main()

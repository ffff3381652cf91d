"""A fresh wheel install, as a user gets one: build deik's wheel, install it into a new virtual
environment and measure what came with it: every package and its size on disk (its installed
files, compiled .pyc included), against issue 19's targets of at most 10 packages and 200 MB.

    python -m benchmarks.wheel_install                 # results/wheel_install.json and .png
    python -m benchmarks.wheel_install --extras viz    # deik[viz] instead

Needs the package index (the build fetches setuptools, the install numpy, numba, llvmlite, lxml
and tqdm). tests/cli/test_wheel.py uses the same steps and then runs the README's `deik`
commands against the installed `deik` (benchmarks.readme_commands).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.readme_commands import ROOT

RESULTS = ROOT / "benchmarks" / "results"
MAX_PACKAGES, MAX_MEGABYTES = 10, 200.0  # issue 19 item 1
MB = 1e6
BUILD_FILES = ("pyproject.toml", "README.md", "LICENSE")  # with src/: all a build of deik reads

# run inside the new environment: each installed distribution's name, version and bytes on disk
SIZES = """
import json
from importlib import metadata
rows = []
for dist in metadata.distributions():
    files = [f.locate() for f in dist.files or ()]
    rows.append({"name": dist.metadata["Name"], "version": dist.version,
                 "bytes": sum(p.stat().st_size for p in files if p.is_file())})
print(json.dumps(rows))
"""


def outside_env() -> dict:
    """This process's environment without what would let another Python see this checkout
    (PYTHONPATH: its src/ and egg-info) or share its kernel cache (NUMBA_CACHE_DIR)."""
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "NUMBA_CACHE_DIR")}


def pip(python: str, *arguments: str) -> subprocess.CompletedProcess:
    """`python -m pip ARGUMENTS`, quiet, outside this checkout; raises CalledProcessError with
    pip's output on failure."""
    return subprocess.run(
        [python, "-m", "pip", "--disable-pip-version-check", *arguments, "--quiet"],
        check=True,
        capture_output=True,
        text=True,
        env=outside_env(),
    )


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
    """Build deik's wheel into `folder` from a copy of what the build reads (pyproject.toml,
    README.md, LICENSE, src/ without caches), so no build/ or egg-info is left in the checkout
    and no stale build/ can slip a deleted module into the wheel; an isolated build, as pip
    does for `pip install .`. Returns the wheel's path."""
    source = folder / "source"
    source.mkdir(parents=True)
    for name in BUILD_FILES:
        shutil.copy2(ROOT / name, source / name)
    shutil.copytree(ROOT / "src", source / "src", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    pip(sys.executable, "wheel", "--no-deps", "--wheel-dir", str(folder), str(source))
    (wheel,) = folder.glob("deik-*.whl")
    return wheel


def fresh_environment(folder: Path) -> str:
    """A new virtual environment in `folder`, made by this interpreter's base Python; returns
    its python. pip and what venv puts there besides are not counted (see measure)."""
    subprocess.run([sys.executable, "-m", "venv", str(folder)], check=True, env=outside_env())
    return str(folder / "bin" / "python")


def installed(python: str) -> list[dict]:
    """Every distribution in the environment of `python`: name, version, bytes."""
    out = subprocess.run([python, "-c", SIZES], check=True, capture_output=True, text=True, env=outside_env()).stdout
    return sorted(json.loads(out), key=lambda row: -row["bytes"])


def install(python: str, wheel: Path, extras: str = "") -> dict:
    """Install `wheel` (with `extras`, e.g. "viz") into the environment of `python`; returns the
    packages it brought (every distribution not there before: deik and its dependencies) with
    their sizes, the bootstrap packages left out, and the install's seconds."""
    before = {row["name"].lower() for row in installed(python)}
    began = time.perf_counter()
    pip(python, "install", f"{wheel}[{extras}]" if extras else str(wheel))
    seconds = time.perf_counter() - began
    rows = installed(python)
    brought = [row for row in rows if row["name"].lower() not in before]
    return {
        "packages": brought,
        "package_count": len(brought),
        "megabytes": sum(row["bytes"] for row in brought) / MB,
        "bootstrap_left_out": sorted(before),
        "install_seconds": seconds,
    }


def measure(folder: Path, extras: str = "") -> dict:
    """Build, make a fresh environment in `folder` and install; the install's record plus the
    environment's python and the wheel's size."""
    wheel = build_wheel(folder / "dist")
    python = fresh_environment(folder / "venv")
    record = install(python, wheel, extras)
    return {
        "python": python,
        "wheel_path": str(wheel),
        "wheel": wheel.name,
        "wheel_bytes": wheel.stat().st_size,
        **record,
    }


def _picture(record: dict, extras: str, path: Path) -> None:
    """A bar per package, MB, with the 200 MB target for the total."""
    from deik.experiments.shared import save_figure
    from deik.viz.plot import require_matplotlib

    plt = require_matplotlib()
    rows = record["packages"]
    figure, axes = plt.subplots(figsize=(7, 3.5))
    axes.barh([row["name"] for row in rows][::-1], [row["bytes"] / MB for row in rows][::-1])
    axes.set_xlabel("MB on disk")
    axes.set_title(
        f"pip install {record['wheel']}{f' [{extras}]' if extras else ''} into a fresh venv:\n"
        f"{record['package_count']} packages, {record['megabytes']:.0f} MB "
        f"(targets: at most {MAX_PACKAGES} packages, {MAX_MEGABYTES:.0f} MB)",
        fontsize=10,
    )
    figure.tight_layout()
    save_figure(figure, str(path))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--extras", default="", help='install deik[EXTRAS], e.g. "viz" (default: none)')
    parser.add_argument("--out", type=Path, default=RESULTS, help="results folder (default benchmarks/results)")
    args = parser.parse_args(argv)
    reachable, why = index_reachable()
    if not reachable:
        raise SystemExit(f"the package index is unreachable ({why}); this benchmark installs from it")
    from deik.experiments.timing import cpu_model
    from deik.io.atomic import write_json_atomically

    with tempfile.TemporaryDirectory() as folder:
        record = measure(Path(folder), args.extras)
    del record["python"], record["wheel_path"]  # in a temporary folder, gone
    name = "wheel_install" + (f"_{args.extras}" if args.extras else "")
    record = {
        "benchmark": name,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "command": f"python -m benchmarks.wheel_install{f' --extras {args.extras}' if args.extras else ''}",
        **record,
        "targets": {
            "packages_at_most": MAX_PACKAGES,
            "packages_met": record["package_count"] <= MAX_PACKAGES,
            "megabytes_at_most": MAX_MEGABYTES,
            "megabytes_met": record["megabytes"] <= MAX_MEGABYTES,
        },
        "machine": {"cpu_model": cpu_model(), "python": sys.version.split()[0], "platform": sys.platform},
    }
    os.makedirs(args.out, exist_ok=True)
    write_json_atomically(str(args.out / f"{name}.json"), record)
    _picture(record, args.extras, args.out / f"{name}.png")
    for row in record["packages"]:
        print(f"{row['name']:12s} {row['version']:10s} {row['bytes'] / MB:8.1f} MB")
    print(
        f"{record['package_count']} packages, {record['megabytes']:.1f} MB (targets: {MAX_PACKAGES} packages, "
        f"{MAX_MEGABYTES:.0f} MB); wrote {args.out / name}.json and .png"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

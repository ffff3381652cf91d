"""What the `view` extra (`pip install "deik[view]"`, for `deik view`) adds to an install: the
packages and megabytes its requirements bring beside deik's own, measured in two fresh virtual
environments made with this Python's venv and filled by pip from the package index.

    python -m benchmarks.view_install        # about a minute; needs the package index

Writes results/view_install.json (the requirements, each environment's packages and size, and
what the extra adds, package by package) and results/view_install.png (the added megabytes by
package).
"""

from __future__ import annotations

import argparse
import datetime
import json
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

from benchmarks.serial_vs_parallel import RESULTS
from deik.experiments.shared import save_figure
from deik.io.atomic import write_json_atomically
from deik.viz.plot import require_matplotlib

ROOT = Path(__file__).resolve().parents[1]
MB = 1e6


def requirements() -> tuple[list[str], list[str]]:
    """(deik's own requirements, the view extra's), from pyproject.toml."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return project["dependencies"], project["optional-dependencies"]["view"]


def environment(folder: Path, packages: list[str]) -> dict:
    """A fresh venv in `folder` with `packages` installed: {package name: bytes on disk}, pip,
    setuptools and wheel (which come with any venv) left out."""
    subprocess.run([sys.executable, "-m", "venv", str(folder)], check=True)
    python = folder / "bin" / "python"
    subprocess.run([python, "-m", "pip", "install", "--quiet", *packages], check=True)
    listed = subprocess.run([python, "-m", "pip", "list", "--format", "json"], check=True, capture_output=True)
    names = {p["name"].lower() for p in json.loads(listed.stdout)} - {"pip", "setuptools", "wheel"}
    script = (
        "import json, sys\nfrom importlib import metadata\nout = {}\n"
        "for d in metadata.distributions():\n"
        "    files = [f.locate() for f in d.files or []]\n"
        "    out[d.metadata['Name'].lower()] = sum(p.stat().st_size for p in files if p.is_file())\n"
        "json.dump(out, sys.stdout)"
    )
    sizes = json.loads(subprocess.run([python, "-c", script], check=True, capture_output=True).stdout)
    return {name: sizes.get(name, 0) for name in sorted(names)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=RESULTS, help="results folder (default benchmarks/results)")
    args = p.parse_args(argv)
    own, view = requirements()
    with tempfile.TemporaryDirectory() as folder:
        base = environment(Path(folder) / "base", own)
        with_view = environment(Path(folder) / "view", own + view)
    added = {name: size for name, size in with_view.items() if name not in base}
    result = {
        "date": datetime.date.today().isoformat(),
        "python": sys.version.split()[0],
        "requirements": own,
        "view_extra": view,
        "base_packages": len(base),
        "base_mb": sum(base.values()) / MB,
        "view_packages": len(with_view),
        "view_mb": sum(with_view.values()) / MB,
        "added_packages": len(added),
        "added_mb": sum(added.values()) / MB,
        "added_mb_by_package": {name: size / MB for name, size in sorted(added.items(), key=lambda kv: -kv[1])},
    }
    args.out.mkdir(parents=True, exist_ok=True)
    write_json_atomically(args.out / "view_install.json", result)
    plt = require_matplotlib()
    figure, ax = plt.subplots(figsize=(8, 4.5), layout="constrained")
    names = list(result["added_mb_by_package"])
    ax.barh(names[::-1], [result["added_mb_by_package"][n] for n in names[::-1]], color="tab:blue")
    ax.set_xlabel("MB on disk")
    ax.set_title(f"the view extra adds {len(added)} packages, {result['added_mb']:.0f} MB beside deik's own")
    save_figure(figure, str(args.out / "view_install.png"))
    print(
        f"deik's requirements: {result['base_packages']} packages, {result['base_mb']:.0f} MB; with the view "
        f"extra: {result['view_packages']} packages, {result['view_mb']:.0f} MB; added {len(added)} packages, "
        f"{result['added_mb']:.0f} MB ({', '.join(names)})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

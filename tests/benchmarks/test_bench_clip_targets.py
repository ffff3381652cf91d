"""The README's clip table is that of benchmarks/results/clip_targets.json, row for row (the
counts its text states are checked with the README's other figures, tests/readme_figures.py)."""

import json

from benchmarks.clip_targets import readme_table
from helpers import ROOT

README = (ROOT / "README.md").read_text()
RESULTS = json.loads((ROOT / "benchmarks" / "results" / "clip_targets.json").read_text())


def test_the_readme_table_is_the_benchmark_s():
    assert readme_table(RESULTS["cases"]) in README
    assert RESULTS["command"].startswith("python -m benchmarks.clip_targets")  # every clip, the default command
    assert len(RESULTS["cases"]) == 24  # 8 shared clips, each as it is, on the studio rig and transformed

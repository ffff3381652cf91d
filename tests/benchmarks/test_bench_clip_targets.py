"""The README's clip figures are those of benchmarks/results/clip_targets.json: its table, and the
counts of cases meeting each target that its text states."""

import json
import re

from benchmarks.clip_targets import readme_table
from helpers import ROOT

README = (ROOT / "README.md").read_text()
RESULTS = json.loads((ROOT / "benchmarks" / "results" / "clip_targets.json").read_text())


def met(target: str) -> int:
    return sum(bool(case["verdicts"].get(target)) for case in RESULTS["cases"])


def test_the_readme_table_is_the_benchmark_s():
    assert readme_table(RESULTS["cases"]) in README
    assert RESULTS["command"].startswith("python -m benchmarks.clip_targets")  # every clip, the default command


def test_the_readme_counts_are_the_benchmark_s():
    text = " ".join(README.split())
    stated = re.search(
        r"The acceleration target holds on all (\d+) cases and the body travels as far as in the capture on "
        r"(\d+); sliding holds on (\d+) and depth on only (\d+):.*? and on (\d+) cases \(",
        text,
    )
    assert stated, "the README's sentence on the clip targets was reworded: update this test"
    peaks, travel, sliding, depth, unlisted = map(int, stated.groups())
    assert peaks == met("peaks") == len(RESULTS["cases"])
    assert (travel, sliding, depth) == (met("travel"), met("sliding"), met("depth"))
    assert unlisted == len(RESULTS["cases"]) - met("listed")


def test_the_readme_s_run_figures_are_the_benchmark_s():
    text = " ".join(README.split())
    after, before = map(
        float, re.search(r"the run's feet, (\d+) mm under the floor .*?, go (\d+) mm under", text).groups()
    )
    run = next(case for case in RESULTS["cases"] if case["case"] == "run")
    assert (after, before) == (round(run["depth_mm"]), round(run["depth_capture_mm"]))

"""The harness every benchmark writes through and benchmarks.compare, which runs one benchmark on
two commits taking turns and sets their figures side by side."""

import json
import math
import subprocess

import pytest

from benchmarks import compare, harness


def test_a_run_writes_its_record_markdown_and_targets(tmp_path, capsys):
    run = harness.start("mine", harness.parser("mine"), ["--quick", "--out", str(tmp_path), "--seed", "3"])
    run.target("seconds", 2.0, 1.5, "s", applies=True, at_most=True)
    run.target("rate", 10.0, 4.0, "/s", applies=False)
    record = run.finish({"rows": [math.nan, 1.0]}, harness.md_table(["a", "b"], [[1, "x|y"]], "table"))
    saved = json.loads((tmp_path / "mine.json").read_text())  # NaN is not JSON: written as null
    assert (
        saved["rows"] == [None, 1.0]
        and saved["command"] == "python -m benchmarks.mine --quick --out " + str(tmp_path) + " --seed 3"
    )
    assert [t["met"] for t in saved["targets"]] == [True, None] and saved["figures"] == {"seconds": 1.5, "rate": 4.0}
    assert saved["environment"]["cpu_model"] and saved["environment"]["load_average_after"]
    text = (tmp_path / "mine.md").read_text()
    assert "### table" in text and "| 1 | x\\|y |" in text and "- Target: rate >= 10 /s: 4, not judged here" in text
    assert text in capsys.readouterr().out and record["seconds"] >= 0 and not (tmp_path / "mine.png").exists()


def test_side_by_side_takes_medians_over_the_rounds_and_divides_after_by_before():
    runs = {
        "before": [
            {"figures": {"rate": 2.0, "gone": 1.0}},
            {"figures": {"rate": 4.0, "gone": None}},
            {"figures": {"rate": 3.0}},
        ],
        "after": [{"figures": {"rate": 9.0}}, {"figures": {"rate": 6.0}}, {"figures": {"rate": 3.0}}],
    }
    rate, gone = compare.side_by_side(runs)
    assert rate["before"] == {"values": [2.0, 4.0, 3.0], "median": 3.0} and rate["after"]["median"] == 6.0
    assert rate["ratio"] == 2.0
    assert (
        gone["before"]["values"] == [1.0] and gone["after"] == {"values": [], "median": None} and gone["ratio"] is None
    )


@pytest.mark.slow
def test_compare_runs_a_benchmark_on_two_commits_in_turns(tmp_path):
    result = compare.main(
        ["parsing", "HEAD", "--rounds", "2", "--out", str(tmp_path), "--", "--quick", "--repeats", "1"]
    )
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    assert result["trees"]["before"] == head and result["trees"]["after"].startswith(head)
    assert [len(result["runs"][side]) for side in ("before", "after")] == [2, 2]
    sources = {side: {r["environment"]["deik_source"] for r in runs} for side, runs in result["runs"].items()}
    assert "deik-compare-" in sources["before"].pop() and sources["after"] == {str(compare.ROOT / "src" / "deik")}
    for row in result["figures"]:
        assert len(row["before"]["values"]) == len(row["after"]["values"]) == 2
        assert row["ratio"] == pytest.approx(row["after"]["median"] / row["before"]["median"])
    name = f"parsing_{result['trees']['before']}_{result['trees']['after']}"
    assert json.loads((tmp_path / f"{name}.json").read_text())["figures"] == result["figures"]
    assert "| urdf 250 s |" in (tmp_path / f"{name}.md").read_text()
    worktrees = subprocess.run(["git", "worktree", "list"], capture_output=True, text=True).stdout
    assert "deik-compare-" not in worktrees  # the temporary checkout is removed

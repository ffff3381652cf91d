"""A few hundred mutated BVH, URDF and TOML files through the command line: each ends in a result
or one `deik: error:` line naming the file, never a traceback, an internal error or a hang
(benchmarks/fuzz_cli.py; `python -m benchmarks.fuzz_cli --cases 3000` runs thousands)."""

from benchmarks.fuzz_cli import fuzz


def test_mutated_inputs_end_in_a_result_or_one_line_naming_the_file(tmp_path):
    found = fuzz(300, seed=0, folder=tmp_path)
    assert found["failures"] == [], found["failures"][:5]
    assert found["outcomes"]["error"] > 0 and found["outcomes"]["ok"] > 0  # both paths were exercised

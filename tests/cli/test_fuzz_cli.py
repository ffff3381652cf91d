"""A few hundred mutated BVH, URDF and TOML files through the command line, in a process with a
6 GiB address-space bound: each ends in a result or one `deik: error:` line naming the file, never
a traceback, an internal error, a hang or a run out of memory (benchmarks/fuzz_cli.py;
`python -m benchmarks.fuzz_cli --cases 3000` runs thousands)."""

import json
import subprocess
import sys


def test_mutated_inputs_end_in_a_result_or_one_line_naming_the_file(tmp_path):
    run = subprocess.run(
        [sys.executable, "-m", "benchmarks.fuzz_cli", "--cases", "300", "--memory-gib", "6", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=1200,
    )
    found = json.loads((tmp_path / "fuzz_cli.json").read_text())
    assert run.returncode == 0 and found["failures"] == [], (run.stdout[-2000:], found["failures"][:5])
    assert found["outcomes"]["error"] > 0 and found["outcomes"]["ok"] > 0  # both paths were exercised

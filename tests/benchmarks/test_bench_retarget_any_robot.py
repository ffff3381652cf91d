"""benchmarks/retarget_quality.py with --robot and --map: every clip as captured onto any URDF,
judged as the plan's runs are (here the walk onto human.urdf through its own map), and the two
options refused apart."""

import json

import pytest

from benchmarks import retarget_quality as quality
from helpers import shared_path


@pytest.mark.shared_data
def test_a_robot_and_its_map_take_the_clips(tmp_path, capsys):
    robot = shared_path("robots", "human.urdf")
    argv = ["--robot", str(robot), "--map", str(quality.URDF_MAP), "--quick", "--out", str(tmp_path)]
    record = quality.main(argv)
    capsys.readouterr()
    (run,) = record["runs"]
    assert run["target"] == "human.urdf" and run["case"] == "as captured" and "failed" not in run
    assert run["sliding_max_mm_per_frame"] <= 1.0 and run["wrap_count"] == 0
    assert run["wrist_distance_max_mm"] <= run["wrist_bound_mm"]
    assert json.loads((tmp_path / "retarget_quality.json").read_text())["command"].endswith(
        f"--robot {robot} --map {quality.URDF_MAP} --quick --out {tmp_path}"
    )


def test_a_robot_without_its_map_or_file_is_refused(tmp_path):
    with pytest.raises(SystemExit, match="give --robot FILE.urdf and --map MAP.toml together"):
        quality.main(["--robot", "robot.urdf", "--out", str(tmp_path)])
    with pytest.raises(SystemExit, match="--robot robot.urdf: no such file"):
        quality.main(["--robot", "robot.urdf", "--map", str(quality.URDF_MAP), "--out", str(tmp_path)])

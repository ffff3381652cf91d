"""The command line, TOML problem files, pose pictures and the demo's helpers, on tiny problems."""

import dataclasses
import json
import re
import subprocess
import sys

import numpy as np
import pytest

import deik
from deik.cli.app import main
from deik.experiments.demo import chain_scenarios, run_demo
from deik.io.load import skeleton_from_spec
from deik.model.rotations import euler_matrix
from deik.solver.problem_file import load_problem
from deik.viz import plot

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
TINY = ["--population", "24", "--generations", "40", "--seed", "0"]


def write(tmp_path, text, name="problem.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_solve_writes_json_whose_angles_reproduce_the_error(tmp_path, capsys):
    out = tmp_path / "pose.json"
    assert main(["solve", "chain:5", "--reach", "tip", "3", "2", "0", *TINY, "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    tip = deik.forward_kinematics(deik.chain(5), data["angles"]).position("tip")
    assert data["goals"][0]["label"] == "position tip"
    assert np.linalg.norm(tip - [3, 2, 0]) == pytest.approx(data["goals"][0]["error"], rel=1e-9)
    printed = capsys.readouterr().out
    assert "position tip" in printed and "generations" in printed and "device cpu" in printed
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pose.json"]


def test_plot_writes_a_png_and_progress_goes_to_stderr(tmp_path, capsys):
    png = tmp_path / "pose.png"
    argv = [
        "solve",
        "chain:4",
        "--reach",
        "tip",
        "2",
        "1",
        "0",
        "--comfort",
        "0.5",
        "--progress",
        "--population",
        "24",
        "--generations",
        "120",
        "--plot",
        str(png),
    ]
    assert main(argv) == 0
    assert png.read_bytes()[:8] == PNG_MAGIC
    assert "deik solve: 100%" in capsys.readouterr().err  # --progress: the bar, though stderr is no terminal
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pose.png"]


def test_plot_pose_draws_3d_skeletons_in_two_views(tmp_path):
    skeleton = deik.chain(3, dims=3)
    assert not plot.is_planar(skeleton) and plot.is_planar(deik.chain(3))
    path = tmp_path / "pose.png"
    plot.plot_pose(
        skeleton,
        np.full(skeleton.n_dofs, 0.3),
        path,
        plot.PoseMarks(targets=[(1, 1, 1)], com=(0.5, 0.2, 0.1), support=(0, 0, 0), obstacles=[((1, 0, 0), 0.2)]),
        title="3-D",
    )
    assert path.read_bytes()[:8] == PNG_MAGIC


def test_missing_matplotlib_names_the_extra(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(ImportError, match=r'pip install "deik\[viz\]"'):
        plot.require_matplotlib()
    argv = [
        "solve",
        "chain:3",
        "--reach",
        "tip",
        "1",
        "1",
        "0",
        "--out",
        str(tmp_path / "p.json"),
        "--plot",
        str(tmp_path / "p.png"),
    ]
    assert main(argv) == 2
    assert "deik[viz]" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


TOML = """
skeleton = "chain3d:4"
limits = "clip"

[settings]
population = 24
generations = 30
seed = 2

[[goal]]
type = "position"
frame = "tip"
target = [2.0, 1.0, 0.5]
tolerance = 0.01

[[goal]]
type = "orientation"
frame = "link3"
euler = "XYZ"
degrees = [0, 30, 45]
level = 1

[[goal]]
type = "aim"
frame = "link2"
target = [0, 3, 0]
axis = [1, 0, 0]
weight = 0.5

[[goal]]
type = "com_over_support"
point = [0.5, 0, 0]
mu = 2.0

[[goal]]
type = "com"
target = [1.0, 0.5, 0.0]

[[goal]]
type = "com_in_polygon"
frames = ["link0", "link1", "tip"]

[[goal]]
type = "obstacle"
centre = [1, 1, 1]
radius = 0.3
bone_radius = 0.05

[[goal]]
type = "comfort"
mode = "max"
joint_weights = { link0 = 1.0, link3 = 0.5 }
level = 2
"""


def test_toml_problem_matches_the_python_api(tmp_path):
    loaded = load_problem(write(tmp_path, TOML))
    problem, settings = loaded.problem, loaded.settings
    skeleton = deik.chain(4, dims=3)
    expected = deik.Problem(
        skeleton,
        [
            deik.Position("tip", (2, 1, 0.5), tolerance=0.01),
            deik.Orientation("link3", euler_matrix("XYZ", np.radians([0, 30, 45])), level=1),
            deik.Aim("link2", (0, 3, 0), axis=(1, 0, 0), weight=0.5),
            deik.ComOverSupport((0.5, 0, 0), mu=2.0),
            deik.CentreOfMass((1, 0.5, 0)),
            deik.ComInPolygon(("link0", "link1", "tip")),
            deik.Obstacle((1, 1, 1), 0.3, bone_radius=0.05),
            deik.Comfort(mode="max", joint_weights={"link0": 1.0, "link3": 0.5}, level=2),
        ],
        limits="clip",
    )
    assert settings == {"population": 24, "generations": 30, "seed": 2}
    assert problem.limits == "clip" and problem.skeleton.n_dofs == skeleton.n_dofs
    got, want = problem.table, expected.table
    assert got.labels == want.labels and got.n_levels == want.n_levels
    for name in ("term_int", "term_float", "params", "dof_weight"):
        np.testing.assert_allclose(getattr(got, name), getattr(want, name), err_msg=name)


def test_cli_solves_a_toml_problem_with_setting_overrides(tmp_path, capsys):
    out = tmp_path / "pose.json"
    path = write(
        tmp_path,
        'skeleton = "chain:3"\n[settings]\npopulation = 24\n'
        '[[goal]]\ntype = "position"\nframe = "tip"\ntarget = [1.5, 1.5, 0]\n',
    )
    assert main(["solve", "--problem", str(path), "--generations", "25", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["skeleton"] == "chain:3"


def test_cli_prints_each_goals_unit_from_its_kind(tmp_path, capsys, monkeypatch):
    path = write(
        tmp_path,
        'skeleton = "chain:3"\nlimits = "penalty"\n[settings]\npopulation = 24\n'
        '[[goal]]\ntype = "position"\nframe = "tip"\ntarget = [1.5, 1.5, 0]\ntolerance = 0.01\n'
        '[[goal]]\ntype = "aim"\nframe = "tip"\ntarget = [3, 0, 0]\n',
    )
    out = tmp_path / "pose.json"
    drawn = []
    monkeypatch.setattr(plot, "plot_result", lambda *args: drawn.append(args[-1]))  # the picture's length unit
    argv = ["solve", "--problem", str(path), "--generations", "25", "--out", str(out), "--plot", "p.png"]
    assert main(argv) == 0
    rows = {line.split("  ")[0]: line for line in capsys.readouterr().out.splitlines()}
    # a chain's lengths are link lengths in the table, the pose file and the picture alike; a
    # rotation-only chain's joint-limit violation is an angle; the CLI shows angles in degrees
    # while the JSON keeps the Python API's radians
    assert re.fullmatch(r"position tip +\S+ link lengths +0\.01 link lengths +(yes|NO)", rows["position tip"])
    assert rows["aim tip"].split()[3] == "deg" and rows["joint limits"].split()[3] == "deg"
    data = json.loads(out.read_text())
    assert data["length_unit"] == "link lengths" and drawn == ["link lengths"]
    goals = data["goals"]
    assert [(g["kind"], g["unit"]) for g in goals] == [("position", "m"), ("aim", "rad"), ("joint_limits", "rad")]
    shown = float(rows["aim tip"].split()[2])
    assert abs(shown - np.degrees(goals[1]["error"])) <= 1e-5 * max(1.0, abs(shown))


GOAL = '[[goal]]\ntype = "position"\nframe = "tip"\ntarget = [1, 1, 0]\n'


@pytest.mark.parametrize(
    "text, fragments",
    [
        ('skeleton = "chain:3"\n[[goal]]\ntype = "positon"\n', ["goal 1", "unknown type 'positon'", "'position'"]),
        ('skeleton = "chain:3"\n[[goal]]\nframe = "tip"\n', ["goal 1", "missing field 'type'"]),
        (
            'skeleton = "chain:3"\n[[goal]]\ntype = "position"\nframe = "tip"\n',
            ["goal 1 (position)", "missing field 'target'"],
        ),
        (
            'skeleton = "chain:3"\n' + GOAL + '[[goal]]\ntype = "comfort"\njoint_wieghts = "start"\n',
            ["goal 2 (comfort)", "unknown field 'joint_wieghts'", "did you mean 'joint_weights'"],
        ),
        (
            'skeleton = "chain:3"\n[[goal]]\ntype = "position"\nframe = "tip"\ntarget = [1, 1]\n',
            ["goal 1 (position)", "field 'target' must be [x, y, z]"],
        ),
        (
            'skeleton = "chain:3"\n[[goal]]\ntype = "position"\nframe = "tip"\ntarget = [nan, 1, 0]\n',
            ["field 'target'", "NaN"],
        ),
        (
            'skeleton = "chain:3"\n[[goal]]\ntype = "position"\nframe = "tipp"\ntarget = [1, 1, 0]\n',
            ["goal 1 (position)", "field 'frame'", "did you mean 'tip'"],
        ),
        (
            'skeleton = "chain:3"\n[[goal]]\ntype = "position"\nframe = "tip"\ntarget = [9, 1, 0]\n',
            ["goal 1 (position)", "unreachable"],
        ),
        (
            'skeleton = "chain:3"\n[[goal]]\ntype = "position"\nframe = "tip"\ntarget = [1, 1, 0]\nlevel = 0.5\n',
            ["field 'level' must be an integer"],
        ),
        (
            'skeleton = "chain3d:3"\n[[goal]]\ntype = "orientation"\nframe = "tip"\n'
            'euler = "XYW"\ndegrees = [0, 0, 0]\n',
            ["goal 1 (orientation)", "field 'euler'"],
        ),
        (
            'skeleton = "chain3d:3"\n[[goal]]\ntype = "orientation"\nframe = "tip"\n'
            'euler = "XY"\ndegrees = [0, 0, 0]\n',
            ["field 'degrees' must be a list of 2 numbers"],
        ),
        (
            'skeleton = "chain3d:3"\n[[goal]]\ntype = "orientation"\nframe = "tip"\n'
            "target = [[2, 0, 0], [0, 1, 0], [0, 0, 1]]\n",
            ["goal 1 (orientation)", "not a rotation matrix"],
        ),
        ('skeleton = "chain3d:3"\n[[goal]]\ntype = "orientation"\nframe = "tip"\n', ["exactly one orientation"]),
        (
            'skeleton = "chain3d:3"\n[[goal]]\ntype = "orientation"\nframe = "tip"\n'
            "quaternion_wxyz = [1, 0, 0, 0]\nrpy_degrees = [0, 0, 0]\n",
            ["exactly one orientation", "both 'quaternion_wxyz' and 'rpy_degrees'"],
        ),
        (
            'skeleton = "chain3d:3"\n[[goal]]\ntype = "orientation"\nframe = "tip"\nquaternion_xyzw = [0, 0, 0, 2]\n',
            ["goal 1 (orientation)", "length 2", "unit quaternion"],
        ),
        (
            'skeleton = "chain3d:3"\n[[goal]]\ntype = "orientation"\nframe = "tip"\nrpy_degrees = [0, 0, 0]\n'
            "degrees = [1, 2, 3]\n",
            ["'degrees' goes with 'euler'"],
        ),
        ('skeleton = "chian:3"\n' + GOAL, ["field 'skeleton'", "chain:N"]),
        ('skelton = "chain:3"\n' + GOAL, ["unknown top-level key 'skelton'", "did you mean 'skeleton'"]),
        ('skeleton = "chain:3"\nlimits = "bounce"\n' + GOAL, ["field 'limits'", "reflect"]),
        ('skeleton = "chain:3"\n[settings]\npopulaton = 50\n' + GOAL, ["[settings]", "did you mean 'population'"]),
        ('skeleton = "chain:3"\n[settings]\npopulation = 2\n' + GOAL, ["[settings]", "population must be"]),
        (
            'skeleton = "chain:3"\n[[goal]]\ntype = "comfort"\njoint_weights = { link1 = -1 }\n',
            ["goal 1 (comfort)", "weight of 'link1' must be a finite number >= 0"],
        ),
        (
            'skeleton = "chain:3"\n[[goal]]\ntype = "comfort"\njoint_weights = [1, 1]\n',
            ["field 'joint_weights' must be a list of 3 numbers"],
        ),
        ('skeleton = "chain:3"\n', ["no goals", "[[goal]]"]),
        ('skeleton = "chain:3"\n[goal]\ntype = "com"\ntarget = [0, 1, 0]\n', ["double brackets"]),
        ('skeleton = "chain:3"\n[[goal]\n', ["not valid TOML"]),
    ],
)
def test_bad_toml_names_file_goal_and_field(tmp_path, text, fragments):
    path = write(tmp_path, text)
    with pytest.raises(ValueError) as caught:
        load_problem(path)
    message = str(caught.value)
    assert message.startswith(str(path))
    for fragment in fragments:
        assert fragment in message


def test_skeleton_specs():
    assert skeleton_from_spec("chain:7").n_joints == 7
    assert skeleton_from_spec("chain3d:2").n_dofs == 4
    assert skeleton_from_spec("humanoid").name == "humanoid"
    for bad in ("chain", "chain:0", "chain:x", "humanoid:3", "robot"):
        with pytest.raises(ValueError, match="chain:N"):
            skeleton_from_spec(bad)


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["solve", "chain:3", "--reach", "tipp", "1", "1", "0"], "did you mean 'tip'"),
        (["solve", "chian:3", "--reach", "tip", "1", "1", "0"], "unknown skeleton 'chian:3'"),
        (["solve", "chain:3", "--reach", "tip", "9", "1", "0"], "unreachable"),
        (["solve", "chain:3", "--reach", "tip", "nan", "1", "0"], "--reach: 'nan' is out of range"),
        (["solve", "chain:3", "--reach", "tip", "1", "9" * 5000, "0"], "--reach: '9999"),
        (["solve", "chain:3", "--population", "9" * 5000], "argument --population: invalid int value"),
        (["solve", "chain:3", "--reach", "tip", "1", "one", "0"], "'one' is not a number"),
        (["solve", "chain:3", "--reach", "tip", "1", "1"], "expected 4 arguments"),
        (["solve", "chain:3", "--reach", "tip", "1", "1", "0", "--population", "2"], "population must be"),
        (["solve", "chain:3", "--reach", "tip", "1", "1", "0", "--strategy", "fast"], "invalid choice"),
        (["solve", "chain:3"], "no goals"),
        (["solve"], "give a SKELETON"),
        (
            ["solve", "chain:3", "--comfort", "3"],
            "argument --comfort: '3' is out of range: give a finite number from -1 to 1",
        ),
        (["solve", "--problem", "missing.toml"], "missing.toml: no such problem (TOML) file"),
        (["solve", "--problem", "p.toml", "--reach", "tip", "1", "1", "0"], "--problem FILE already names"),
    ],
)
def test_bad_cli_input_exits_2_with_one_line_and_no_file(tmp_path, capsys, monkeypatch, argv, fragment):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "pose.json"
    assert main(argv + ["--out", str(out), "--plot", str(tmp_path / "pose.png")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and err.count("\n") == 1 and fragment in err
    assert list(tmp_path.iterdir()) == []


def test_help_returns_0(capsys):
    assert main(["solve", "--help"]) == 0
    assert "--reach FRAME X Y Z" in capsys.readouterr().out


def test_output_folder_must_exist(tmp_path, capsys):
    argv = ["solve", "chain:3", "--reach", "tip", "1", "1", "0", "--out", str(tmp_path / "no" / "p.json")]
    assert main(argv) == 2
    assert "does not exist" in capsys.readouterr().err


def test_run_demo_on_tiny_chains_writes_pictures_and_summary(tmp_path, capsys):
    rows = run_demo(tmp_path, chain_scenarios(n_links=3, seed=1))
    assert {row["scenario"] for row in rows} == {"a_chain_reach", "b_chain_straight_start", "c_chain_straight_end"}
    assert all(row["passed"] for row in rows)
    tip = [row for row in rows if row["goal"] == "position tip"]
    assert all(row["met"] and row["percent_of_reach"] <= 1.0 for row in tip)
    for key in ("a_chain_reach", "b_chain_straight_start", "c_chain_straight_end"):
        assert (tmp_path / f"{key}.png").read_bytes()[:8] == PNG_MAGIC
    summary = json.loads((tmp_path / "demo.json").read_text())
    assert [s["passed"] for s in summary["scenarios"]] == [True, True, True]
    assert "every scenario met its targets" in capsys.readouterr().out


def test_run_demo_reports_a_missed_bound(tmp_path, capsys):
    plain = chain_scenarios(n_links=3)[0]
    tip = plain.problem.goals[0]
    impossible = deik.Problem(plain.problem.skeleton, [dataclasses.replace(tip, tolerance=1e-12)])
    scenario = dataclasses.replace(plain, problem=impossible, settings={**plain.settings, "generations": 3})
    rows = run_demo(tmp_path, [scenario])
    assert rows[0]["met"] is False and rows[0]["passed"] is False
    assert "MISSED: a_chain_reach" in capsys.readouterr().out


def test_ctrl_c_during_the_demo_writes_nothing_as_it_says(tmp_path, capsys, monkeypatch):
    from deik.experiments import demo

    scenarios, solved = chain_scenarios(n_links=3, seed=1), []

    def interrupted(problem, **settings):
        if solved:  # the first scenario is solved and drawn, the second interrupted
            raise KeyboardInterrupt
        solved.append(deik.solve(problem, **settings))
        return solved[-1]

    monkeypatch.setattr(demo, "solve", interrupted)
    monkeypatch.setattr(demo, "chain_scenarios", lambda: scenarios)
    monkeypatch.setattr(demo, "humanoid_scenario", lambda: scenarios[0])
    assert main(["demo", "--out", str(tmp_path / "demo"), "--quiet"]) == 130
    assert "deik: interrupted; nothing was written" in capsys.readouterr().err
    assert solved and list((tmp_path / "demo").iterdir()) == []


def test_experiments_subcommand_reaches_the_runner(tmp_path, capsys):
    assert main(["experiments", "fig99", "--quick", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: unknown experiment 'fig99'") and err.count("\n") == 1
    assert main(["experiments", "fig7", "--quick", "--out", str(tmp_path / "y")]) == 0
    assert (tmp_path / "y" / "fig7.csv").stat().st_size > 0


def test_version_is_printed_and_matches_the_package(capsys):
    from importlib.metadata import version

    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"deik {deik.__version__}" == f"deik {version('deik')}"


def test_demo_prints_its_table_without_matplotlib(tmp_path):
    code = (
        "import sys; sys.modules['matplotlib'] = None\n"  # as if deik[viz] were not installed
        "from deik.experiments.demo import chain_scenarios, run_demo\n"
        f"run_demo({str(tmp_path)!r}, chain_scenarios(n_links=3, seed=1))\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert "every scenario met its targets" in run.stdout and "no pictures" in run.stdout
    assert "position tip" in run.stdout and not list(tmp_path.glob("*.png"))
    assert (tmp_path / "demo.json").exists()


def test_negative_numbers_in_any_notation_are_values_not_options(tmp_path):
    out = tmp_path / "pose.json"
    argv = ["solve", "chain3d:3", "--reach", "tip", "1.5", "-1e-3", "-.5", "--generations", "3", "--quiet"]
    assert main(argv + ["--out", str(out)]) == 0
    targets = json.loads(out.read_text())["targets"]
    assert targets[0]["position"] == [1.5, -0.001, -0.5]

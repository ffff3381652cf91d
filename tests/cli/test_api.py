"""Every command has a Python function at the top level of deik, and the two give the same answer:
deik.clean_clip and `deik clip` (one clip and a folder), problem_from_flags and load_problem with
deik.solve and `deik solve`, describe_skeleton and `deik info`, range_of_motion and `deik
limits`, view_scene and `deik view`'s scene, demo and run_experiments printing nothing. A clip's
forward kinematics is computed once per clean."""

import json
import textwrap

import numpy as np
import pytest

import deik
from deik.cleanup.ground import resting_body
from deik.cli.app import build_parser, main
from deik.cli.info_command import format_info
from deik.experiments.demo import chain_scenarios
from deik.io.atomic import write_json_atomically
from deik.viz.marks import length_unit
from helpers import shared_path

TIMINGS = ("wall_time_s", "stages")  # the only parts of a clip report that differ between two runs


def _without_timings(document: dict) -> dict:
    return {key: value for key, value in document.items() if key not in TIMINGS}


@pytest.mark.shared_data
def test_clean_clip_gives_what_deik_clip_writes(tmp_path, capsys):
    walk = shared_path("humanoid", "humanoid3d_walk.bvh")
    out, report = tmp_path / "cli.bvh", tmp_path / "cli.json"
    argv = ["clip", str(walk), "--plant-feet", "auto", "--balance", "--seed", "0", "--out", str(out)]
    assert main(argv + ["--json", str(report), "--quiet"]) == 0
    printed = capsys.readouterr().out
    cleaned = deik.clean_clip(walk, deik.CleanOptions(plant_feet="auto", balance=True, seed=0))
    deik.write_bvh(tmp_path / "api.bvh", cleaned.clip)
    assert (tmp_path / "api.bvh").read_bytes() == out.read_bytes()
    written = json.loads(report.read_text())
    write_json_atomically(tmp_path / "api.json", cleaned.report, missing_as_null=True)  # as --json writes it
    assert _without_timings(written) == _without_timings(json.loads((tmp_path / "api.json").read_text()))
    # what it could not do, as the command says it
    skipped = written["balance"]["skipped_frames"]
    assert cleaned.skipped_balance_frames == skipped and f"skipped in {len(skipped)} frames" in printed
    assert cleaned.unmet_frames == [n for n, met in enumerate(written["met_per_frame"]) if not met]
    assert f"{39 - len(cleaned.unmet_frames)}/39 frames meet" in printed
    assert cleaned.far_joints == written["joints_far_from_capture"]["joint_frames"]
    assert cleaned.contacts.sites == resting_body(cleaned.original)[2].sites  # every resting point, as deik clip


@pytest.mark.shared_data
def test_an_unreachable_reach_is_reported_by_the_api_as_by_the_command(tmp_path, capsys):
    walk = shared_path("humanoid", "humanoid3d_walk.bvh")
    reach = "RightElbow_end=3,1,0@10:12"  # 3 m ahead of a body whose feet stay planted
    cleaned = deik.clean_clip(walk, deik.CleanOptions(reach=reach, seed=0))
    missed = cleaned.unreachable["reach_RightElbow_end"]
    short = dict(zip(missed["frames"], missed["distance_mm"]))
    assert all(short[n] > 1000 for n in (10, 11, 12))  # metres short where the track holds
    assert main(["clip", str(walk), "--reach", reach, "--seed", "0", "--out", str(tmp_path / "o.bvh")]) == 0
    frames = cleaned.unreachable["reach_RightElbow_end"]["frames"]
    assert f"reach_RightElbow_end: out of reach in {len(frames)} frames" in capsys.readouterr().out


@pytest.mark.shared_data
def test_a_folder_run_calls_the_api_and_writes_what_it_gives(tmp_path, capsys):
    clips = tmp_path / "clips"
    clips.mkdir()
    (clips / "walk.bvh").write_bytes(shared_path("humanoid", "humanoid3d_walk.bvh").read_bytes())
    argv = ["clip", str(clips), "--out", str(tmp_path / "fixed"), "--contact", "auto", "--seed", "0"]
    args = build_parser().parse_args(argv)
    from deik.cli.folder_command import library_jobs

    (job,), _ = library_jobs(args)
    options = job.payload["options"]
    assert isinstance(options, deik.CleanOptions) and options.contact == ("auto",) and options.seed == 0
    assert main(argv + ["--workers", "1", "--quiet"]) == 0
    capsys.readouterr()
    cleaned = deik.clean_clip(clips / "walk.bvh", options)
    deik.write_bvh(tmp_path / "api.bvh", cleaned.clip)
    assert (tmp_path / "api.bvh").read_bytes() == (tmp_path / "fixed" / "walk.bvh").read_bytes()
    sidecar = json.loads((tmp_path / "fixed" / ".walk.bvh.deik.json").read_text())
    assert sidecar["record"]["frames_met"] == 39 - len(cleaned.unmet_frames)
    assert "printed" not in sidecar["record"]  # no command rerun with its output captured


def _stepping_clip(frames: int = 24) -> deik.Clip:
    """A built-in humanoid walking in place, its right foot sliding forward while low."""
    human = deik.humanoid()
    poses = np.repeat(human.reference[None], frames, axis=0)
    hip = human.dof_names.index(next(n for n in human.dof_names if "right_hip" in n))
    poses[:, hip] = 0.3 * np.sin(np.linspace(0, 2 * np.pi, frames))
    return deik.Clip.from_poses(human, poses, frame_time=1 / 30)


def test_a_clean_computes_the_clip_s_forward_kinematics_once(monkeypatch):
    import deik.io.motion as motion

    clip = _stepping_clip()
    calls = []
    real = motion.forward_kinematics

    def counting(skeleton, angles):  # the body's own (its sole sites added) is another skeleton
        calls.append(skeleton is clip.skeleton and np.array_equal(np.asarray(angles), clip.frames))
        return real(skeleton, angles)

    monkeypatch.setattr(motion, "forward_kinematics", counting)
    options = deik.CleanOptions(plant_feet="right_heel:0-11", seed=0, passes=0)
    cleaned = deik.clean_clip(clip, options)
    assert calls.count(True) <= 1  # the original's, at most once, however many measures read it
    assert cleaned.clip.kinematics is cleaned.clip.kinematics  # kept on the clip
    with pytest.raises(ValueError):  # shared, so read-only
        cleaned.original.kinematics.p_world_frame[0, 0, 0] = 1.0


@pytest.mark.parametrize(
    "options, message",
    [
        ({"plant_feet": "right_heal:0-3"}, "--plant-feet 'right_heal:0-3': no joint or site 'right_heal'"),
        ({"plant_feet": "right_heel:3-99"}, "frames 3-99 are outside the clip or reversed; valid frames: 0..23"),
        ({"contact": ["auto", "none"]}, "--contact none cannot be combined"),
        ({"floor": "low"}, "--floor 'low': use a height"),
        ({"reach": "left_hand=0,1,0@30:40"}, "frames 30:40 are outside the clip"),
        ({"units": "furlong"}, "--units 'furlong'"),
        ({"plant_feet": 3}, "plant_feet takes a spec"),
        ({"contact_speed": 0.0}, "--contact-speed 0.0: give a finite number above 0"),  # nothing would rest
    ],
)
def test_options_that_do_not_fit_the_clip_raise_input_error(options, message):
    with pytest.raises(deik.InputError) as caught:
        deik.clean_clip(_stepping_clip(), deik.CleanOptions(**options))
    assert message in str(caught.value)


def test_problem_from_flags_solves_as_deik_solve_does(tmp_path, capsys):
    flags = ["chain:5", "--reach", "tip", "3", "2", "0", "--comfort", "0.2", "--seed", "4", "--population", "24"]
    flags += ["--generations", "40", "--polish", "0"]
    assert main(["solve", *flags, "--out", str(tmp_path / "pose.json"), "--quiet"]) == 0
    capsys.readouterr()
    spec = deik.problem_from_flags(flags)
    assert spec.settings == {"seed": 4, "population": 24, "generations": 40, "polish": 0} and spec.start is None
    result = deik.solve(spec.problem, **spec.settings)
    written = json.loads((tmp_path / "pose.json").read_text())
    np.testing.assert_array_equal(np.asarray(written["angles"]), result.angles)
    with pytest.raises(deik.UsageError, match="no goals"):
        deik.problem_from_flags(["chain:5"])


@pytest.mark.shared_data
def test_a_bvh_frame_and_a_toml_file_pose_the_same_problem_as_the_flags(tmp_path):
    walk = shared_path("humanoid", "humanoid3d_walk.bvh")
    flags = deik.problem_from_flags(["--skeleton", walk, "--frame", "12", "--reach", "LeftElbow_end", "0.4", "1", "0"])
    (tmp_path / "p.toml").write_text(
        textwrap.dedent(
            f"""
            skeleton = "{walk}"
            frame = 12
            [[goal]]
            type = "position"
            frame = "LeftElbow_end"
            target = [0.4, 1, 0]
            [[goal]]
            type = "comfort"
            level = 1
            """
        )
    )
    file = deik.load_problem(tmp_path / "p.toml")
    assert isinstance(flags, deik.ProblemFile) and isinstance(file, deik.ProblemFile)
    np.testing.assert_array_equal(flags.start, file.start)  # both start around frame 12
    np.testing.assert_array_equal(flags.start, deik.read_bvh(walk).pose(12))
    assert [type(goal) for goal in flags.problem.goals] == [type(goal) for goal in file.problem.goals]
    np.testing.assert_array_equal(flags.problem.goals[1].reference, file.problem.goals[1].reference)


@pytest.mark.parametrize("name", ["chain:3", "humanoid"])
def test_describe_skeleton_is_the_data_deik_info_prints(name, capsys):
    assert main(["info", name]) == 0
    info = deik.describe_skeleton(name)
    skeleton = deik.humanoid() if name == "humanoid" else deik.chain(3)
    assert capsys.readouterr().out == format_info(info, name, length_unit(skeleton, info["kind"])) + "\n"
    assert [dof["name"] for dof in info["dofs"]] == list(skeleton.dof_names)
    np.testing.assert_array_equal([dof["lower"] for dof in info["dofs"]], skeleton.lower)
    assert info["dof_count"] == skeleton.n_dofs and info["mass_kg"] == pytest.approx(skeleton.total_mass)
    assert json.loads(json.dumps(info)) == info  # plain data


@pytest.mark.shared_data
def test_range_of_motion_is_what_deik_limits_writes(tmp_path, capsys):
    walk = shared_path("humanoid", "humanoid3d_walk.bvh")
    assert main(["limits", str(walk), "--margin", "5", "--out", str(tmp_path / "cli.json")]) == 0
    clip = deik.read_bvh(walk)
    deik.write_limits(tmp_path / "api.json", clip.skeleton, deik.range_of_motion(clip, 5.0))
    assert (tmp_path / "api.json").read_text() == (tmp_path / "cli.json").read_text()


def test_view_scene_is_the_scene_deik_view_serves():
    from deik.cli.view_command import build_scene

    options = deik.ViewOptions(units="cm")
    scene = deik.view_scene("chain:3", options)
    served = build_scene(build_parser().parse_args(["view", "chain:3", "--units", "cm"]))
    shown = (scene.title, scene.unit, scene.n_steps)
    assert shown == (served.title, served.unit, served.n_steps) == ("chain:3", "cm", 1)
    with pytest.raises(deik.InputError, match="--compare 'x.txt': give a .bvh clip or a pose .json"):
        deik.view_scene("chain:3", deik.ViewOptions(compare="x.txt"))


def test_demo_and_experiments_return_their_results_and_print_nothing(tmp_path, capsys):
    document = deik.demo(tmp_path / "demo", chain_scenarios(n_links=3, seed=1))
    assert [s["passed"] for s in document["scenarios"]] == [True, True, True]
    assert json.loads((tmp_path / "demo" / "demo.json").read_text())["rows"] == json.loads(json.dumps(document["rows"]))
    (section,) = deik.run_experiments(["fig7"], tmp_path / "fig", quick=True)
    assert section.name == "fig7" and (tmp_path / "fig" / "fig7.csv").stat().st_size > 0
    assert capsys.readouterr() == ("", "")

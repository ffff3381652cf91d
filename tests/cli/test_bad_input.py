"""Bad input a user can give: each case gets a clear error naming the problem and the fix,
never a traceback, a silent guess or nonsense output."""

import dataclasses
import os
import re

import numpy as np
import pytest

import deik
from deik.cli import main
from deik.errors import InputError
from deik.io.urdf import read_urdf
from helpers import MESH_ROBOT, robot_arm
from judging.rigs import format_rig
from judging.walk import procedural_walk


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"adaptive": "no"}, "adaptive must be true or false, got 'no'"),
        ({"adaptive": 1}, "adaptive must be true or false"),
        ({"F": True}, "F must be a finite number"),
        ({"F": "0.5"}, r"F must be a finite number \(the differential weight"),
        ({"CR": None}, "CR must be a finite number"),
        ({"seed": True}, "seed must be an integer >= 0, got True"),
        ({"polish": True}, "polish must be an integer >= 0"),
        ({"population": 4.0}, "population must be an integer >= 4"),
        ({"strategy": 3}, "strategy must be one of"),
        ({"stop_on_converged": "yes"}, "stop_on_converged must be true or false"),
        ({"time_limit": float("inf")}, "time_limit must be a finite number"),
        ({"dtype": np.float64}, "dtype must be one of"),
    ],
)
def test_every_setting_is_type_checked_by_name(changes, message):
    with pytest.raises(ValueError, match=message):
        deik.Settings(**changes)


def test_settings_accept_numpy_scalars_of_the_right_kind():
    settings = deik.Settings(
        seed=np.uint64(2**64 - 1), population=np.int64(8), F=np.float32(0.5), adaptive=np.bool_(False)
    )
    assert settings.seed == 2**64 - 1 and settings.population == 8


def _write(tmp_path, text):
    path = tmp_path / "robot.urdf"
    path.write_text(text)
    return path


def test_urdf_joint_without_origin_sits_at_its_parent(tmp_path):
    # URDF makes <origin> optional: absent, the joint frame is the parent link's frame
    with_origin = _write(
        tmp_path,
        """<?xml version="1.0"?><robot name="r"><link name="a"/><link name="b"/><link name="c"/>
        <joint name="j" type="revolute"><parent link="a"/><child link="b"/>{origin}<axis xyz="0 0 1"/>
        <limit lower="-1" upper="1"/></joint>
        <joint name="k" type="fixed"><parent link="b"/><child link="c"/><origin xyz="1 0 0"/></joint></robot>""",
    )
    text = with_origin.read_text()
    explicit = read_urdf(_write(tmp_path, text.replace("{origin}", '<origin xyz="0 0 0" rpy="0 0 0"/>')))
    implicit = read_urdf(_write(tmp_path, text.replace("{origin}", "")))
    q = np.array([0.7])
    np.testing.assert_array_equal(
        deik.forward_kinematics(implicit, q).position("c"), deik.forward_kinematics(explicit, q).position("c")
    )
    np.testing.assert_allclose(deik.forward_kinematics(implicit, q).position("c"), [np.cos(0.7), np.sin(0.7), 0])


def test_skeleton_without_free_dofs_is_refused_before_solving(tmp_path):
    path = _write(
        tmp_path,
        """<?xml version="1.0"?><robot name="r"><link name="a"><inertial><mass value="1"/>
        </inertial></link><link name="b"/><joint name="j" type="fixed"><parent link="a"/><child link="b"/>
        <origin xyz="0 0 1"/></joint></robot>""",
    )
    skeleton = read_urdf(path)
    with pytest.raises(ValueError, match="has no free DOF to solve for .* choose a base and tip with moving joints"):
        deik.Problem(skeleton, [deik.Position("b", [0, 0, 1])])


def test_duplicate_names_are_found_in_one_pass():
    joints = [deik.Joint("root", None)] + [
        deik.Joint(f"j{k}", "root" if k == 0 else f"j{k - 1}", (0, 0, 0.1), deik.hinge((0, 0, 1))) for k in range(3000)
    ]
    sites = [deik.Site("j5", "j7"), deik.Site("j9", "j9")]
    with pytest.raises(ValueError, match=r"duplicate joint/site names \['j5', 'j9'\]"):
        deik.build_skeleton(joints, sites=sites)


def test_deeply_nested_toml_is_refused_with_the_file_named(tmp_path):
    from deik.solver.problem_file import load_problem

    path = tmp_path / "deep.toml"
    path.write_text('skeleton = "chain:3"\nx = ' + "[" * 50000 + "]" * 50000 + "\n")
    with pytest.raises(ValueError, match=r"deep\.toml: arrays or tables nested too deeply"):
        load_problem(path)


def test_range_of_motion_of_a_clip_without_frames_is_refused(tmp_path):
    from deik.io.bvh import read_bvh
    from deik.io.limits import range_of_motion

    path = tmp_path / "empty.bvh"
    path.write_text(
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
        "  End Site\n  {\n    OFFSET 0 1 0\n  }\n}\nMOTION\nFrames: 0\nFrame Time: 0.033333\n"
    )
    with pytest.raises(ValueError, match=f"{path}: the clip has no frames"):
        range_of_motion(read_bvh(path), 10.0)


def test_every_command_on_a_clip_without_frames_names_the_file(tmp_path, capsys):
    path = tmp_path / "empty.bvh"
    path.write_text(TOY_BVH.split("MOTION")[0] + "MOTION\nFrames: 0\nFrame Time: 0.033333\n")
    out = tmp_path / "out.bvh"
    for argv in (
        ["clip", path, "--out", out],
        ["retarget", path, "--scale", "Arm=2", "--out", out],
        ["limits", path, "--out", tmp_path / "limits.json"],
    ):
        status, err = _cli(argv, capsys)
        assert status == 2 and err.count("\n") == 1, err
        assert err.startswith(f"deik: error: {path}: the clip has no frames"), err
        assert not out.exists()


TOY_BVH = (
    "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
    "  JOINT Arm\n  {\n    OFFSET 0 1 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
    "    End Site\n    {\n      OFFSET 0 1 0\n    }\n  }\n}\nMOTION\nFrames: 2\nFrame Time: 0.033333\n"
    "0 0 0 0 0 0\n0 0 0 10 0 0\n"
)


def _cli(argv, capsys):
    from deik.cli import main

    status = main([str(a) for a in argv])
    return status, capsys.readouterr().err


def test_a_clip_whose_bones_all_have_zero_length_is_refused_by_clip_and_retarget(tmp_path, capsys):
    path = tmp_path / "point.bvh"
    path.write_text(TOY_BVH.replace("OFFSET 0 1 0", "OFFSET 0 0 0"))
    out = tmp_path / "out.bvh"
    for argv in (["clip", path, "--out", out], ["retarget", path, "--scale", "Arm=2", "--out", out]):
        status, err = _cli(argv, capsys)
        assert (
            status == 2 and err.strip() == f"deik: error: {path}: every bone has zero length: there is no body to clean"
        )
        assert not out.exists()


def test_info_prints_a_clip_whose_bones_all_have_zero_length(tmp_path, capsys):
    """deik info reads the file as it is: no body to look for cuts in is no error."""
    from deik.cli import main

    path = tmp_path / "point.bvh"
    path.write_text(TOY_BVH.replace("OFFSET 0 1 0", "OFFSET 0 0 0"))
    assert main(["info", str(path)]) == 0
    assert "clip: 2 frames" in capsys.readouterr().out


def test_output_that_is_the_input_is_refused_before_solving(tmp_path, capsys):
    clip = tmp_path / "walk.bvh"
    clip.write_text(TOY_BVH)
    status, err = _cli(
        ["solve", "--skeleton", clip, "--frame", "0", "--reach", "Arm_end", 0, 1.5, 0.5, "--out", clip], capsys
    )
    assert status == 2 and "--out" in err and "is the input file" in err and "--overwrite" in err
    assert err.count("\n") == 1 and clip.read_text() == TOY_BVH
    status, err = _cli(["clip", clip, "--out", clip], capsys)
    assert status == 2 and "is the input file" in err and clip.read_text() == TOY_BVH


def test_two_outputs_naming_one_file_are_refused(tmp_path, capsys):
    # the PNG of --plot can no longer land in the JSON's name: --plot takes .png only
    status, err = _cli(
        ["solve", "chain:3", "--reach", "tip", 1, 1, 0, "--out", tmp_path / "x.json", "--plot", tmp_path / "x.json"],
        capsys,
    )
    assert status == 2 and "--plot" in err and "must end in .png" in err
    assert not list(tmp_path.iterdir())
    from deik.cli.arguments import UsageError, check_outputs

    with pytest.raises(UsageError, match="--a and --b both name"):
        check_outputs({"--a": str(tmp_path / "x.json"), "--b": str(tmp_path / "x.json")}, {})


def test_unwritable_output_folder_is_refused_before_solving(tmp_path, capsys, monkeypatch):
    import deik.cli.arguments

    # as root every folder is writable, so the check's system call is made to answer "no"
    monkeypatch.setattr(deik.cli.arguments.os, "access", lambda path, mode: False)
    status, err = _cli(["solve", "chain:3", "--reach", "tip", 1, 1, 0, "--out", tmp_path / "x.json"], capsys)
    assert status == 2 and "is not writable; choose another folder" in err


def test_all_or_nothing_leaves_no_file_when_a_later_write_fails(tmp_path):
    from deik.io import atomic

    first, second = tmp_path / "a.json", tmp_path / "b.png"
    first.write_text("old\n")

    def broken(file):
        file.write(b"part")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        with atomic.all_or_nothing():
            atomic.write_json_atomically(first, {"new": 1})
            atomic.save_atomically(second, broken)
    assert first.read_text() == "old\n" and not second.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]
    with atomic.all_or_nothing():
        atomic.write_json_atomically(first, {"new": 1})
        assert first.read_text() == "old\n"  # moved into place only when the block ends
    assert json_load(first) == {"new": 1}


def json_load(path):
    import json

    return json.loads(path.read_text())


def test_a_temporary_file_stranded_by_a_killed_process_is_removed_by_the_next_write(tmp_path):
    from deik.io import atomic

    stranded = tmp_path / f"{atomic.PARTIAL}{atomic.HOST}-999999999-0123abcd.pose.json"
    stranded.write_text("{")
    atomic.write_json_atomically(tmp_path / "pose.json", {"ok": True})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pose.json"]


def test_nan_results_are_never_written_as_json(tmp_path):
    from deik.io import atomic

    with pytest.raises(ValueError, match=r"x\.json: the results hold NaN or infinite numbers, so no JSON was written"):
        atomic.write_json_atomically(tmp_path / "x.json", {"angles": [float("nan")]})
    assert not list(tmp_path.iterdir())


def test_ctrl_c_stops_a_long_solve_quickly_writes_nothing_and_exits_130(tmp_path):
    import re
    import signal
    import subprocess
    import sys
    import time

    problem = tmp_path / "long.toml"
    problem.write_text(
        'skeleton = "chain:30"\n[settings]\ngenerations = 10000000\npatience = 10000000\n'
        "population = 64\n"
        + "".join(  # two targets for one tip: never met, never stagnant
            f'[[goal]]\ntype = "position"\nframe = "tip"\ntarget = [{x}, 9.0, 0.0]\ntolerance = 0.0\n'
            for x in (12.0, -12.0)
        )
    )
    out = tmp_path / "pose.json"
    process = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from deik.cli import main; sys.exit(main())",
            "solve",
            "--problem",
            str(problem),
            "--out",
            str(out),
            "--progress",
        ],
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        shown = ""  # read until the bar has moved: compiled, and running generations
        while not re.search(r"\| *[1-9][0-9]*/10000000 ", shown):
            character = process.stderr.read(1)
            assert character, f"the solve ended before it ran: {shown}"
            shown += character
        sent = time.perf_counter()
        process.send_signal(signal.SIGINT)
        status = process.wait(timeout=30)
        stopped = time.perf_counter() - sent
    finally:
        process.kill()
    rest = process.stderr.read()
    assert status == 130, rest
    assert "deik: interrupted; nothing was written" in rest
    assert stopped < 10, f"took {stopped:.1f} s to stop"
    assert not list(tmp_path.glob("*.json")) and not list(tmp_path.glob(".*"))


def test_a_solve_beyond_memory_is_refused_before_allocating(tmp_path, capsys):
    problem = deik.Problem(deik.chain(10), [deik.Position("tip", [5.0, 5.0, 0.0])])
    refused = r"population 1000000000 needs about [0-9.]+ GiB, more than the .* \(Settings\(memory_limit"
    with pytest.raises(deik.SolveError, match=refused):
        deik.solve(problem, population=1_000_000_000)
    with pytest.raises(deik.SolveError, match=r"needs about .* more than the 0\.000977 GiB allowed"):
        deik.solve(problem, population=100_000, memory_limit=2**20)
    status, err = _cli(["solve", "chain:10", "--reach", "tip", 5, 5, 0, "--population", 1_000_000_000], capsys)
    assert status == 2 and "--memory-limit GIB" in err and err.count("\n") == 1
    clip = tmp_path / "walk.bvh"  # a clip frame seeds a quarter of the population around it: guarded too
    clip.write_text(TOY_BVH)
    argv = ["solve", "--skeleton", clip, "--frame", 0, "--reach", "Arm_end", 0, 1.5, 0.5, "--population", 10**9]
    status, err = _cli(argv + ["--quiet"], capsys)
    assert status == 2 and "250000000 poses around a pose needs about" in err and err.count("\n") == 1


def test_memory_estimate_covers_what_a_solve_allocates():
    from deik.solver.footprint import solve_bytes

    problem = deik.Problem(deik.chain(10), [deik.Position("tip", [5.0, 5.0, 0.0])])
    engine = deik.Engine(problem, deik.Settings(population=64, generations=50, polish=0))
    state = engine.run(engine.init(), 50)
    held = sum(a.nbytes for a in state.buffers) + state.history.nbytes
    estimate = solve_bytes(1, 64, 10, 1, 1, 4, 50)
    assert held <= estimate <= 8 * held


def test_absurd_chains_are_refused_with_the_limit(capsys):
    with pytest.raises(ValueError, match="n_links must be an integer from 1 to 100000, got 100000000"):
        deik.chain(100_000_000)
    status, err = _cli(["info", "chain:100000000"], capsys)
    assert status == 2 and "from 1 to 100000" in err


def test_absurd_limits_and_masses_are_refused_when_the_skeleton_is_built():
    def arm(lower=-1.0, upper=1.0, mass=1.0):
        return deik.build_skeleton(
            [deik.Joint("base", None, dofs=deik.hinge((0, 0, 1), lower, upper)), deik.Joint("tip", "base", (1, 0, 0))],
            segments=[deik.Segment("base", mass, (0.5, 0, 0))],
        )

    for lower, upper in ((-1e308, 1e308), (-1e38, 1e38), (0.0, 2e6)):
        with pytest.raises(ValueError, match=r"has limits .* beyond \+-1e\+06 .* give real limits"):
            arm(lower, upper)
    with pytest.raises(ValueError, match=r"mass 1e\+308 kg on joint 'base' must lie between 0 and 1e\+12 kg"):
        arm(mass=1e308)
    assert arm(-2 * np.pi, 2 * np.pi).upper[0] == 2 * np.pi


def test_piping_into_head_is_quiet():
    import subprocess
    import sys

    code = "import sys; from deik.cli import main; sys.exit(main())"
    run = subprocess.run(
        f"{sys.executable} -c '{code}' info chain:20000 | head -1",
        shell=True,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.stdout.startswith("chain:20000") and run.stderr == ""


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_full_disk_under_standard_output_is_one_line_with_the_fix():
    """`deik info X > /dev/full` said only "[Errno 28] No space left on device"."""
    import subprocess
    import sys

    code = "import sys; from deik.cli import main; sys.exit(main())"
    with open("/dev/full", "w") as full:
        run = subprocess.run(
            [sys.executable, "-c", code, "info", "chain:3"], stdout=full, stderr=subprocess.PIPE, text=True, timeout=300
        )
    assert run.returncode == 2
    assert run.stderr.strip().splitlines() == [
        "deik: error: writing the standard output: No space left on device; free some space or redirect it elsewhere"
    ]


def test_a_bug_is_reported_as_an_internal_error_not_a_usage_error(monkeypatch, capsys):
    import deik.cli.app as cli_main

    def broken(args):
        return [][1]  # an IndexError from deik's own code

    real = cli_main.build_parser

    def parser_with_broken_info(command=None):
        parser = real(command)
        parser.parse_args(["info", "chain:2"])  # the info subcommand exists
        parser._subparsers._group_actions[0].choices["info"].set_defaults(run=broken)
        return parser

    monkeypatch.setattr(cli_main, "build_parser", parser_with_broken_info)
    status, err = _cli(["info", "chain:2"], capsys)
    assert status == 3 and err.startswith("deik: internal error: IndexError") and "please report it" in err
    assert err.count("\n") == 1


def test_info_on_a_robot_without_free_dofs_describes_it_and_solve_refuses_it(tmp_path, capsys):
    path = _write(
        tmp_path,
        """<?xml version="1.0"?><robot name="r"><link name="a"><inertial><mass value="1"/>
        </inertial></link><link name="b"/><joint name="j" type="fixed"><parent link="a"/><child link="b"/>
        <origin xyz="0 0 1"/></joint></robot>""",
    )
    assert _cli(["info", path], capsys)[0] == 0
    status, err = _cli(["solve", "--skeleton", path, "--reach", "b", 0, 0, 1], capsys)
    assert status == 2 and "has no free DOF to solve for" in err and err.count("\n") == 1


def test_a_problem_file_that_is_not_utf8_is_named(tmp_path, capsys):
    path = tmp_path / "latin.toml"
    path.write_bytes('skeleton = "chain:3"\n# r\xe9sum\xe9\n'.encode("latin-1"))
    status, err = _cli(["solve", "--problem", path], capsys)
    assert status == 2 and "latin.toml:2: not a text (UTF-8) problem (TOML) file" in err


def test_an_error_about_a_huge_input_is_cut_to_one_short_line(tmp_path, capsys):
    path = tmp_path / "huge.toml"
    target = ", ".join(["1.0"] * 100_000)
    path.write_text(f'skeleton = "chain:3"\n[[goal]]\ntype = "position"\nframe = "tip"\ntarget = [{target}]\n')
    status, err = _cli(["solve", "--problem", path], capsys)
    assert status == 2 and err.count("\n") == 1 and len(err) <= 520
    assert "huge.toml" in err and "1.0, 1.0" in err  # the echoed value, cut short


def test_the_largest_chain_is_described_and_refused_for_a_solve_by_its_memory(capsys):
    """chain:100000 is the largest built-in chain: `deik info` lists its tree without indenting
    past MAX_INDENT levels (the text grew with depth squared: 24 GB, then the system killed it),
    and `deik solve` refuses it in one line, where the LM polish's two D x D matrices failed
    inside the kernel with an internal error."""
    from deik.cli import main
    from deik.cli.info_command import MAX_INDENT

    assert main(["info", "chain:100000"]) == 0
    lines = capsys.readouterr().out.splitlines()
    deepest = next(line for line in lines if "link99999 " in line)
    assert deepest.startswith("  " * (MAX_INDENT + 1) + "[depth 99999] link99999"), deepest[:120]
    status, err = _cli(["solve", "chain:100000", "--reach", "tip", 1, 0, 0, "--generations", 5, "--quiet"], capsys)
    assert status == 2 and err.count("\n") == 1 and "needs about" in err and "GiB" in err, err


def test_a_floor_above_the_body_and_a_reach_out_of_range_name_their_flags(tmp_path, capsys):
    """Both used to stop with a goal's own words ("position RightAnkle_heel: target ... is
    unreachable"), naming no flag."""
    clip = tmp_path / "toy.bvh"
    clip.write_text(TOY_BVH)
    out = tmp_path / "out.bvh"
    status, err = _cli(["clip", clip, "--out", out, "--floor", 100], capsys)
    assert status == 2 and err.startswith("deik: error: --floor 100: the floor would lie above the whole body"), err
    status, err = _cli(["clip", clip, "--out", out, "--reach", "Arm_end=0,30,0@0:1"], capsys)
    assert status == 2 and err.startswith("deik: error: --reach 'Arm_end=0,30,0@0:1': target [0.0, 30.0, 0.0]"), err
    assert "is unreachable" in err and err.count("\n") == 1 and not out.exists()


def test_a_floor_far_below_the_body_is_warned_and_one_near_it_is_not(tmp_path, capsys):
    """`--floor -5` under a clip standing at 0 was taken without a word: nothing can rest on it."""
    clip = tmp_path / "walk.bvh"
    clip.write_text(format_rig(procedural_walk().rig))
    out = tmp_path / "out.bvh"
    status, err = _cli(["clip", clip, "--out", out, "--floor", -5], capsys)
    assert (
        status == 0
        and "warning: --floor -5: the body never comes within 5 length units of this floor (its lowest point is at 0)"
        in err
    ), err
    assert "nothing rests on it" in err
    status, err = _cli(["clip", clip, "--out", out, "--floor", -0.02, "--overwrite"], capsys)
    assert status == 0 and "--floor" not in err, err


def test_demo_into_a_file_names_the_flag(tmp_path, capsys):
    taken = tmp_path / "taken.txt"
    taken.write_text("keep")
    status, err = _cli(["demo", "--out", taken], capsys)
    expected = f"--out {str(taken)!r} is a file; give a folder for the pictures and demo.json\n"
    assert status == 2 and err.endswith(expected)
    assert err.count("\n") == 1
    assert taken.read_text() == "keep"


def test_a_tolerance_finer_than_float32_resolves_is_warned_with_the_fix(capsys):
    status, err = _cli(
        ["solve", "chain:5", "--reach", "tip", 3, 2, 0, "--tolerance", 1e-12, "--generations", 20], capsys
    )
    assert status == 0  # the solve still runs, and says whether it converged
    assert "--tolerance 1e-12 is finer than float32 kernels reliably reach" in err and "--dtype float64" in err
    _, err = _cli(["solve", "chain:5", "--reach", "tip", 3, 2, 0, "--tolerance", 1e-12, "--dtype", "float64"], capsys)
    assert "finer than float32" not in err
    _, err = _cli(["solve", "chain:5", "--reach", "tip", 3, 2, 0, "--tolerance", 1e-4], capsys)
    assert "finer than float32" not in err


def test_an_output_name_too_long_or_ending_in_a_slash_is_refused_before_any_output(tmp_path, capsys):
    """A --json name over 255 bytes: --out was written, then the journal's move of the report
    failed naming deik's temporary file (a half-written set); a trailing slash wrote a file."""
    clip = tmp_path / "walk.bvh"
    clip.write_text(format_rig(procedural_walk().rig))
    for extra in (["--json", str(tmp_path / ("b" * 300 + ".json"))], ["--json", str(tmp_path / "r.json") + "/"]):
        before = sorted(p.name for p in tmp_path.iterdir())
        assert main(["clip", str(clip), "--out", str(tmp_path / "o.bvh"), "--quiet", *extra]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and err.startswith("deik: error: --json: "), err
        assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_a_limits_table_past_a_robot_s_own_limits_is_refused_in_degrees(tmp_path, capsys):
    """A limits table narrows a skeleton's limits: one that went past a URDF joint's own let a
    solve leave panda_joint4 at +60 degrees, where the robot allows -176 to -4, with exit 0."""
    from deik.io.limits import with_limits

    arm = robot_arm()
    d = next(k for k in range(arm.n_dofs) if not arm.full_turns[k] and np.isfinite(arm.upper[k]))
    name = arm.dof_names[d]
    wide = (float(arm.lower[d]) - 0.5, float(arm.upper[d]) + 0.5)
    with pytest.raises(InputError, match=rf"DOF '{name}': limits \[.*\] degrees go past the skeleton's own"):
        with_limits(arm, {name: wide})
    narrow = with_limits(arm, {name: (float(arm.lower[d]) + 0.1, float(arm.upper[d]) - 0.1)})
    assert narrow.upper[d] == pytest.approx(arm.upper[d] - 0.1)


def test_a_setting_flag_out_of_range_is_named_and_a_json_key_given_twice_is_refused(tmp_path, capsys):
    """`--population 0` said "population must be ...", naming no flag; a limits table with one
    DOF twice kept the last silently; `{}` was called "not a JSON object"."""
    assert main(["solve", "chain:5", "--reach", "tip", "1", "1", "0", "--population", "0"]) == 2
    assert capsys.readouterr().err.startswith("deik: error: --population: population must be an integer >= 4")
    clip = tmp_path / "walk.bvh"
    clip.write_text(format_rig(procedural_walk().rig))
    assert main(["clip", str(clip), "--out", str(tmp_path / "o.bvh"), "--generations", "-1"]) == 2
    assert capsys.readouterr().err.startswith("deik: error: --generations: ")
    table = tmp_path / "limits.json"
    for text, message in (
        ('{"LeftKnee.Zrotation": [-150, 0], "LeftKnee.Zrotation": [-10, 0]}', "is given twice in one object"),
        ("{}", "lists no DOF"),
    ):
        table.write_text(text)
        assert main(["clip", str(clip), "--out", str(tmp_path / "o.bvh"), "--limits", str(table)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and str(table) in err and message in err, err
    assert not (tmp_path / "o.bvh").exists()


def test_a_zero_obstacle_and_a_point_given_two_targets_name_their_flags(capsys):
    """`--obstacle X Y Z 0` was refused in the goal's own words ("bone_radius >= 0"), naming no
    flag; two --reach targets for one point were solved as a compromise that met neither."""
    base = ["solve", "chain:5", "--generations", 5, "--quiet"]
    status, err = _cli([*base, "--reach", "tip", 3, 2, 0, "--obstacle", 1, 1, 0, 0], capsys)
    assert status == 2 and err == "deik: error: --obstacle 1 1 0 0: the radius (the last number) must be above 0\n"
    status, err = _cli([*base, "--reach", "tip", 3, 2, 0, "--reach", "tip", 3, 1, 0], capsys)
    assert (
        status == 2 and err == "deik: error: --reach tip is given more than once: give one target per joint or site\n"
    )
    status, err = _cli([*base, "--orient", "tip", "rpy", 0, 0, 0, "--orient", "tip", "rpy", 0, 9, 0], capsys)
    assert status == 2 and err.startswith("deik: error: --orient tip is given more than once"), err
    assert _cli([*base, "--reach", "tip", 3, 2, 0, "--orient", "tip", "rpy", 0, 0, 0], capsys)[0] == 0


def test_a_scale_retarget_of_a_rig_without_legs_names_the_file(tmp_path, capsys):
    """The refusal named no file ("the source's root is not above its contact sites")."""
    path = tmp_path / "upright.bvh"
    path.write_text(
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Zposition\n  JOINT Spine\n  {\n"
        "    OFFSET 0 1 0\n    CHANNELS 1 Zrotation\n    End Site\n    {\n      OFFSET 0 1 0\n    }\n  }\n}\n"
        "MOTION\nFrames: 2\nFrame Time: 0.0333\n0 0 0 0\n0 0 0 5\n"
    )
    status, err = _cli(["retarget", path, "--scale", "Spine=2", "--out", tmp_path / "o.bvh", "--quiet"], capsys)
    assert status == 2 and err.startswith(f"deik: error: {path}: the root is above no joint or site at rest"), err
    assert not (tmp_path / "o.bvh").exists()


def test_reach_tracks_giving_one_frame_two_targets_or_huge_numbers_are_refused(tmp_path, capsys):
    """Two --reach tracks overlapping on a site were accepted (frames 2-3 had two targets), and
    a fixed point of 1e300 printed a numpy overflow warning before its refusal."""
    clip = tmp_path / "toy.bvh"
    clip.write_text(TOY_BVH)
    out = tmp_path / "out.bvh"
    status, err = _cli(
        ["clip", clip, "--out", out, "--reach", "Arm_end=0,1,1@0:1", "--reach", "Arm_end=0,1.5,1@1:1"], capsys
    )
    assert status == 2 and err.count("\n") == 1 and "both give Arm_end a target in frame 1" in err, err
    status, err = _cli(["clip", clip, "--out", out, "--reach", "Arm_end=1,1,1e300@0:1"], capsys)
    assert status == 2 and err.count("\n") == 1 and "out of range: give numbers from -1e+12 to 1e+12" in err, err
    assert not out.exists()


def test_clean_options_are_checked_as_their_flags_are():
    """CleanOptions took contact_height=-1 or inf silently, raised numpy's own error for 'x'
    and Python's for balance='yes', clamped memory_limit=-5 to one byte, and called a dict of
    limits a missing file."""
    for fields, words in (
        ({"contact_height": -1}, "--contact-height -1: give a finite number from 0"),
        ({"contact_height": float("inf")}, "--contact-height inf"),
        ({"contact_speed": float("inf")}, "--contact-speed inf"),
        ({"contact_height": "x"}, "--contact-height 'x'"),
        ({"balance": "yes"}, "balance: give True or False"),
        ({"memory_limit": -5}, "--memory-limit -5: give a finite number above 0"),
        ({"fidelity": 2}, "--fidelity 2: give a finite number from 0 to 1"),
        ({"limits": {"Arm.Zrotation": [0, 1]}}, "limits: give the path of a limits table"),
    ):
        with pytest.raises(InputError, match=re.escape(words)):
            deik.CleanOptions(**fields)
    assert deik.CleanOptions(contact_height=np.float64(0.05), fidelity=1, balance=np.True_).balance


def test_api_arguments_of_the_wrong_kind_are_named(tmp_path):
    """read_urdf kept up=(0, 1) and a later balance goal failed on array shapes; retarget's
    velocity, scale and frames and write_bvh's and range_of_motion's clip raised Python's own
    errors (or accepted an unknown DOF)."""
    from deik.io.limits import range_of_motion
    from deik.retargeting.api import _check_velocity

    clip = tmp_path / "toy.bvh"
    clip.write_text(TOY_BVH)
    arm = tmp_path / "arm.urdf"
    arm.write_text(MESH_ROBOT)
    for up in ((0, 1), (0, 0, 0), "z", [[0], [0], [1]]):
        with pytest.raises(InputError, match=r"up: give a direction of three finite numbers"):
            deik.read_urdf(arm, up=up)
    robot = deik.read_urdf(arm, up=(0, 0, 2))
    assert np.allclose(robot.up, [0, 0, 1])
    for velocity, words in (
        ({"nope": 1.0}, "has no DOF 'nope'"),
        ({robot.dof_names[0]: -1.0}, "must be a finite number above 0"),
        ([1.0, 2.0], "give {DOF name: limit}"),
    ):
        with pytest.raises(InputError, match=re.escape(words)):
            _check_velocity(velocity, robot)
    with pytest.raises(InputError, match=r"scale: give \{joint: factor\}"):
        deik.retarget(clip, scale="Arm=1.1")
    with pytest.raises(InputError, match=r"frames: give \(start, stop\)"):
        deik.retarget(clip, scale={"Arm": 1.1}, frames=(0, 2, 1))
    with pytest.raises(TypeError, match="write_bvh writes a deik.Clip"):
        deik.write_bvh(tmp_path / "x.bvh", deik.read_bvh(clip).skeleton)
    with pytest.raises(TypeError, match="range_of_motion measures a deik.Clip"):
        range_of_motion(str(clip), 10)


def test_units_that_make_the_body_an_impossible_size_are_warned(tmp_path, capsys):
    """`--units cm` on a clip in metres described a 2 cm person without a word."""
    clip = tmp_path / "walk.bvh"
    clip.write_text(format_rig(procedural_walk().rig))
    assert main(["clip", str(clip), "--out", str(tmp_path / "o.bvh"), "--units", "cm"]) == 0
    assert "warning: --units cm: the body would span 0.0" in capsys.readouterr().err
    assert main(["clip", str(clip), "--out", str(tmp_path / "o.bvh"), "--units", "m"]) == 0
    assert "--units m: the body would span" not in capsys.readouterr().err


def test_goals_and_files_that_name_things_oddly_are_refused_with_the_reason(tmp_path, capsys):
    """A support polygon of one string was read letter by letter and one listing a corner three
    times was solved; euler "XXY" was taken; a .json track holding a string was read as CSV;
    `deik solve` told a clip of 0 frames to choose a frame, and `deik clip --floor none` called
    it a floor it could not detect; `experiments --doc` wrote a report into a .txt."""
    from deik.cleanup.tracks import read_track
    from deik.errors import FileFormatError

    human = deik.humanoid()
    with pytest.raises(InputError, match="give a list of frame names, not the one string 'right_heel'"):
        deik.Problem(human, [deik.ComInPolygon("right_heel")])
    with pytest.raises(InputError, match="lists 'right_heel' more than once"):
        deik.Problem(human, [deik.ComInPolygon(("right_heel", "right_heel", "left_heel"))])
    problem = tmp_path / "p.toml"
    problem.write_text(
        'skeleton = "humanoid"\n[[goal]]\ntype = "orientation"\nframe = "head"\neuler = "XXY"\ndegrees = [1, 2, 3]\n'
    )
    status, err = _cli(["solve", "--problem", problem], capsys)
    assert status == 2 and "euler 'XXY' turns about one axis twice in a row" in err, err
    track = tmp_path / "track.json"
    track.write_text('"frame,x,y,z"')
    with pytest.raises(FileFormatError) as caught:
        read_track(track, 3)
    assert "header" not in str(caught.value), caught.value
    still = tmp_path / "still.bvh"
    still.write_text(TOY_BVH.replace("Frames: 2", "Frames: 0").split("Frame Time")[0] + "Frame Time: 0.033333\n")
    status, err = _cli(["solve", still, "--reach", "Arm_end", 0, 1, 1], capsys)
    assert status == 2 and "has no frames (Frames: 0), so no pose to start from" in err, err
    status, err = _cli(["clip", still, "--floor", "none", "--out", tmp_path / "o.bvh"], capsys)
    assert status == 2 and err.endswith("the clip has no frames (Frames: 0) to fix; give one with motion\n"), err
    status, err = _cli(["experiments", "all", "--quick", "--doc", tmp_path / "e.txt", "--out", tmp_path / "e"], capsys)
    assert status == 2 and "give a PATH.md" in err and not (tmp_path / "e.txt").exists(), err


def test_frames_from_the_end_are_a_range_not_a_flag(tmp_path, capsys):
    """`--frames -5:-1` failed in argparse ("expected one argument"): a range is now read as a
    Python slice, in the CLI and in deik.retarget, and cuts the source the same way."""
    from deik.retargeting.outcome import frame_range

    path = tmp_path / "walk.bvh"
    path.write_text(format_rig(procedural_walk().rig))
    clip = deik.read_bvh(path)
    n = clip.n_frames
    for frames, kept in (((-5, -1), slice(n - 5, n - 1)), ((-5, None), slice(n - 5, n)), ((None, 3), slice(0, 3))):
        assert np.array_equal(frame_range(clip, frames).frames, clip.frames[kept]), frames
    with pytest.raises(InputError, match=f"clip of {n} frames"):
        frame_range(clip, (-n - 1, None))
    out = tmp_path / "out.bvh"
    assert main(["retarget", str(path), "--scale", "LeftHip=1.0", "--frames", "-6:", "--out", str(out), "-q"]) == 0
    assert deik.read_bvh(out).n_frames == 6
    assert main(["retarget", str(path), "--scale", "LeftHip=1.0", "--frames", "4:2", "--out", str(out), "-q"]) == 2
    assert "frames 4:2 are empty" in capsys.readouterr().err


def test_true_and_false_are_not_coordinates():
    """deik.Position("tip", True) broadcast to (1, 1, 1) and [True, False, True] was solved as
    (1, 0, 1): a boolean where numbers belong is a mistake, refused by name."""
    problem = deik.Problem(deik.chain(3), [deik.Position("tip", [0.5, 0.5, 0.0])])
    assert deik.solve(problem, seed=0).converged
    for target in (True, [True, False, True], np.array([1, 0, 1], bool)):
        with pytest.raises(InputError, match=r"tip target holds True/False, not numbers"):
            deik.solve(deik.Problem(deik.chain(3), [deik.Position("tip", target)]), seed=0)
    with pytest.raises(InputError, match="holds True/False"):
        deik.forward_kinematics(deik.chain(3), np.ones(deik.chain(3).n_dofs, bool))


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
def test_outputs_that_are_no_regular_file_or_no_name_are_refused(tmp_path, capsys):
    """A pipe given as --json was replaced by a regular file; `--out a.bvh/x.bvh` said the
    folder a.bvh "does not exist"; `--out .bvh` said it "must end in .bvh"."""
    clip = tmp_path / "toy.bvh"
    clip.write_text(TOY_BVH)
    pipe = tmp_path / "report.json"
    os.mkfifo(pipe)
    status, err = _cli(["clip", clip, "--out", tmp_path / "o.bvh", "--json", pipe], capsys)
    assert status == 2 and err.strip().endswith("is a device, pipe or socket; give a regular file path"), err
    assert not (tmp_path / "o.bvh").exists() and pipe.is_fifo()
    status, err = _cli(["clip", clip, "--out", tmp_path / "toy.bvh" / "x.bvh"], capsys)
    assert status == 2 and "is a file, not a folder; give a path in a folder" in err, err
    status, err = _cli(["clip", clip, "--out", tmp_path / ".bvh"], capsys)
    assert status == 2 and "has no name before .bvh; give one" in err, err


def test_an_address_where_nothing_answers_is_refused_at_once():
    """ray.init waited for ever on a cluster address where nothing listened."""
    import socket
    import time

    from deik.errors import SolveError
    from deik.library.ray_cluster import check_address

    with socket.socket() as probe:  # a port that was free a moment ago: nothing listens there
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    began = time.perf_counter()
    for address in (f"127.0.0.1:{port}", f"ray://127.0.0.1:{port}"):
        with pytest.raises(SolveError, match=f"--address {re.escape(address)}: nothing answers there"):
            check_address(address)
    assert time.perf_counter() - began < 5.0
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        check_address(f"127.0.0.1:{server.getsockname()[1]}")  # something answers: Ray's to judge
    check_address("auto")


def test_a_zero_velocity_limit_is_none_and_a_one_frame_clip_needs_no_frame_flag(tmp_path, capsys):
    """CAD exporters write <limit velocity="0"> for an unknown limit, and `deik info` refused
    the robot; a clip of one frame asked for --frame N."""
    from deik.io.urdf import read_velocity_limits

    urdf = tmp_path / "arm.urdf"
    urdf.write_text(MESH_ROBOT.replace('upper="3"/>', 'upper="3" effort="0" velocity="0"/>'))
    assert read_velocity_limits(urdf) == {} and main(["info", str(urdf)]) == 0
    urdf.write_text(MESH_ROBOT.replace('upper="3"/>', 'upper="3" velocity="-1"/>'))
    status, err = _cli(["info", urdf], capsys)
    assert status == 2 and "a velocity limit must be > 0, or 0 for none" in err, err
    walk = procedural_walk().rig
    one = tmp_path / "one.bvh"
    one.write_text(format_rig(dataclasses.replace(walk, frames=walk.frames[:1])))
    hand = walk.sites[0][0]  # an End Site of the walk's rig
    status, err = _cli(["solve", "--skeleton", one, "--reach", hand, 0.3, 0.9, 0.1, "-q"], capsys)
    assert status == 0, err


def test_a_clip_whose_warm_start_would_not_fit_is_refused_before_it(tmp_path, capsys):
    """A rig of 4,000 joints died in the warm start with "internal error: MemoryError: Unable to
    allocate 85.8 GiB" (2,000 joints: killed by the system); the warm start's Jacobians
    (2 x N x F x 3 x D float64) are now checked against the memory limit with the DE's buffers."""
    walk = procedural_walk().rig
    clip = tmp_path / "walk.bvh"
    clip.write_text(format_rig(walk))
    sk = deik.read_bvh(clip).skeleton
    needed = 6 * len(walk.frames) * sk.n_frames * sk.n_dofs * 8  # the soles add frames: at least this
    limit = needed / 2**30 / 2
    status, err = _cli(["clip", clip, "--out", tmp_path / "o.bvh", "--memory-limit", limit, "-q"], capsys)
    assert status == 2 and err.count("\n") == 1, err
    assert f"the warm start of {len(walk.frames)} frames x " in err and "clean fewer frames at a time" in err, err
    assert not (tmp_path / "o.bvh").exists()


def test_an_existing_output_that_is_no_input_is_replaced(tmp_path, capsys):
    """The README: an output that is none of the command's inputs is replaced, as a compiler
    replaces its output; only an input needs --overwrite."""
    clip = tmp_path / "toy.bvh"
    clip.write_text(TOY_BVH)
    out = tmp_path / "out.bvh"
    out.write_text("an older result")
    status, err = _cli(["clip", clip, "--out", out, "-q"], capsys)
    assert status == 0, err
    assert deik.read_bvh(out).n_frames == deik.read_bvh(clip).n_frames

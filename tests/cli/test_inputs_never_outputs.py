"""Every file a command reads is an input and never an output, however it is named: on the
command line, or inside another input (a problem file's skeleton, joint_limits and segments, a
reach track of any name). Each case is refused before any work with one line naming the flag
and the file, and the input is left byte for byte."""

import json

import pytest

from deik.cli.app import main

TOY_BVH = (
    "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
    "  JOINT Arm\n  {\n    OFFSET 0 1 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
    "    End Site\n    {\n      OFFSET 0 1 0\n    }\n  }\n}\nMOTION\nFrames: 2\nFrame Time: 0.033333\n"
    "0 0 0 0 0 0\n0 0 0 10 0 0\n"
)
LIMITS = '{"Arm.Zrotation": [-90, 90]}'
SEGMENTS = json.dumps({"segments": [{"bvh_frame": "Hips", "mass_kg": 1.0, "com_offset_m": [0, 0.5, 0]}]})


def _problem(tmp_path, **files):
    """tmp/p.toml naming walk.bvh (frame 0) and the `files` {key: name} it is given."""
    (tmp_path / "walk.bvh").write_text(TOY_BVH)
    (tmp_path / "limits.json").write_text(LIMITS)
    (tmp_path / "segments.json").write_text(SEGMENTS)
    keys = "".join(f'{key} = "{name}"\n' for key, name in files.items())
    path = tmp_path / "p.toml"
    path.write_text(
        f'skeleton = "walk.bvh"\nframe = 0\n{keys}[settings]\ngenerations = 3\n'
        '[[goal]]\ntype = "position"\nframe = "Arm_end"\ntarget = [0.0, 1.5, 0.5]\n'
    )
    return path


def _snapshot(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir()}


@pytest.mark.parametrize(
    "files, out",
    [
        ({}, "walk.bvh"),  # the skeleton the problem file names
        ({"joint_limits": "limits.json"}, "limits.json"),
        ({"segments": "segments.json"}, "segments.json"),
    ],
)
def test_solve_never_writes_over_a_file_a_problem_file_names(tmp_path, capsys, files, out):
    problem = _problem(tmp_path, **files)
    before = _snapshot(tmp_path)
    assert main(["solve", "--problem", str(problem), "--out", str(tmp_path / out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: --out ") and out in err and err.count("\n") == 1
    assert _snapshot(tmp_path) == before


def test_clip_never_writes_its_report_over_a_reach_track(tmp_path, capsys):
    (tmp_path / "walk.bvh").write_text(TOY_BVH)
    tracks = (  # a JSON track, and a CSV track whose name ends in neither .csv nor .json
        ("t.json", '[{"frame": 0, "x": 0, "y": 1.5, "z": 0.5}]', "--json"),
        ("t.png", "frame,x,y,z\n0,0,1.5,0.5\n", "--report"),
    )
    for name, text, flag in tracks:
        track = tmp_path / name
        track.write_text(text)
        before = _snapshot(tmp_path)
        argv = ["clip", str(tmp_path / "walk.bvh"), "--reach", f"Arm_end={track}", "--plant-feet", "none"]
        assert main(argv + ["--out", str(tmp_path / "o.bvh"), flag, str(track), "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"deik: error: {flag} ") and "is the input file" in err and err.count("\n") == 1
        assert _snapshot(tmp_path) == before


def test_overwrite_lets_the_output_replace_the_input_it_names(tmp_path, capsys):
    problem = _problem(tmp_path)
    argv = ["solve", "--problem", str(problem), "--out", str(tmp_path / "walk.bvh"), "--quiet", "--overwrite"]
    assert main(argv) == 0
    assert (tmp_path / "walk.bvh").read_text() != TOY_BVH  # the frame was replaced, as asked


def test_a_refusal_offers_overwrite_only_where_the_command_has_it(tmp_path, capsys):
    """`deik clip` has --overwrite and says so; `deik retarget` has none and offers none."""
    clip = tmp_path / "walk.bvh"
    clip.write_text(TOY_BVH)
    for command, extra, offered in (("clip", [], True), ("retarget", ["--scale", "Spine=1.1"], False)):
        assert main([command, str(clip), *extra, "--out", str(clip), "--quiet"]) == 2
        err = capsys.readouterr().err
        assert "is the input file; write elsewhere" in err and ("--overwrite" in err) == offered, err
        assert clip.read_text() == TOY_BVH

"""The one input reader (deik.io.files): only regular files, of bounded size and nesting, parsed
with the file named, typed field access naming the field; and every reader built on it (limits,
segments, tracks, maps, problems, URDF, BVH) refusing huge and many-digit numbers, values far
beyond float32 and names that hold terminal escapes, each with one message naming the file."""

import os
import threading

import pytest

from deik.errors import FileFormatError, InputError
from deik.io.files import Fields, command_inputs, input_named, inputs_read, parse_csv, read_input, read_json, read_toml


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda path: path.symlink_to("/dev/zero"), "is a device, pipe or socket"),
        (lambda path: os.mkfifo(path), "is a device, pipe or socket"),  # opened without blocking
        (lambda path: path.mkdir(), "is a folder"),
        (lambda path: None, "no such table file"),
        (lambda path: path.write_bytes(b"\xff\xfe{}"), "not a text (UTF-8) table file"),
    ],
)
def test_only_regular_text_files_are_read(tmp_path, make, message):
    path = tmp_path / "t.json"
    make(path)
    done = []
    reader = threading.Thread(target=lambda: done.append(_error(lambda: read_json(path, "table"))), daemon=True)
    reader.start()
    reader.join(30)
    assert done, "the reader hung"
    assert str(path) in done[0] and message in done[0]


def _error(read) -> str:
    try:
        read()
    except FileFormatError as error:
        return str(error)
    return "no error"


def test_size_and_nesting_are_bounded(tmp_path, monkeypatch):
    path = tmp_path / "t.json"
    path.write_text("[" * 33 + "]" * 33)
    with pytest.raises(FileFormatError, match="nested more than 32 levels deep"):
        read_json(path, "table")
    path.write_text("[" * 200_000 + "]" * 200_000)
    with pytest.raises(FileFormatError, match="nested too deeply"):
        read_json(path, "table")
    toml = tmp_path / "t.toml"
    toml.write_text("x = " + "[" * 40 + "]" * 40 + "\n")
    with pytest.raises(FileFormatError, match=r"t\.toml: nested more than 32"):
        read_toml(toml, "problem")
    monkeypatch.setenv("DEIK_MAX_INPUT_BYTES", "10")
    path.write_text("[1, 2, 3, 4, 5]")
    with pytest.raises(FileFormatError, match="is 15 bytes, more than the 10 a table file may have"):
        read_input(path, "table")
    monkeypatch.setenv("DEIK_MAX_INPUT_BYTES", "9" * 5000)
    with pytest.raises(InputError, match="must be a positive whole number of bytes"):
        read_input(path, "table")


def test_numbers_of_thousands_of_digits_name_the_file(tmp_path):
    path = tmp_path / "t.json"
    path.write_text("[1" + "0" * 5000 + "]")
    with pytest.raises(FileFormatError, match=r"t\.json: not a table file: Exceeds the limit"):
        read_json(path, "table")
    toml = tmp_path / "t.toml"
    toml.write_text("x = 1" + "0" * 5000 + "\n")
    with pytest.raises(FileFormatError, match=r"t\.toml: not a problem file"):
        read_toml(toml, "problem")


def test_typed_fields_name_the_file_and_the_field():
    fields = Fields({"n": 3, "x": 1.5, "big": 10**400, "name": "a", "flag": True, "sub": {"y": "no"}}, "f.json")
    assert fields.integer("n") == 3 and fields.number("x") == 1.5 and fields.text("name") == "a"
    assert fields.number("missing", default=None) is None
    cases = [
        (lambda: fields.number("big"), "f.json: big: must be a finite number"),
        (lambda: fields.number("flag"), "f.json: flag: must be a finite number, got True"),
        (lambda: fields.integer("x"), "f.json: x: must be a whole number, got 1.5"),
        (lambda: fields.integer("n", 4, 9), "f.json: n: must be a whole number from 4 to 9, got 3"),
        (lambda: fields.number("x", 0, 1), "f.json: x: must lie between 0 and 1, got 1.5"),
        (lambda: fields.text("n"), "f.json: n: must be a string, got 3"),
        (lambda: fields.table("sub").number("y"), "f.json: sub.y: must be a finite number, got 'no'"),
        (lambda: fields.get("absent"), "f.json: absent: is missing"),
        (lambda: Fields([1], "f.json"), "f.json: top level: must be an object"),
    ]
    for read, message in cases:
        with pytest.raises(FileFormatError) as caught:
            read()
        assert str(caught.value).startswith(message), str(caught.value)


def test_csv_rows_keep_their_line_numbers_and_quotes():
    rows = parse_csv('frame,x,y,z\n\n0, 1, "2", 3\n', "t.csv")
    assert rows == [(1, ["frame", "x", "y", "z"]), (3, ["0", "1", "2", "3"])]
    with pytest.raises(FileFormatError, match=r"t\.csv:2: not valid CSV"):
        parse_csv('frame,x\n0,"1\n', "t.csv")


def test_a_command_knows_every_file_it_read_under_any_name(tmp_path):
    path = tmp_path / "a.json"
    path.write_text("{}")
    (tmp_path / "link.json").symlink_to(path)
    os.link(path, tmp_path / "hard.json")
    with command_inputs():
        read_json(tmp_path / "link.json", "table")
        (tmp_path / "record.json").write_text("{}")
        read_json(tmp_path / "record.json", "record", record=False)  # deik's own record: no input
        assert inputs_read() == [str(tmp_path / "link.json")]
        assert input_named(path) == input_named(tmp_path / "hard.json") == str(tmp_path / "link.json")
        assert input_named(tmp_path / "other.json") is None
    assert input_named(path) is None  # outside a command nothing is recorded


URDF = """<?xml version="1.0"?><robot name="r"><link name="a"><inertial><origin xyz="{com}"/><mass value="1"/>
</inertial></link><link name="b"/><link name="c"/>
<joint name="j" type="revolute"><parent link="a"/><child link="b"/><origin xyz="{xyz}"/><axis xyz="0 0 1"/>
<limit lower="-1" upper="1"/></joint>
<joint name="k" type="revolute"><parent link="b"/><child link="c"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>
<mimic joint="j" multiplier="{multiplier}" offset="{offset}"/></joint></robot>"""
GOOD = {"com": "0 0 0", "xyz": "0 0 1", "multiplier": "1", "offset": "0"}


@pytest.mark.parametrize(
    "change, message",
    [
        ({"multiplier": "1e300"}, '<mimic multiplier="1e300">: 1e+300 is beyond +-1e+06'),
        ({"offset": "1e300"}, '<mimic offset="1e300">: 1e+300 is beyond +-1e+06'),
        ({"xyz": "0 0 1e300"}, '<origin xyz="0 0 1e300">: 1e+300 is beyond +-1e+06'),
        ({"com": "1e300 0 0"}, '<origin xyz="1e300 0 0">: 1e+300 is beyond +-1e+06'),
        ({"xyz": "0 0 1" + "0" * 400}, "is too large for a 64-bit float"),
    ],
)
def test_urdf_values_far_beyond_float32_are_refused_by_element(tmp_path, capsys, change, message):
    from deik.cli.app import main
    from deik.io.urdf import read_urdf

    path = tmp_path / "r.urdf"
    path.write_text(URDF.format(**{**GOOD, **change}))
    with pytest.raises(FileFormatError, match="r.urdf:") as caught:
        read_urdf(path)
    assert message in str(caught.value)
    assert main(["info", str(path)]) == 2  # not "reach 1e+300", not an internal error
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and "r.urdf" in err and err.count("\n") == 1


def test_names_holding_terminal_escapes_are_refused_not_printed(tmp_path, capsys):
    from deik.cli.app import main

    path = tmp_path / "escape.bvh"
    name = "Arm\x1b]0;pwned\x07"
    path.write_text(
        f"HIERARCHY\nROOT Hips\n{{\nOFFSET 0 0 0\nCHANNELS 1 Zrotation\nJOINT {name}\n{{\nOFFSET 0 1 0\n"
        "CHANNELS 1 Zrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 0\n"
    )
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert "\x1b" not in err and "\x07" not in err and "\\x1b" in err and "control characters" in err


@pytest.mark.parametrize(
    "text, message",
    [
        ('[points]\nHips = { target = "pelvis", offset = [0, 1e300, 0] }\n', "points.Hips.offset[1]: must lie between"),
        ("scale = 1" + "0" * 400 + '\n[points]\nHips = "pelvis"\n', "scale: must be a finite number"),
        ("scale = 1" + "0" * 5000 + '\n[points]\nHips = "pelvis"\n', "not a joint map file: Exceeds the limit"),
        ('up = [0, 0, 0]\n[points]\nHips = "pelvis"\n', "up: must be a direction"),
    ],
)
def test_map_numbers_are_range_checked_by_key(tmp_path, text, message):
    from deik.retargeting.maps import read_map

    path = tmp_path / "m.toml"
    path.write_text(text)
    with pytest.raises(FileFormatError) as caught:
        read_map(path)
    assert str(caught.value).startswith(str(path)) and message in str(caught.value)


@pytest.mark.parametrize(
    "goal, message",
    [
        ("target = [1" + "0" * 400 + ", 0, 0]", "field 'target' must be [x, y, z] (finite numbers)"),
        ("target = [1e300, 0, 0]", "beyond +-1e+12"),
        ("target = [1, 0, 0]\nweight = 1" + "0" * 400, "field 'weight' must be a finite number"),
    ],
)
def test_problem_numbers_beyond_float_range_name_the_file_and_field(tmp_path, capsys, goal, message):
    from deik.cli.app import main

    path = tmp_path / "p.toml"
    path.write_text(f'skeleton = "chain:3"\n[[goal]]\ntype = "position"\nframe = "tip"\n{goal}\n')
    assert main(["solve", "--problem", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"deik: error: {path}") and message in err and err.count("\n") == 1

"""Reach target tracks: CSV and JSON files, the --reach syntax, and one test per malformed input."""

import json

import numpy as np
import pytest

from deik.cleanup.tracks import parse_reach_spec, read_track
from deik.errors import FileFormatError

N = 10


def write(tmp_path, name: str, text: str):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def expected_track(points: dict):
    mask, targets = np.zeros(N, bool), np.full((N, 3), np.nan)
    for frame, point in points.items():
        mask[frame], targets[frame] = True, point
    return mask, targets


def check(result, points: dict):
    mask, targets = expected_track(points)
    np.testing.assert_array_equal(result[0], mask)
    np.testing.assert_array_equal(result[1], targets)


POINTS = {0: (0.1, 1.5, -0.25), 3: (0.2, 1.4, -0.2), 9: (1e-3, 2.0, 3.5)}


def test_csv_round_trip_any_column_order_extra_columns_and_spaces(tmp_path):
    rows = "\n".join(f"{z}, note , {frame} ,{x}, {y}" for frame, (x, y, z) in POINTS.items())
    path = write(tmp_path, "track.csv", f"Z, comment, Frame, x ,Y\n\n{rows}\n\n")
    check(read_track(path, N), POINTS)


def test_json_round_trip_both_forms(tmp_path):
    listed = [{"frame": f, "x": x, "y": y, "z": z, "label": "cup"} for f, (x, y, z) in POINTS.items()]
    check(read_track(write(tmp_path, "a.json", json.dumps(listed)), N), POINTS)
    paired = {"frames": list(POINTS), "positions": [list(p) for p in POINTS.values()]}
    check(read_track(write(tmp_path, "b.json", json.dumps(paired)), N), POINTS)


@pytest.mark.parametrize(
    "text, message",
    [
        ("frame,x\n0,1,\n", r"track.csv:1: missing columns y, z"),
        ("frame,x,y,z\n0,1,2,3\n1,1,oops,3\n", r"track.csv:3: column y 'oops' is not a number"),
        ("frame,x,y,z\n0,1,nan,3\n", r"track.csv:2: column y is nan: NaN"),
        ("frame,x,y,z\n1.5,1,2,3\n", r"track.csv:2: frame '1.5' is not a whole number"),
        ("frame,x,y,z\n2,1,2,3\n4,0,0,0\n2,1,2,3\n", r"track.csv:4: frame 2 is listed twice \(first at line 2\)"),
        ("frame,x,y,z\n10,1,2,3\n", r"track.csv:2: frame 10 is outside the clip; valid frames: 0\.\.9"),
        ("frame,x,y,z\n-1,1,2,3\n", r"valid frames: 0\.\.9"),
        ("frame,x,y,z\n0,1,2\n", r"track.csv:2: 3 fields where the header has 4"),
        ("frame,x,y,z\n\n", r"track.csv: empty track"),
        ("", r"track.csv: empty track"),
    ],
)
def test_csv_errors_name_the_file_and_line(tmp_path, text, message):
    with pytest.raises(FileFormatError, match=message):
        read_track(write(tmp_path, "track.csv", text), N)


@pytest.mark.parametrize(
    "data, message",
    [
        ([{"frame": 0, "x": 1, "y": 2}], r"t.json: \[0\]: missing z"),
        ([{"frame": 0, "x": 1, "y": 2, "z": "3"}], r"t.json: \[0\]\.z: must be a finite number"),
        ([{"frame": 0, "x": 1, "y": 2, "z": float("nan")}], r"t.json: \[0\]\.z: must be a finite number, got nan"),
        ([{"frame": True, "x": 1, "y": 2, "z": 3}], r"\[0\]\.frame: must be a whole number"),
        (
            [{"frame": 1, "x": 1, "y": 2, "z": 3}, {"frame": 1, "x": 0, "y": 0, "z": 0}],
            r"\[1\]\.frame: frame 1 is listed twice \(first at \[0\]\.frame\)",
        ),
        (
            {"frames": [12], "positions": [[0, 0, 0]]},
            r"frames\[0\]: frame 12 is outside the clip; valid frames: 0\.\.9",
        ),
        ({"frames": [1, 2], "positions": [[0, 0, 0]]}, r"must be lists of the same length"),
        ({"frames": [1], "positions": [[0, 0]]}, r"positions\[0\]: must be \[x, y, z\]"),
        ({"frames": [1], "positions": [[0, None, 0]]}, r"positions\[0\]\[1\]: must be a finite number"),
        ([], r"t.json: empty track"),
        ({"points": []}, r"top level: expected a list"),
    ],
)
def test_json_errors_name_the_file_and_element(tmp_path, data, message):
    with pytest.raises(FileFormatError, match=message):
        read_track(write(tmp_path, "t.json", json.dumps(data)), N)


def test_invalid_json_names_the_line(tmp_path):
    with pytest.raises(FileFormatError, match=r"t.json:2: not valid JSON"):
        read_track(write(tmp_path, "t.json", '[\n{"frame": 0,, }]'), N)


def test_reach_spec_with_a_track_file(tmp_path):
    path = write(tmp_path, "cup.csv", "frame,x,y,z\n3,0.2,1.4,-0.2\n")
    site, mask, targets = parse_reach_spec(f"RightElbow_end={path}", N)
    assert site == "RightElbow_end"
    check((mask, targets), {3: (0.2, 1.4, -0.2)})


def test_reach_spec_with_a_fixed_point_over_an_inclusive_range():
    site, mask, targets = parse_reach_spec("LeftElbow_end=0.3, 1.2,-4e-1@2:5", N)
    assert site == "LeftElbow_end"
    check((mask, targets), {n: (0.3, 1.2, -0.4) for n in range(2, 6)})
    check(parse_reach_spec("hand=1,2,3", N)[1:], {n: (1, 2, 3) for n in range(N)})
    check(parse_reach_spec("hand=1,2,3@9:9", N)[1:], {9: (1, 2, 3)})


@pytest.mark.parametrize(
    "spec, message",
    [
        ("hand", "is not SITE=TARGET"),
        ("=1,2,3", "is not SITE=TARGET"),
        ("hand=", "is not SITE=TARGET"),
        ("hand=1,2", "is not a point X,Y,Z"),
        ("hand=1,2,inf", "is not a point X,Y,Z"),
        ("hand=1,2,3@4", "frame range '4' is not A:B"),
        ("hand=1,2,3@a:b", "frame range 'a:b' is not A:B"),
        ("hand=1,2,3@5:2", r"frames 5:2 are outside the clip or reversed; valid frames: 0\.\.9"),
        ("hand=1,2,3@0:10", r"frames 0:10 are outside the clip"),
    ],
)
def test_malformed_reach_specs_name_the_accepted_forms(spec, message):
    with pytest.raises(ValueError, match=message) as error:
        parse_reach_spec(spec, N)
    if "outside" not in message:
        assert "SITE=track.csv, SITE=track.json, or SITE=X,Y,Z@A:B" in str(error.value)


def test_reach_spec_naming_a_missing_track_file(tmp_path):
    with pytest.raises(FileFormatError, match=r"missing\.csv: no such track file"):
        parse_reach_spec(f"hand={tmp_path / 'missing.csv'}", N)

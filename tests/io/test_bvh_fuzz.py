"""Fuzz the BVH reader: on any text or bytes it returns a Clip or raises FileFormatError naming
the file, and every Clip it returns writes and reads back unchanged.

Inputs: arbitrary text and bytes, soups of BVH words, and a valid file after a few random edits
(also as CRLF bytes). Derandomized, so every run tries the same inputs. By default a few hundred
in all, so that every test run includes the fuzzing; DEIK_FUZZ_SCALE=10 multiplies each count
for a thorough search (thousands of inputs, a few minutes).
"""

import os
import re

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from deik.errors import FileFormatError
from deik.io.bvh import format_bvh, parse_bvh

SCALE = float(os.environ.get("DEIK_FUZZ_SCALE", "1"))


def examples(n: int) -> int:
    """The number of inputs a test tries: n, times DEIK_FUZZ_SCALE."""
    return max(1, round(n * SCALE))


FUZZ = settings(
    max_examples=examples(60),
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)

VALID = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 0.9 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Spine
\t{
\t\tOFFSET 0 0.2 0
\t\tCHANNELS 4 Zrotation Yposition Xrotation Yrotation
\t\tJOINT Head
\t\t{
\t\t\tOFFSET 0 0.3 0
\t\t\tCHANNELS 2 Xrotation Zrotation
\t\t\tEnd Site
\t\t\t{
\t\t\t\tOFFSET 0 0.2 0
\t\t\t}
\t\t}
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0.1 0 0
\t\t}
\t}
\tJOINT LeftUpLeg
\t{
\t\tOFFSET 0.1 -0.1 0
\t\tCHANNELS 3 Zrotation Xrotation Yrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 -0.8 0
\t\t}
\t}
}
MOTION
Frames: 3
Frame Time: 0.0333333
0 0.9 0 1 2 3 4 0.01 5 6 7 8 9 10 11
0.1 0.91 0 -179 2 3 4 0.02 5 6 7 8 9 10 11
0.2 0.92 0 181 2 3 4 0.03 5 6 370 8 9 10 11
"""
WORDS = [
    "HIERARCHY",
    "ROOT",
    "JOINT",
    "End",
    "Site",
    "OFFSET",
    "CHANNELS",
    "{",
    "}",
    "MOTION",
    "Frames:",
    "Frame",
    "Time:",
    "0",
    "1",
    "2",
    "3",
    "6",
    "-2.5",
    "1e12",
    "1e308",
    "nan",
    "-inf",
    "Xposition",
    "Zrotation",
    "Yrotation",
    "xROTATION",
    "Hips",
    "Spine",
    "é",
    "\x00",
    "7x",
    "--1",
    ".5",
    "1e",
    "\t",
    "\r",
]
NUMBER = re.compile(r"-?[0-9.]+")
NUMBERS = ["0", "-0", "1", "2", "3", "6", "-2.5", ".5", "1e-9", "1e12", "-1e12", "370", "12345.678"]


def check(data, source="fuzz.bvh"):
    """parse_bvh gives a Clip that round-trips, or a FileFormatError naming `source`."""
    try:
        clip = parse_bvh(data, source)
    except FileFormatError as error:
        assert error.source == source and str(error).startswith(source)
        assert error.line is None or error.line >= 1
        return
    again = parse_bvh(format_bvh(clip), "again.bvh")
    assert again.layout == clip.layout and again.frame_time == clip.frame_time
    np.testing.assert_array_equal(again.skeleton.offsets, clip.skeleton.offsets)
    np.testing.assert_allclose(again.channel_values(), clip.channel_values(), rtol=1e-9, atol=1e-6)


def test_the_valid_file_parses():
    clip = parse_bvh(VALID, "valid.bvh")
    assert clip.frames.shape == (3, 15) and clip.skeleton.site_names == ("Head_end", "Spine_end", "LeftUpLeg_end")
    check(VALID)


@FUZZ
@given(st.text(max_size=400))
def test_arbitrary_text(text):
    check(text)


@FUZZ
@given(st.binary(max_size=400))
def test_arbitrary_bytes(data):
    check(data)


@settings(FUZZ, max_examples=examples(100))
@given(st.lists(st.sampled_from(WORDS + ["\n"] * 8), max_size=120))
def test_soup_of_bvh_words(words):
    check(" ".join(words))


@st.composite
def mutations(draw):
    """VALID after 1-4 random edits of its lines or tokens, maybe truncated. Positions are drawn
    uniformly (hypothesis' own integers favour the first lines)."""
    rnd = draw(st.randoms(use_true_random=False))
    lines, numbers_only = VALID.split("\n"), rnd.random() < 0.3  # numbers only: mostly valid
    for _ in range(rnd.randint(1, 4)):
        edit = (
            "number"
            if numbers_only
            else rnd.choice(
                ["delete line", "duplicate line", "move line", "insert", "delete", "duplicate", "replace", "number"]
            )
        )
        numeric = [[i for i, word in enumerate(line.split()) if NUMBER.fullmatch(word)] for line in lines]
        candidates = [m for m, found in enumerate(numeric) if found] if edit == "number" else []
        n = rnd.choice(candidates) if candidates else rnd.randrange(len(lines))
        words = lines[n].split()
        k = rnd.choice(numeric[n]) if edit == "number" and numeric[n] else rnd.randrange(len(words) + 1)
        if edit == "delete line":
            del lines[n]
        elif edit == "duplicate line":
            lines.insert(n, lines[n])
        elif edit == "move line":
            lines.insert(rnd.randrange(len(lines)), lines.pop(n))
        elif edit == "insert":
            lines[n] = " ".join(words[:k] + [rnd.choice(WORDS)] + words[k:])
        else:
            token = {
                "delete": [],
                "duplicate": words[k : k + 1] * 2,
                "replace": [rnd.choice(WORDS)],
                "number": [rnd.choice(NUMBERS)],
            }[edit]
            lines[n] = " ".join(words[:k] + token + words[k + 1 :])
        lines = lines or [""]
    text = "\n".join(lines)
    truncate = rnd.random() < 0.3 and not numbers_only
    return text[: rnd.randrange(len(text) + 1)] if truncate else text


@settings(FUZZ, max_examples=examples(200))
@given(mutations())
def test_mutations_of_a_valid_file(text):
    check(text)


@FUZZ
@given(mutations())
def test_mutations_as_bytes_with_crlf(text):
    check(text.replace("\n", "\r\n").encode("utf-8"))

"""A BVH file is read in blocks into one array sized before any frame is read: a header that
claims more frames than the file can hold, or frames beyond the memory limit, are refused before
allocating, with the file and line named; a large clip peaks at a few times its size, not the
eight times a whole-file read took."""

import subprocess
import sys

import pytest

from deik.errors import FileFormatError
from deik.io.bvh import read_bvh
from helpers import ROOT

HEAD = (
    "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
    "Yrotation\n  End Site\n  {\n    OFFSET 0 1 0\n  }\n}\nMOTION\n"
)
ROW = "0.123456 1.234567 -2.345678 12.345678 -23.456789 34.567891\n"


def test_a_header_claiming_more_frames_than_the_file_holds_is_refused_before_allocating(tmp_path):
    path = tmp_path / "liar.bvh"
    path.write_text(HEAD + "Frames: 100000000000\nFrame Time: 0.04\n" + ROW)
    with pytest.raises(FileFormatError, match=r"liar\.bvh:12: 'Frames: 100000000000' but the rest of the file holds"):
        read_bvh(path)


def test_frames_beyond_the_memory_limit_are_refused_naming_the_file(tmp_path, monkeypatch):
    import deik.memory

    path = tmp_path / "big.bvh"
    path.write_text(HEAD + "Frames: 2000\nFrame Time: 0.04\n" + ROW * 2000)
    monkeypatch.setattr(deik.memory, "physical_memory", lambda: 100_000)  # a machine of 100 kB
    with pytest.raises(FileFormatError, match=r"big\.bvh:12: a clip of 2000 frames x 6 channels needs about"):
        read_bvh(path)


def test_one_endless_line_is_refused_without_reading_it_whole(tmp_path):
    path = tmp_path / "endless.bvh"
    path.write_text(HEAD + "Frames: 1\nFrame Time: 0.04\n" + "1 " * 3_000_000)
    with pytest.raises(FileFormatError, match=r"endless\.bvh:14: a line of more than 1408 bytes"):
        read_bvh(path)


PEAK = """
import sys
from deik.io.bvh import read_bvh

def status(key):  # kB; VmHWM, this process's own peak (ru_maxrss keeps the forking parent's)
    return int(open("/proc/self/status").read().split(key + ":")[1].split()[0])

before = status("VmRSS")
clip = read_bvh(sys.argv[1])
print(clip.n_frames, status("VmHWM") - before)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_large_clip_peaks_at_a_few_times_its_size(tmp_path):
    frames = 1_000_000  # a 60 MB file
    path = tmp_path / "large.bvh"
    with open(path, "w") as file:
        file.write(HEAD + f"Frames: {frames}\nFrame Time: 0.01\n")
        for _ in range(frames // 1000):
            file.write(ROW * 1000)
    size_kib = path.stat().st_size / 1024
    run = subprocess.run(
        [sys.executable, "-c", PEAK, str(path)], capture_output=True, text=True, timeout=600, cwd=ROOT, check=True
    )
    read, peak_kib = map(int, run.stdout.split())
    assert read == frames
    assert peak_kib < 4 * size_kib, f"peak {peak_kib / size_kib:.1f}x the file's size"

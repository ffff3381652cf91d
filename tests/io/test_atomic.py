"""Atomic writes under attack and under SIGKILL: temporary files are created exclusively at
unpredictable names (a planted link is never followed), fit a legal 255-byte name, are cleaned
by the next write, and a command's files appear together or not at all even when a real
process is killed between its moves (deik.io.atomic)."""

import json
import os
import subprocess
import sys
import textwrap

import pytest

from deik.errors import InputError
from deik.io import atomic
from deik.io.files import command_inputs, read_input
from helpers import kill_when_ready


def test_a_symlink_planted_at_the_temporary_name_is_never_written_through(tmp_path, monkeypatch):
    outside = tmp_path / "outside.txt"
    outside.write_text("precious\n")
    folder = tmp_path / "out"
    folder.mkdir()
    tokens = iter(["0badc0de", "0badc0de", "600dcafe"])
    monkeypatch.setattr(atomic.secrets, "token_hex", lambda n: next(tokens))
    planted = folder / f"{atomic.PARTIAL}{atomic.HOST}-{os.getpid()}-0badc0de.o.json"
    planted.symlink_to(outside)
    atomic.write_text_atomically(folder / "o.json", "{}\n")
    assert outside.read_text() == "precious\n"
    assert not (folder / "o.json").is_symlink() and (folder / "o.json").read_text() == "{}\n"
    assert planted.is_symlink()  # left alone: not ours to remove, a live process's name


def test_a_255_byte_output_name_is_written(tmp_path):
    name = "a" * 250 + ".json"
    atomic.write_json_atomically(tmp_path / name, {"ok": 1})
    assert [p.name for p in tmp_path.iterdir()] == [name]
    utf8 = "é" * 122 + ".json"  # 249 bytes: the temporary name must not cut a character in two
    atomic.write_text_atomically(tmp_path / utf8, "x")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, utf8])


def test_a_write_never_replaces_an_input_of_the_command(tmp_path):
    track = tmp_path / "track.json"
    track.write_text("[]")
    link = tmp_path / "link.json"
    link.symlink_to(track)
    with command_inputs():
        read_input(link, "track")
        with pytest.raises(InputError, match=r"track\.json: this output is also an input of the command \(read as"):
            atomic.write_text_atomically(track, "report")
    assert track.read_text() == "[]"
    with command_inputs(protect=False):  # --overwrite
        read_input(track, "track")
        atomic.write_text_atomically(track, "report")
    assert track.read_text() == "report"


def test_a_full_disk_names_the_file_and_leaves_nothing(tmp_path):
    def full(file):
        file.write(b"part")
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="cannot write it: No space left on device") as caught:
        atomic.save_atomically(tmp_path / "o.bvh", full)
    assert caught.value.filename == str(tmp_path / "o.bvh") and not list(tmp_path.iterdir())


WRITER = """
import os, sys, time
from deik.io import atomic

folder, pause = sys.argv[1], sys.argv[2]
real = os.replace
moved = []

def slow_replace(source, target):
    real(source, target)
    if not os.path.basename(target).startswith(atomic.JOURNAL):
        moved.append(target)
        if pause == "between" and len(moved) == 1:
            open(os.path.join(folder, "..", "ready"), "w").close()
            time.sleep(60)

atomic.os.replace = slow_replace
with atomic.all_or_nothing():
    atomic.write_text_atomically(os.path.join(folder, "o.bvh"), "new clip")
    atomic.write_text_atomically(os.path.join(folder, "o.json"), "new report")
    atomic.write_text_atomically(os.path.join(folder, "sub", "o.png"), "new picture")
    if pause == "before":
        open(os.path.join(folder, "..", "ready"), "w").close()
        time.sleep(60)
"""


def _killed_writer(tmp_path, pause: str):
    """Run WRITER until it says it is ready, then SIGKILL it; returns the output folder."""
    folder = tmp_path / "out"
    (folder / "sub").mkdir(parents=True)
    for name, text in (("o.bvh", "old clip"), ("o.json", "old report"), ("sub/o.png", "old picture")):
        (folder / name).write_text(text)
    script = tmp_path / "writer.py"
    script.write_text(textwrap.dedent(WRITER))
    kill_when_ready(subprocess.Popen([sys.executable, str(script), str(folder), pause]), tmp_path / "ready")
    return folder


def _contents(folder):
    return [(folder / name).read_text() for name in ("o.bvh", "o.json", "sub/o.png")]


def _hidden(folder):
    return sorted(p.name for p in folder.rglob(".*"))


def test_a_kill_between_the_moves_is_finished_by_the_next_command_in_the_folder(tmp_path):
    folder = _killed_writer(tmp_path, "between")
    assert _contents(folder) == ["new clip", "old report", "old picture"]  # what the kill left
    assert any(name.startswith(atomic.JOURNAL) for name in _hidden(folder))
    # the next command reading (here) or writing in either folder finishes the moves first
    subprocess.run(
        [
            sys.executable,
            "-c",
            f"from deik.io.files import read_input; read_input({str(folder / 'sub' / 'o.png')!r}, 'x')",
        ],
        check=True,
    )
    assert _contents(folder) == ["new clip", "new report", "new picture"]
    assert _hidden(folder) == []


def test_a_kill_before_the_moves_leaves_every_old_file_and_its_temporaries_are_cleaned(tmp_path):
    folder = _killed_writer(tmp_path, "before")
    assert _contents(folder) == ["old clip", "old report", "old picture"]
    assert len(_hidden(folder)) == 3  # the temporary files of the killed process
    writes = [
        f"atomic.write_text_atomically({str(path)!r}, 'x')" for path in (folder / "other.txt", folder / "sub" / "x")
    ]
    code = "from deik.io import atomic; " + "; ".join(writes)
    subprocess.run([sys.executable, "-c", code], check=True)
    assert _contents(folder) == ["old clip", "old report", "old picture"] and _hidden(folder) == []


def test_a_damaged_journal_moves_nothing_and_is_removed(tmp_path):
    target = tmp_path / "o.json"
    target.write_text("old")
    elsewhere = tmp_path / "elsewhere.txt"
    elsewhere.write_text("not ours")
    journal = tmp_path / f"{atomic.JOURNAL}{atomic.HOST}-999999999-0123abcd.json"
    journal.write_text(json.dumps({"moves": [[str(elsewhere), str(target)]], "journals": [str(journal)]}))
    atomic.tidy(tmp_path)
    assert target.read_text() == "old" and elsewhere.read_text() == "not ours" and not journal.exists()


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc, a folder no file can be made in")
def test_a_folder_that_takes_no_files_is_named_with_the_target_and_found_before_any_work(tmp_path, capsys):
    """/proc allows root by its permissions yet creates nothing: the error names the file asked
    for (it named deik's hidden temporary file), and a command refuses --out there before it
    starts (it refused only after the whole clean-up)."""
    from deik.cli.app import main

    with pytest.raises(OSError, match=r"cannot write it: .*'/proc/out\.txt'"):
        atomic.write_text_atomically("/proc/out.txt", "x")
    clip = tmp_path / "toy.bvh"
    clip.write_text(
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
        "  End Site\n  {\n    OFFSET 0 1 0\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.033333\n0 0 0\n"
    )
    assert main(["clip", str(clip), "--out", "/proc/out.bvh"]) == 2
    err = capsys.readouterr().err
    assert err == "deik: error: --out: cannot write in folder '/proc' (No such file or directory); choose another\n"

"""A folder of clips: which files are clips, which are skipped, and the output folders."""

from __future__ import annotations

import os

from deik.errors import InputError
from deik.io.files import FilePath

CLIP_SUFFIX = ".bvh"


def find_clips(folder: FilePath) -> tuple[list[str], list[str]]:
    """(paths of every *.bvh file directly in `folder`, sorted by name; names of the other
    entries, which are skipped: other files, sub-folders (not searched), hidden files).
    ValueError naming the folder when it holds no clip."""
    entries = sorted(os.listdir(folder))
    clips = [
        os.path.join(folder, name)
        for name in entries
        if not name.startswith(".")
        and os.path.splitext(name)[1].lower() == CLIP_SUFFIX
        and os.path.isfile(os.path.join(folder, name))
    ]
    taken = {os.path.basename(path) for path in clips}
    others = [name for name in entries if name not in taken]
    if not clips:
        shown = ", ".join(others[:5]) + (", ..." if len(others) > 5 else "")
        raise InputError(
            f"{folder}: no {CLIP_SUFFIX} clips in this folder (sub-folders are not searched)"
            + (f"; it holds {shown}" if others else "; it is empty")
        )
    stems = {}
    for path in clips:
        stem = os.path.splitext(os.path.basename(path))[0]
        if stem in stems:
            raise InputError(
                f"{folder}: {os.path.basename(stems[stem])} and {os.path.basename(path)} would write the same "
                "outputs; rename one of them"
            )
        stems[stem] = path
    return clips, others


def output_folder(flag: str, folder: str, inputs: str, create: bool = True) -> str:
    """The absolute output `folder` of `flag`, created (with `create`) when its parent exists;
    InputError when the parent is missing, it is a file, or it is the `inputs` folder (outputs
    would replace or mix with the clips). Check every folder with create=False before creating
    any, so that a refused run leaves no folder behind."""
    path = os.path.abspath(folder)
    if os.path.exists(path) and not os.path.isdir(path):
        raise InputError(f"{flag} {folder!r} is a file; with a folder of clips, {flag} names a folder")
    if not os.path.isdir(os.path.dirname(path)):
        raise InputError(f"{flag}: folder {os.path.dirname(path)!r} does not exist; create it first")
    if os.path.isdir(path) and os.path.samefile(path, inputs):
        raise InputError(f"{flag} {folder!r} is the folder of the input clips; write the outputs to another folder")
    if not os.access(path if os.path.isdir(path) else os.path.dirname(path), os.W_OK | os.X_OK):
        raise InputError(f"{flag}: folder {folder!r} is not writable (or cannot be made); choose another folder")
    if create:
        os.makedirs(path, exist_ok=True)
    return path

"""Atomic file writes: a reader sees the old file or the complete new one, never a part."""

from __future__ import annotations

import json
import os
import uuid


def save_atomically(path, write) -> None:
    """Call write(temporary_path) to create a file beside `path`, then move it onto `path`;
    on failure the temporary file is removed and `path` is left as it was."""
    folder, name = os.path.split(os.path.abspath(path))
    stem, extension = os.path.splitext(name)
    temporary = os.path.join(folder, f".{stem}.{uuid.uuid4().hex}.tmp{extension}")
    try:
        write(temporary)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def write_text_atomically(path, text: str) -> None:
    """Write `text` (UTF-8) to `path` atomically."""
    def write(temporary):
        with open(temporary, "w", encoding="utf-8") as file:
            file.write(text)

    save_atomically(path, write)


def write_json_atomically(path, data) -> None:
    """Write `data` as indented JSON to `path` atomically."""
    write_text_atomically(path, json.dumps(data, indent=2) + "\n")

"""One kernel compiled by two processes (deik.backends.sharing): which types a subtree's root is
compiled for, and the claims that keep the two from compiling a function twice or waiting for
ever. The whole exchange, and that it leaves the answers bit for bit the same, is tested on a real
cold compile in tests/backends/test_compiling.py."""

import os
import subprocess
import sys
import types

import pytest
from numba.core import types as nbtypes

from deik.backends import sharing


def _callee(*args):
    return args


def _caller(a, b, c):
    x = b > 0
    return _callee(c, x, a)


def test_a_roots_types_are_those_its_caller_passes():
    signature = (nbtypes.int32, nbtypes.float64, nbtypes.float32)
    found = sharing.call_signature(_caller, "_callee", signature, {"x": nbtypes.boolean})
    assert found == (nbtypes.float32, nbtypes.boolean, nbtypes.int32)
    with pytest.raises(LookupError, match="does not call"):
        sharing.call_signature(_caller, "_absent", signature, {})


def _dispatcher(name: str):
    return types.SimpleNamespace(py_func=types.SimpleNamespace(__module__="deik.test", __qualname__=name))


def test_a_failed_compile_releases_its_claim_and_a_dead_owners_claim_is_taken_over(tmp_path):
    with sharing.through(tmp_path):
        assert sharing.active()

        def fails():
            raise RuntimeError("typing failed")

        with pytest.raises(RuntimeError, match="typing failed"):
            sharing.compile_once(_dispatcher("f"), (nbtypes.int64,), fails)
        assert not list(tmp_path.glob("*.lock"))  # the other process may compile it now
        dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
        lock = tmp_path / "held.lock"
        lock.write_text(dead.stdout.strip())
        assert sharing._claim(tmp_path / "held.bin", lock)  # its owner has exited: claimed here
        assert lock.read_text() == str(os.getpid())
        (tmp_path / "done.bin").write_bytes(b"")
        assert not sharing._claim(tmp_path / "done.bin", tmp_path / "done.lock")  # there to load
    assert not sharing.active()


def test_a_claim_held_longer_than_the_limit_is_compiled_here_as_well(tmp_path, monkeypatch):
    monkeypatch.setattr(sharing, "WAIT_LIMIT", 0.05)
    lock = tmp_path / "slow.lock"
    lock.write_text(str(os.getpid()))  # alive, never done
    assert sharing._claim(tmp_path / "slow.bin", lock)

"""One kernel compiled by two processes: the linked functions each compiles reach the other
through a folder, so that a first solve's DE kernel, most of a cold start, uses two cores.

Numba compiles a kernel's call tree depth first, in one thread. While a worker compiles a DE
kernel, another compiles a subtree of it from its root (deik.backends.compiling.PartJob); inside
`through(folder)`, each process claims a linked function (deik.backends.linking) with a lock file
before compiling it and writes it to the folder once lowered: its LLVM bitcode (everything it
links included), function descriptor, environment and signature. A function the other process
has claimed is waited for and loaded, not compiled again. The call graph has no cycles, so the
two never wait on each other; a claim whose process has died, or whose compile failed, is
released, and a wait longer than WAIT_LIMIT compiles the function here. The folder lives only as
long as one compile: no entry outlives the code that wrote it.

The machine code is the same: the kernel's library links the same LLVM modules and optimises
them in one module as before (tests/backends/test_compiling.py compares answers). This uses
Numba internals (code libraries, function descriptors, compile results) as they are in Numba
0.60-0.68.
"""

from __future__ import annotations

import ast
import copy
import hashlib
import inspect
import os
import pickle
import textwrap
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

POLL = 0.005  # seconds between looks at a function the other process compiles
WAIT_LIMIT = 300.0  # seconds after which a function still claimed is compiled here as well

_folder: Path | None = None
loaded: list[str] = []  # names of the linked functions this process loaded from the other


@contextmanager
def through(folder: str | os.PathLike) -> Iterator[None]:
    """While the body runs, linked functions are claimed, shared and loaded through `folder`."""
    global _folder
    _folder = Path(folder)
    try:
        yield
    finally:
        _folder = None


def active() -> bool:
    """Whether this process shares its linked functions now."""
    return _folder is not None


def compile_once(dispatcher, args: tuple, compile_here: Callable[[], None]) -> None:
    """Give the link-only `dispatcher` an overload for `args`: loaded when the other process has
    compiled it (after waiting while it does), else `compile_here()` and published."""
    key = hashlib.sha256(
        f"{dispatcher.py_func.__module__}:{dispatcher.py_func.__qualname__}:{args!r}".encode()
    ).hexdigest()[:32]
    result, lock = _folder / f"{key}.bin", _folder / f"{key}.lock"
    if not _claim(result, lock):
        dispatcher.add_overload(_load(dispatcher, result.read_bytes()))
        loaded.append(dispatcher.py_func.__qualname__)
        return
    try:
        compile_here()
        _publish(result, dispatcher.overloads[args])
    except BaseException:
        lock.unlink(missing_ok=True)  # the other process compiles it itself
        raise


def _claim(result: Path, lock: Path) -> bool:
    """True once this process has claimed the function, False once `result` is there to load."""
    waited = time.monotonic()
    while not result.exists():
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            if not _owner_alive(lock) or time.monotonic() - waited > WAIT_LIMIT:
                lock.unlink(missing_ok=True)
                waited = time.monotonic()
                continue
            time.sleep(POLL)
            continue
        os.write(fd, str(os.getpid()).encode())
        os.close(fd)
        return True
    return False


def _owner_alive(lock: Path) -> bool:
    """Whether the process that wrote `lock` still runs (a lock being written counts as alive;
    on Windows, where signal 0 would end the process, every owner does: WAIT_LIMIT still holds)."""
    if os.name == "nt":
        return True
    try:
        pid = int(lock.read_text())
    except (OSError, ValueError):
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    return True


def _publish(result: Path, cres) -> None:
    """Write a linked function's compile result to `result` in one step."""
    from numba.core import serialize

    library = cres.library
    library._ensure_finalized()  # links its callees in: what its callers would do first
    fndesc = copy.copy(cres.fndesc)
    fndesc.typemap = fndesc.calltypes = None  # typing tables: not needed to call it, not picklable
    payload = (
        library.name,
        library._final_module.as_bitcode(),
        tuple(library._reload_init),
        fndesc,
        cres.environment,
        cres.signature,
    )
    part = result.with_suffix(f".{os.getpid()}.part")
    part.write_bytes(serialize.dumps(payload))
    os.replace(part, result)


def _load(dispatcher, data: bytes):
    """The compile result `_publish` wrote, its library link-only LLVM for callers to link."""
    from llvmlite import binding as ll
    from numba.core import compiler

    name, bitcode, reload_init, fndesc, environment, signature = pickle.loads(data)
    for init in reload_init:  # the parallel back-end a parfor calls, as Numba's cache does
        init()
    library = dispatcher.library_class(dispatcher.targetctx.codegen(), name)
    library._final_module = ll.parse_bitcode(bitcode)
    library._reload_init.update(reload_init)
    library._finalize_final_module()
    return compiler.CompileResult(
        typing_context=dispatcher.typingctx,
        target_context=dispatcher.targetctx,
        entry_point=None,
        typing_error=None,
        type_annotation=None,
        signature=signature,
        objectmode=False,
        lifted=(),
        fndesc=fndesc,
        library=library,
        call_helper=None,
        environment=environment,
        metadata=None,
        reload_init=list(reload_init),
        referenced_envs=None,
    )


def call_signature(caller: Callable, callee: str, signature: tuple, local_types: dict) -> tuple:
    """The argument types of the first call to `callee` in the plain function `caller`, given
    the types of the caller's parameters (`signature`) and of the locals the call passes
    (`local_types`): what the caller's compile asks `callee` for."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(caller)))
    known = dict(zip(inspect.signature(caller).parameters, signature)) | local_types
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == callee:
            return tuple(known[argument.id] for argument in node.args)
    raise LookupError(f"{caller.__qualname__} does not call {callee}")

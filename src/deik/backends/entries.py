"""Entry points: the cached njit trampoline Python calls for a linked function, and the small,
fast form its machine code is cached in.

A linked function (deik.backends.linking) has no machine code of its own; Python calls it
through a one-line njit trampoline of the same name, file and first line, whose library links
the whole call tree and is cached on disk (Numba's cache with deik's stamped locators,
deik.backends.targets). An Entry is that trampoline, made without the function it calls: the
compiled namespace is only built (`resolve`) when a signature must be compiled, so loading a
cached kernel builds no dispatchers for the device maths.

Loading is what every warm command pays, so the cache keeps less than Numba's own: the machine
code and the names of the symbols it defines, not the optimised LLVM bitcode Numba keeps for
linking a function into others (nobody links a trampoline; parsing it took a tenth of a second
per kernel), and a load skips the typing and lowering registries Numba refreshes first (another
tenth): machine code needs neither, and a compile refreshes them itself. This uses Numba
internals (its cache implementation, code libraries and compile results) as they are in Numba
0.60-0.68; `ready_signatures` and `compile_seconds` read private parts the same way.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable

import numba
from numba.core import caching, compiler, registry, sigutils
from numba.core.compiler_lock import global_compiler_lock
from numba.core.runtime import rtsys

CACHE_KIND = "deik-object"  # the library form of deik's cache entries: (machine code, symbol names)
_ENTRIES = {}  # (file, qualname) -> Entry


class _KernelCacheImpl(caching.CompileResultCacheImpl):
    """Numba's compile-result caching, with the library kept as machine code and symbol names."""

    def reduce(self, cres):
        payload = cres._reduce()
        name, _, (object_code, _) = payload[0]
        module = cres.library._final_module
        symbols = sorted(
            g.name for group in (module.functions, module.global_variables) for g in group if not g.is_declaration
        )
        return ((name, CACHE_KIND, (object_code, symbols)), *payload[1:])

    def rebuild(self, target_context, payload):
        (name, kind, data), fndesc, env, signature, objectmode, lifted, typeann, reload_init, envs = payload
        if kind != CACHE_KIND:  # written by Numba's own cache: load it Numba's way
            return super().rebuild(target_context, payload)
        for init in reload_init:
            init()
        codegen = target_context.codegen()
        library = codegen.create_library(name)
        library.enable_object_caching()
        library._set_compiled_object(data[0])
        library._finalize_final_module()
        codegen._engine._defined_symbols.update(data[1])
        cres = compiler.CompileResult(
            target_context=target_context,
            typing_context=target_context.typing_context,
            library=library,
            environment=env,
            entry_point=target_context.get_executable(library, fndesc, env),
            fndesc=fndesc,
            type_annotation=typeann,
            signature=signature,
            objectmode=objectmode,
            lifted=lifted,
            typing_error=None,
            call_helper=None,
            metadata=None,
            reload_init=reload_init,
            referenced_envs=envs,
        )
        for referenced in envs:
            library.codegen.set_env(referenced.env_name, referenced)
        return cres


class KernelCache(caching.FunctionCache):
    """An entry's disk cache: Numba's, in deik's form (the module doc)."""

    _impl_class = _KernelCacheImpl

    def load_overload(self, sig, target_context):
        # of target_context.refresh() only Numba's runtime (NRT), which the machine code calls:
        # loading it needs no typing or lowering registry
        rtsys.initialize(target_context)
        return self._load_overload(sig, target_context)


class Entry(registry.CPUDispatcher):
    """The trampoline of a linked function: an njit function `qualname(args): return
    _target(args)`, compiled and cached per signature, whose `_target` (the linked function) is
    only resolved when a signature must be compiled."""

    @classmethod
    def of(cls, func, qualname: str, resolve: Callable[[], object]) -> Entry:
        """The Entry of `func` (a plain function: its module, name, parameters, file and first
        line) under `qualname` (its cache files' name), calling what `resolve()` returns; one
        per (file, qualname) in a process."""
        key = (func.__code__.co_filename, qualname)
        if key not in _ENTRIES:
            _ENTRIES[key] = cls._make(func, qualname, resolve)
        return _ENTRIES[key]

    @classmethod
    def _make(cls, func, qualname: str, resolve: Callable[[], object]) -> Entry:
        parameters = inspect.signature(func).parameters.values()
        if any(p.default is not p.empty or p.kind is not p.POSITIONAL_OR_KEYWORD for p in parameters):
            raise TypeError(f"{func.__qualname__}: a linked function takes plain positional arguments only")
        names = ", ".join(p.name for p in parameters)
        code = func.__code__
        source = "\n" * (code.co_firstlineno - 1) + f"def {func.__name__}({names}):\n    return _target({names})\n"
        namespace = {"__name__": func.__module__}
        exec(compile(source, code.co_filename, "exec"), namespace)
        trampoline = namespace[func.__name__]
        trampoline.__qualname__ = qualname
        entry = cls(trampoline, targetoptions={"nopython": True, "nogil": True})
        entry._resolve = resolve
        entry._cache = KernelCache(trampoline)
        return entry

    def compile(self, sig):
        with global_compiler_lock:
            args, _ = sigutils.normalize_signature(sig)
            existing = self.overloads.get(tuple(args))
            if existing is not None:
                return existing.entry_point
            cres = self._cache.load_overload(sig, self.targetctx)
            if cres is not None:
                self._cache_hits[sig] += 1
                self.add_overload(cres)
                return cres.entry_point
            self.py_func.__globals__["_target"] = self._resolve()
        return super().compile(sig)

    def entry_point(self, args: tuple):
        """The compiled function for these arguments (loaded or compiled first), which Python
        calls directly: the dispatcher's own call types every argument every time."""
        sig = tuple(numba.typeof(a) for a in args)
        self.compile(sig)
        return self.overloads[sig].entry_point

    def ready_signatures(self) -> list[tuple]:
        """Argument types (tuples of Numba types) compiled in this process or cached on disk for
        this machine. If Numba's cache index cannot be read, only this process's own count (the
        worst outcome is an unneeded note)."""
        ready = list(self.overloads)
        try:
            index = self._cache._cache_file._load_index()
            magic = self.targetctx.codegen().magic_tuple()
            ready += [tuple(key[0]) for key in index if key[1] == magic]
        except Exception:  # no cache (read-only, disabled) or another Numba's internals
            pass
        return ready

    def compile_seconds(self) -> dict:
        """{argument types: seconds} of this process's compiles (not cache loads)."""
        timers = {sig: (cres.metadata or {}).get("timers", {}) for sig, cres in self.overloads.items()}
        return {sig: t["compiler_lock"] for sig, t in timers.items() if "compiler_lock" in t}

    @property
    def cache_folder(self) -> str | None:
        """The folder of this entry's disk cache (None when it has none)."""
        return getattr(self._cache, "_cache_path", None)

"""How the CPU kernels are compiled: each function called from Python once, everything it calls
linked in.

Numba gives every jitted function a library of its own: on first use it optimises the function's
LLVM module together with everything the function calls (linked in) and compiles that to machine
code. The device maths is a deep call tree (launch -> run_generations -> breed chunk ->
breed_individual -> evaluate -> term_error -> forward_kinematics ...), so a cold compile optimised
and compiled the same code again at every level of it, and each parallel loop (parfor) three more
times in the wrappers Numba builds around its body: that repeated LLVM work was about half of a
first solve's compile (docs/performance.md).

`linked` functions are lowered to LLVM IR only, with their parfors, and linked unoptimised into
their callers. A call from Python goes through a one-line trampoline, an ordinary cached njit
function, whose library links the whole tree: it alone is optimised (the optimiser inlines and
simplifies the linked code as before, so the machine code is unchanged) and compiled, once per
signature, and cached on disk. This uses Numba internals (its code libraries and function
compiler) as they are in Numba 0.60-0.68.
"""

from __future__ import annotations

import importlib.util
import sys
from contextlib import contextmanager

from numba.core import codegen, compiler, dispatcher, registry, sigutils
from numba.core import types as numba_types
from numba.core.compiler_lock import global_compiler_lock

from deik.backends import sharing
from deik.backends.entries import Entry


def _import_numba_arraymath_without_scipy() -> None:
    """Import Numba's NumPy-array lowering with scipy.linalg hidden. It imports that (0.4 s,
    the largest part of a warm command) only to learn whether BLAS exists, for the inner
    product of np.correlate and np.convolve; the kernels use no BLAS. The flag is then set to
    what it would have found, and np.dot or np.linalg still import SciPy when they compile."""
    if "numba.np.arraymath" in sys.modules or "scipy.linalg" in sys.modules:
        return
    sys.modules["scipy.linalg"] = None  # `import scipy.linalg...` raises ImportError meanwhile
    try:
        from numba.np import arraymath
    finally:
        del sys.modules["scipy.linalg"]
    arraymath._HAVE_BLAS = importlib.util.find_spec("scipy") is not None


_import_numba_arraymath_without_scipy()

# names Numba gives the libraries of a parfor's body and of its two wrappers (numba.parfors,
# numba.np.ufunc); they are only ever linked into the function holding the loop. Should Numba
# rename them, they are compiled as before: slower to compile, the same code.
PARFOR_LIBRARIES = ("__numba_parfor_gufunc", "<numba.np.ufunc.wrappers._GufuncWrapper", "parallelgufuncwrapper")


class LinkOnlyLibrary(codegen.JITCodeLibrary):
    """A library kept as LLVM IR for its callers to link in: no module-level optimisation and no
    machine code of its own."""

    def _optimize_final_module(self):
        pass

    def _finalize_final_module(self):
        self._finalize_dynamic_globals()
        self._verify_declare_only_symbols()
        self._finalized = True


@contextmanager
def _parfors_link_only(target_codegen):
    """While a linked function compiles, the libraries Numba creates for its parfors are
    link-only too (their code is never called but from the function's own)."""
    if "create_library" in vars(target_codegen):  # already inside a linked function's compile
        yield
        return
    create = target_codegen.create_library

    def create_library(name, **kwargs):
        if str(name).startswith(PARFOR_LIBRARIES):
            return LinkOnlyLibrary(target_codegen, name, **kwargs)
        return create(name, **kwargs)

    target_codegen.create_library = create_library
    try:
        yield
    finally:
        del target_codegen.create_library


class _LinkOnlyCompiler(dispatcher._FunctionCompiler):
    """Numba's function compiler, lowering into a LinkOnlyLibrary without Python wrappers."""

    def _compile_core(self, args, return_type):
        flags = compiler.Flags()
        self.targetdescr.options.parse_as_flags(flags, self.targetoptions)
        flags.no_compile = flags.no_cpython_wrapper = flags.no_cfunc_wrapper = True
        context = self.targetdescr.target_context
        with _parfors_link_only(context.codegen()):
            cres = compiler.compile_extra(
                self.targetdescr.typing_context,
                context,
                self.py_func,
                args=args,
                return_type=return_type,
                flags=flags,
                locals=self.locals,
                library=LinkOnlyLibrary(context.codegen(), self.py_func.__qualname__),
                pipeline_class=self.pipeline_class,
            )
        if cres.typing_error is not None:
            raise cres.typing_error
        return cres


class _LinkKey:
    """What callers look a link-only overload up by (it has no machine-code entry point)."""

    def __init__(self, name: str):
        self.name = name

    def __repr__(self) -> str:
        return f"<linked {self.name}>"


class LinkOnlyDispatcher(registry.CPUDispatcher):
    """A function compiled only into the jitted functions that call it; constant arguments are
    typed as their plain types, so `f(x, 0)` and `f(x, 1)` share one compile. Called from
    Python, it runs `entry`, its cached trampoline (deik.backends.entries)."""

    library_class = LinkOnlyLibrary

    def __init__(self, py_func, targetoptions, original, entry_name: str):
        """py_func: the copy to compile (deik.backends.targets.compile_namespace); original: the
        function it copies, whose module, file and first line the entry takes; entry_name:
        the entry's qualified name (its cache files' name)."""
        super().__init__(py_func, targetoptions=targetoptions)
        self._compiler = _LinkOnlyCompiler(py_func, self.targetdescr, targetoptions, self.locals, compiler.Compiler)
        self._original, self._entry_name = original, entry_name

    def get_call_template(self, args, kws):
        return super().get_call_template(tuple(numba_types.unliteral(a) for a in args), kws)

    def compile(self, sig):
        """Numba's compile, except that while a kernel compiles in two processes a signature
        the other compiles is loaded from it (deik.backends.sharing)."""
        if not sharing.active():
            return super().compile(sig)
        with global_compiler_lock:
            args = tuple(sigutils.normalize_signature(sig)[0])
            if args not in self.overloads:
                sharing.compile_once(self, args, lambda: super(LinkOnlyDispatcher, self).compile(sig))
            return self.overloads[args].entry_point

    def add_overload(self, cres):
        key = _LinkKey(self.py_func.__qualname__)
        self.targetctx.insert_user_function(key, cres.fndesc, [cres.library])
        self.overloads[tuple(cres.signature.args)] = cres._replace(entry_point=key)

    @property
    def entry(self) -> Entry:
        """The cached entry point that Python calls run (deik.backends.entries)."""
        return Entry.of(self._original, self._entry_name, lambda: self)

    def __call__(self, *args):
        return self.entry(*args)


def linked(**options):
    """Decorator: marks a function to be compiled as a LinkOnlyDispatcher with njit `options`
    (parallel, nogil, _nrt, forceinline) when deik.backends.targets.compile_namespace puts a
    copy of it into a compiled namespace; the function itself stays plain Python."""

    def mark(func):
        func.linked_options = {"nopython": True, **options}
        return func

    return mark

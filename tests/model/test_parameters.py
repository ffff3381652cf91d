"""No function outside the compiled kernels takes more than 8 parameters: what travels together
travels as one record (a goal's row, a clip's goals, a back-end's inputs). Counted over deik, the
benchmarks and the judge: positional and keyword parameters, *args and **kwargs one each, self and cls not."""

import ast
from pathlib import Path

import deik

MAX_PARAMETERS = 8
ROOT = Path(__file__).resolve().parents[2]
ROOTS = {"deik": Path(deik.__file__).parent, "benchmarks": ROOT / "benchmarks", "judging": ROOT / "judging"}
# The compiled kernels, exempt: Numba types every argument of a kernel, and a record of arrays
# would be a tuple each call unpacks. The device maths is compiled whole for every target
# (backends/targets.py); elsewhere a kernel is a function under one of these decorators
# (backends/linking.linked, numba.njit, numba.cuda.jit).
COMPILED_FOLDERS = ("deik/device/",)
COMPILED_DECORATORS = {"linked", "njit", "jit"}
# Host-side functions allowed over the limit, with their count, until they are narrowed: an
# entry that no longer exceeds it, or is gone, fails the test, so that the list only shrinks
# (empty: every host-side function takes at most 8 parameters).
NOT_YET: dict[str, int] = {}


def _decorators(node) -> set[str]:
    """The names of a function's decorators (`@cuda.jit` -> "jit", `@linked()` -> "linked")."""
    names = set()
    for decorator in node.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        names.add(target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", ""))
    return names


def count(node) -> int:
    """The parameters of a function node: positional and keyword ones, *args and **kwargs one
    each, a leading self or cls not."""
    a = node.args
    named = [arg.arg for arg in a.posonlyargs + a.args]
    return (
        len(named)
        + len(a.kwonlyargs)
        + (a.vararg is not None)
        + (a.kwarg is not None)
        - (named[:1] in (["self"], ["cls"]))
    )


def parameter_counts() -> dict[str, int]:
    """{"root/file.py:function": parameters} of every function over the limit outside the
    compiled kernels (a name used twice in a file keeps its largest count)."""
    counts = {}
    for root, folder in ROOTS.items():
        for path in folder.rglob("*.py"):
            where = f"{root}/{path.relative_to(folder).as_posix()}"
            if where.startswith(COMPILED_FOLDERS):
                continue
            for node in ast.walk(ast.parse(path.read_text())):
                if (
                    not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
                    or _decorators(node) & COMPILED_DECORATORS
                ):
                    continue
                n = count(node)
                if n > MAX_PARAMETERS:
                    key = f"{where}:{node.name}"
                    counts[key] = max(n, counts.get(key, 0))
    return counts


def test_no_function_outside_the_kernels_takes_more_than_eight_parameters():
    counts = parameter_counts()
    assert {key: n for key, n in counts.items() if key not in NOT_YET} == {}
    narrowed = {key for key in NOT_YET if key not in counts}
    assert narrowed == set(), "narrowed since: remove them from NOT_YET"


def test_the_count_and_the_exemptions():
    source = "def f(a, b, /, c, *d, e, **g): pass\nclass C:\n    @numba.njit\n    def m(self, a, b): pass"
    f, c = ast.parse(source).body
    assert count(f) == 6 and count(c.body[0]) == 2 and _decorators(c.body[0]) == {"njit"}
    counts = parameter_counts()  # the kernels take 10 to 15 parameters: none may show
    assert not any(key.startswith("deik/device/") or "cpu_kernels.py" in key for key in counts)

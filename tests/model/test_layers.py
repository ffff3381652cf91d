"""The package layers of docs/architecture.md: every deik module imports only from its own
package and the layers below it, so the data flows one way and no import cycle can form;
nothing above the solver reaches into the device maths or the back-ends; no two source files
share a name; no module is over 450 lines. Beside the package, the independent judge (judging/)
imports nothing of deik, so that what it measures is not deik measuring itself."""

import ast
from collections import Counter
from pathlib import Path

import deik

LAYERS = [
    "errors",
    "suggest",
    "console",
    "memory",
    "model",
    "io",
    "objectives",
    "device",
    "backends",
    "solver",
    "cleanup",
    "retargeting",
    "viz",
    "library",
    "experiments",
    "cli",
]
SOURCE = Path(deik.__file__).parent
KERNELS = ("device", "backends")  # the layers only deik.solver may call
# experiments/serial_compiled.py is a compiled kernel itself: the paper's serial Algorithm 1 built
# from the device maths, which it calls directly as the back-ends do (and its host side, beside it)
REACHES_KERNELS = {"experiments/serial_compiled.py"}


def _imports(path: Path):
    """(line, imported deik module) of every import in a source file, lazy ones included."""
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "deik":
            yield node.lineno, node.module
            for alias in node.names:
                yield node.lineno, f"{node.module}.{alias.name}"
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "deik":
                    yield node.lineno, alias.name


def test_the_judge_shares_no_code_with_deik():
    judging = Path(__file__).resolve().parents[2] / "judging"
    modules = sorted(judging.glob("*.py"))
    assert len(modules) >= 5, modules
    found = [f"{path.name}:{line} {name}" for path in modules for line, name in _imports(path)]
    assert not found, found


def test_every_module_belongs_to_a_layer():
    tops = {p.relative_to(SOURCE).parts[0].removesuffix(".py") for p in SOURCE.rglob("*.py")}
    assert tops - {"__init__", "__main__"} <= set(LAYERS)


def test_imports_go_only_downwards():
    upward = []
    for path in SOURCE.rglob("*.py"):
        own = path.relative_to(SOURCE).parts[0].removesuffix(".py")
        if own not in LAYERS:
            continue
        for line, module in _imports(path):
            parts = module.split(".")
            if len(parts) > 1 and parts[1] in LAYERS and LAYERS.index(parts[1]) > LAYERS.index(own):
                upward.append(f"{path.relative_to(SOURCE)}:{line} imports {module}")
    assert upward == []


def test_nothing_above_the_solver_reaches_into_the_kernels():
    above = LAYERS[LAYERS.index("solver") + 1 :]
    reach = []
    for path in SOURCE.rglob("*.py"):
        where = path.relative_to(SOURCE)
        if where.parts[0].removesuffix(".py") not in above or where.as_posix() in REACHES_KERNELS:
            continue
        for line, module in _imports(path):
            parts = module.split(".")
            if len(parts) > 1 and parts[1] in KERNELS:
                reach.append(f"{where}:{line} imports {module}")
    assert reach == []


def test_no_source_file_name_is_used_twice():
    names = Counter(p.name for p in SOURCE.rglob("*.py") if p.name not in ("__init__.py", "__main__.py"))
    assert sorted(name for name, count in names.items() if count > 1) == []


def test_no_module_is_longer_than_a_reader_can_hold():
    """One module, one job: none over 450 lines (a longer one splits along its jobs)."""
    long = {str(p.relative_to(SOURCE)): n for p in SOURCE.rglob("*.py") if (n := len(p.read_text().splitlines())) > 450}
    assert long == {}

"""The package layers of docs/architecture.md: every deik module imports only from its own
package and the layers above it, so the data flows one way and no import cycle can form."""

import ast
from pathlib import Path

import deik

LAYERS = [
    "suggest",
    "console",
    "errors",
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

"""Annotations on the public API (py.typed promises them): every function and public method of
every module a user may import annotates each parameter and its return value, and the
annotations of everything in deik.__all__ resolve to real types. deik.device and deik.backends are
left out: they are the engine's inside (docs/architecture.md), Numba-compiled device maths and the host code that
hands it the packed NamedTuples of device/layout.py, called only by deik.solver."""

import ast
import inspect
import typing
from pathlib import Path

import pytest

import deik

SOURCE = Path(deik.__file__).parent
INSIDE = ("device", "backends")  # the packages no user calls


def _inside(path: Path) -> bool:
    return path.relative_to(SOURCE).parts[0] in INSIDE


def _public_functions(tree: ast.Module):
    """(qualified name, FunctionDef, is a method) of the public functions and methods of a module."""
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and not node.name.startswith("_"):
            yield node.name, node, False
        elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            for item in node.body:
                if isinstance(item, ast.FunctionDef) and (not item.name.startswith("_") or item.name == "__init__"):
                    yield f"{node.name}.{item.name}", item, True


def _missing(function: ast.FunctionDef, method: bool) -> list[str]:
    arguments = function.args
    names = arguments.posonlyargs + arguments.args + arguments.kwonlyargs
    if method and not any(isinstance(d, ast.Name) and d.id == "staticmethod" for d in function.decorator_list):
        names = names[1:]  # self or cls
    names += [a for a in (arguments.vararg, arguments.kwarg) if a is not None]
    missing = [a.arg for a in names if a.annotation is None]
    if function.returns is None and function.name != "__init__":
        missing.append("return")
    return missing


def test_every_public_function_is_annotated():
    unannotated = []
    for path in sorted(SOURCE.rglob("*.py")):
        if _inside(path):
            continue
        for name, function, method in _public_functions(ast.parse(path.read_text())):
            missing = _missing(function, method)
            if missing:
                unannotated.append(f"{path.relative_to(SOURCE)}:{function.lineno} {name}: {', '.join(missing)}")
    assert unannotated == []


def _callables(obj):
    """obj itself (a function) or a class's public methods and __init__ defined on it."""
    if inspect.isfunction(obj):
        yield obj.__qualname__, obj
        return
    for name, member in vars(obj).items():
        function = member.fget if isinstance(member, property) else getattr(member, "__func__", member)
        if inspect.isfunction(function) and (not name.startswith("_") or name == "__init__"):
            yield f"{obj.__name__}.{name}", function


@pytest.mark.parametrize("name", deik.__all__)
def test_the_exported_api_s_annotations_resolve(name):
    for qualified, function in _callables(getattr(deik, name)):
        hints = typing.get_type_hints(function)  # raises on a name that does not resolve
        parameters = [p for p in inspect.signature(function).parameters if p not in ("self", "cls")]
        assert set(parameters) <= set(hints), f"{qualified}: {sorted(set(parameters) - set(hints))} unannotated"


def _type_checking_imports() -> dict[str, str]:
    """{name: module} of the `if TYPE_CHECKING:` imports in deik/__init__.py, each checked to
    import the name as itself (an explicit re-export)."""
    tree = ast.parse((SOURCE / "__init__.py").read_text())
    (block,) = [node for node in tree.body if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING"]
    imported = {}
    for node in block.body:
        assert isinstance(node, ast.ImportFrom), ast.unparse(node)
        for alias in node.names:
            assert alias.asname == alias.name, f"{ast.unparse(node)}: import it `as {alias.name}`"
            imported[alias.name] = node.module
    return imported


def test_the_type_checker_sees_every_lazy_name_from_its_module():
    """A type checker does not run deik's PEP 562 __getattr__: it reads the TYPE_CHECKING imports,
    which must name every public name from the module the lazy loader imports it from."""
    assert _type_checking_imports() == deik._EXPORTS


def test_settings_keywords_have_the_settings_fields_types():
    from deik.solver.settings import Settings, SettingsChanges

    assert typing.get_type_hints(SettingsChanges) == typing.get_type_hints(Settings)

"""The shape of the code, checked with the standard library's parser: the layers of
docs/architecture.md import one way, no package imports itself in a circle, no module
reaches into another package's private names, and the on-sensor pipeline is made of
rooms, not one large class."""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

#: Packages whose modules may use no private name of another module at all.
NO_FRIENDS = ("ppaloc.onsensor", "ppaloc.localise")
#: The largest class in these packages, in lines.
ROOMS = {"ppaloc.onsensor": 400}


def _modules() -> dict[str, ast.Module]:
    out = {}
    for path in sorted((SRC / "ppaloc").rglob("*.py")):
        parts = path.relative_to(SRC).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    return out


MODULES = _modules()


def _package(module: str) -> str:
    """The package a module belongs to (``ppaloc.sim.engines.fused`` -> ``ppaloc.sim``)."""
    parts = module.split(".")
    return ".".join(parts[:2]) if len(parts) > 2 or module in _PACKAGES else "ppaloc"


_PACKAGES = {m for m in MODULES if (SRC / Path(*m.split(".")) / "__init__.py").exists()}


def _top_level_imports(module: str, tree: ast.Module) -> set[str]:
    """The ppaloc modules ``module`` imports when it is imported (not inside functions,
    not under ``if TYPE_CHECKING``)."""
    out: set[str] = set()

    def visit(body: list[ast.stmt]) -> None:
        for node in body:
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                continue
            if isinstance(node, ast.If | ast.Try):
                visit(node.body)
                visit(getattr(node, "orelse", []))
                for handler in getattr(node, "handlers", []):
                    visit(handler.body)
            elif isinstance(node, ast.Import):
                out.update(a.name for a in node.names if a.name.startswith("ppaloc"))
            elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("ppaloc"):
                base = node.module
                for a in node.names:  # ``from ppaloc.x import y`` may name a module y
                    sub = f"{base}.{a.name}"
                    out.add(sub if sub in MODULES else base)

    visit(tree.body)
    return {m for m in out if m in MODULES and m != module}


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``graph``, or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def walk(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt) :], nxt]
            if nxt not in state and (found := walk(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := walk(node)):
            return found
    return None


def test_no_import_cycle_inside_a_package():
    graph = {m: _top_level_imports(m, tree) for m, tree in MODULES.items()}
    for package in sorted({_package(m) for m in MODULES}):
        inside = {
            m: {n for n in deps if _package(n) == package and not package.endswith("ppaloc")}
            for m, deps in graph.items()
            if _package(m) == package
        }
        assert _cycle(inside) is None, f"{package}: import cycle {_cycle(inside)}"


def test_a_cycle_is_found_when_there_is_one():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _defined_private_names() -> dict[str, set[str]]:
    """Per module, the private names it defines (functions, classes, attributes it
    assigns, parameters)."""
    out: dict[str, set[str]] = defaultdict(set)
    for module, tree in MODULES.items():
        for node in ast.walk(tree):
            name = None
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                name = node.name
            elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                name = node.id
            elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
                name = node.attr
            elif isinstance(node, ast.arg):
                name = node.arg
            if name and _private(name):
                out[module].add(name)
    return out


def _foreign_private_uses() -> list[tuple[str, str, str]]:
    """``(module, use, owner)``: a private name of another module, imported from it or
    reached as an attribute of something that is not ``self``/``cls``."""
    defined = _defined_private_names()
    uses = []
    for module, tree in MODULES.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("ppaloc"):
                for a in node.names:
                    if _private(a.name):
                        uses.append((module, f"from {node.module} import {a.name}", node.module))
            elif isinstance(node, ast.Attribute) and _private(node.attr):
                if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                    continue
                if node.attr in defined[module]:
                    continue
                for owner, names in defined.items():
                    if owner != module and node.attr in names:
                        uses.append((module, ast.unparse(node), owner))
                        break
    return uses


def test_no_module_uses_another_packages_private_names():
    crossing = [(m, use, o) for m, use, o in _foreign_private_uses() if _package(m) != _package(o)]
    assert crossing == []


@pytest.mark.parametrize("package", NO_FRIENDS)
def test_the_filter_packages_use_no_other_modules_private_names(package):
    used = [(m, use, o) for m, use, o in _foreign_private_uses() if _package(m) == package]
    assert used == []


@pytest.mark.parametrize(("package", "limit"), ROOMS.items())
def test_no_class_is_a_house(package, limit):
    sizes = {
        f"{module}.{node.name}": node.end_lineno - node.lineno + 1  # type: ignore[operator]
        for module, tree in MODULES.items()
        if _package(module) == package
        for node in ast.walk(tree)
        if isinstance(node, ast.ClassDef)
    }
    assert sizes and max(sizes.values()) <= limit, max(sizes.items(), key=lambda kv: kv[1])

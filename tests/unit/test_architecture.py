"""The package's layers (docs/architecture.md): each imports only the layers below it, and no
module imports itself back through others.

The import graph is read from the source with ``ast`` (every import statement, also those
inside functions and ``TYPE_CHECKING`` blocks), so a lazy import cannot hide a wrong direction.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src"
PACKAGE = SRC / "adaptnav"

# Each layer and the layers it may import (besides itself and the package root's __version__).
# Bottom to top; docs/architecture.md has the same table.
ALLOWED: dict[str, set[str]] = {
    "core": set(),
    "models": {"core"},
    "sensors": {"core", "models"},
    "estimation": {"core", "models", "sensors"},
    "compiled": {"core", "models", "sensors", "estimation"},
    "engine": {"core", "models", "sensors", "estimation", "compiled"},
    "mission": {"core", "models", "sensors", "estimation"},
    "sim": {"core", "models", "sensors", "estimation", "mission"},
    "api": {"core", "models", "sensors", "estimation", "compiled", "engine", "mission"},
}
ALLOWED["analysis"] = ALLOWED["api"] | {"api"}
ALLOWED["viz"] = ALLOWED["analysis"] | {"analysis"}
ALLOWED["experiments"] = ALLOWED["viz"] | {"viz", "sim"}
ALLOWED["importers"] = ALLOWED["analysis"] | {"analysis", "sim"}
ALLOWED["cli"] = set(ALLOWED) | {"experiments", "importers", "viz", "sim"}


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(SRC).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _imports(name: str, path: Path) -> Iterator[tuple[str, int]]:
    """(imported adaptnav module, line) for each import in ``path``; ``from P import m`` of a
    submodule ``m`` counts as importing ``P.m``, not the package ``P``."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("adaptnav"):
                    yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            if not module.startswith("adaptnav"):
                continue
            subs = [f"{module}.{a.name}" for a in node.names if f"{module}.{a.name}" in MODULES]
            if len(subs) == len(node.names):
                yield from ((s, node.lineno) for s in subs)
            else:
                yield module, node.lineno


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


GRAPH = {name: sorted(set(_imports(name, path))) for name, path in MODULES.items()}


def test_every_module_is_in_a_layer() -> None:
    layers = {_layer(m) for m in MODULES} - {""}
    assert layers <= set(ALLOWED), f"modules outside the layer table: {layers - set(ALLOWED)}"
    top = sorted(m for m in MODULES if m.count(".") == 1 and MODULES[m].name != "__init__.py")
    assert top == [], f"modules directly under adaptnav/ (put each in its layer): {top}"


@pytest.mark.parametrize("name", sorted(MODULES))
def test_imports_go_downward(name: str) -> None:
    own = _layer(name)
    wrong = [
        f"{MODULES[name].relative_to(SRC)}:{line} imports {target}"
        for target, line in GRAPH[name]
        if _layer(target) not in {own, ""} and _layer(target) not in ALLOWED.get(own, set())
    ]
    assert wrong == [], "\n".join(wrong)


def test_the_package_root_gives_only_the_version() -> None:
    # adaptnav/__init__.py holds only __version__, so importing it pulls in no layer.
    tree = ast.parse((PACKAGE / "__init__.py").read_text(encoding="utf-8"))
    assert not [n for n in ast.walk(tree) if isinstance(n, ast.Import | ast.ImportFrom)]


def test_no_import_cycles() -> None:
    edges = {n: {t for t, _ in GRAPH[n] if t in MODULES and t != n} for n in MODULES}
    state: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def visit(n: str) -> None:
        state[n] = 1
        stack.append(n)
        for t in sorted(edges[n]):
            if state.get(t) == 1:
                cycles.append([*stack[stack.index(t) :], t])
            elif t not in state:
                visit(t)
        stack.pop()
        state[n] = 2

    for n in sorted(edges):
        if n not in state:
            visit(n)
    assert cycles == [], "\n".join(" -> ".join(c) for c in cycles)


def test_the_checker_sees_a_wrong_direction(tmp_path: Path) -> None:
    # The test above must be able to fail: a core module importing the engine is caught.
    path = tmp_path / "x.py"
    path.write_text("def f():\n    from adaptnav.engine.batch import run_batch\n")
    found = list(_imports("adaptnav.core.x", path))
    assert found == [("adaptnav.engine.batch", 2)]
    assert "engine" not in ALLOWED["core"]


def _long_functions(limit: int) -> list[str]:
    """Functions whose body (from the first statement after the docstring) is over ``limit``
    lines, outside the Numba kernels (decorated ``jit``/``jit_inline``)."""
    out = []
    for path in MODULES.values():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            decorators = {ast.unparse(d).split("(")[0] for d in node.decorator_list}
            if decorators & {"jit", "jit_inline", "numba.njit", "njit"}:
                continue
            body = node.body
            first = (
                body[1]
                if len(body) > 1
                and isinstance(body[0], ast.Expr)
                and isinstance(getattr(body[0], "value", None), ast.Constant)
                else body[0]
            )
            lines = (node.end_lineno or node.lineno) - first.lineno + 1
            if lines > limit:
                out.append(f"{path.relative_to(SRC)}:{node.lineno} {node.name} ({lines} lines)")
    return out


def test_functions_are_short() -> None:
    # Readable in one screen; the compiled kernels are exempt (one loop compiled once).
    assert _long_functions(60) == []

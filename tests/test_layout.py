"""The package's layout (issue 30): no module of cablefem over 550 lines, no function over
120 lines, no class over 30 methods, no private name (``_x``) imported from another cablefem
module, no import cycle among cablefem's modules. ``import cablefem.case`` loading no dolfinx
is tested in test_constructors.py (test_imports_layering).

The checks read the source with :mod:`ast` (nothing is imported) and report every offender
at once; each is first shown to find what it looks for in a small package written to a
temporary folder."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

pytestmark = pytest.mark.single_rank  # reads files: nothing distributed

ROOT = Path(__file__).resolve().parents[1]
MAX_MODULE_LINES = 550
MAX_FUNCTION_LINES = 120
MAX_CLASS_METHODS = 30


def _modules(root: Path) -> dict[str, Path]:
    """Dotted name -> file of every module under the package folder ``root``."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def _rel(path: Path, root: Path) -> str:
    return str(path.relative_to(root.parent))


def long_modules(root: Path, limit: int = MAX_MODULE_LINES) -> list[str]:
    return [f"{_rel(p, root)}: {n} lines" for p in _modules(root).values()
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > limit]


def long_functions(root: Path, limit: int = MAX_FUNCTION_LINES) -> list[str]:
    """Functions (methods and nested functions included) over ``limit`` lines, from the
    ``def`` line to the last line of the body."""
    out = []
    for path in _modules(root).values():
        for node in ast.walk(_tree(path)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > limit:
                    out.append(f"{_rel(path, root)}:{node.lineno} {node.name}: {n} lines")
    return out


def big_classes(root: Path, limit: int = MAX_CLASS_METHODS) -> list[str]:
    """Classes with more than ``limit`` methods of their own (inherited ones not counted)."""
    out = []
    for path in _modules(root).values():
        for node in ast.walk(_tree(path)):
            if isinstance(node, ast.ClassDef):
                n = sum(isinstance(b, (ast.FunctionDef, ast.AsyncFunctionDef))
                        for b in node.body)
                if n > limit:
                    out.append(f"{_rel(path, root)}:{node.lineno} {node.name}: {n} methods")
    return out


def _imported_module(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    """The absolute name of the module a ``from ... import`` names (relative ones resolved
    against ``module``)."""
    if not node.level:
        return node.module or ""
    base = module.split(".")
    base = base[:len(base) - node.level + (1 if is_package else 0)]
    return ".".join(base + ([node.module] if node.module else []))


def private_imports(root: Path) -> list[str]:
    """``from <package>.x import _y`` (anywhere in a module, one or several lines, absolute
    or relative): a private name taken from another module of the package. Dunder names
    (``__version__``) are public."""
    modules, pkg = _modules(root), root.name
    out = []
    for name, path in modules.items():
        for node in ast.walk(_tree(path)):
            if not isinstance(node, ast.ImportFrom):
                continue
            source = _imported_module(node, name, path.name == "__init__.py")
            if source != pkg and not source.startswith(pkg + "."):
                continue
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    out.append(f"{_rel(path, root)}:{node.lineno} imports {alias.name} "
                               f"from {source}")
    return out


def _top_level_imports(tree: ast.Module):
    """Import statements run when the module is imported: those at the top level, also
    inside ``try``/``if`` blocks there, but not under ``if TYPE_CHECKING:``, not in
    functions or classes."""
    stack = list(tree.body)
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        elif isinstance(node, ast.If):
            test = node.test
            if not (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING"
                    or isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"):
                stack += node.body
            stack += node.orelse
        elif isinstance(node, ast.Try):
            stack += node.body + node.orelse + node.finalbody
            for handler in node.handlers:
                stack += handler.body
        elif isinstance(node, (ast.With,)):
            stack += node.body


def import_graph(root: Path) -> dict[str, set[str]]:
    """Module -> the package's modules it imports at import time. ``from p import m`` with
    ``m`` a module of ``p`` is an edge to ``p.m``; a name from ``p`` an edge to ``p``
    itself. The import of a parent package that Python does on the way to a submodule is
    not an edge (a package's ``__init__`` may import its own submodules)."""
    modules = _modules(root)
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for name, path in modules.items():
        for node in _top_level_imports(_tree(path)):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                source = _imported_module(node, name, path.name == "__init__.py")
                targets = [f"{source}.{a.name}" if f"{source}.{a.name}" in modules else source
                           for a in node.names]
            graph[name] |= {t for t in targets if t in modules and t != name}
    return graph


def import_cycles(root: Path) -> list[str]:
    """Every strongly connected component of more than one module of the import graph
    (Tarjan's algorithm), with one cycle through it spelled out."""
    graph = import_graph(root)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components = []

    def visit(v: str) -> None:  # recursion depth: at most the number of modules
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                components.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    out = []
    for comp in components:
        members, path = set(comp), [comp[0]]
        while True:  # walk inside the component until a module repeats: one cycle
            nxt = min(w for w in graph[path[-1]] if w in members)
            if nxt in path:
                path = path[path.index(nxt):] + [nxt]
                break
            path.append(nxt)
        out.append(f"{', '.join(comp)} (e.g. {' -> '.join(path)})")
    return out


# ------------------------------------------------------------------ the checks find offenders

def _write(root: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return root


def test_checks_find_what_they_look_for(tmp_path):
    """A small package with one offender of each kind, and look-alikes that are none."""
    body = "    x = 1\n" * 5
    pkg = _write(tmp_path / "pkg", {
        "__init__.py": "from pkg.sub import thing\n__version__ = '1'\n",
        "a.py": ("from pkg.b import helper\n"
                 "from pkg.c import (\n    public,\n    _hidden,\n)\n"
                 "def f():\n" + body + "def g():\n    from pkg import __version__\n"),
        "b.py": ("from typing import TYPE_CHECKING\nfrom pkg import a\n"
                 "if TYPE_CHECKING:\n    from pkg.c import public\n"
                 "def helper():\n    from pkg.c import _late\n"),
        "c.py": "from os import _exit\nclass K:\n" + "".join(
            f"    def m{i}(self):\n        pass\n" for i in range(4)),
        "sub/__init__.py": "from .inner import thing\n",
        "sub/inner.py": "from ..c import _rel\nfrom pkg.sub.leaf import other\nthing = 1\n",
        "sub/leaf.py": "other = 1\n",
    })
    assert long_modules(pkg, limit=10) == ["pkg/a.py: 13 lines"]
    assert long_functions(pkg, limit=5) == ["pkg/a.py:6 f: 6 lines"]
    assert big_classes(pkg, limit=3) == ["pkg/c.py:2 K: 4 methods"]
    assert sorted(private_imports(pkg)) == [
        "pkg/a.py:2 imports _hidden from pkg.c",
        "pkg/b.py:6 imports _late from pkg.c",
        "pkg/sub/inner.py:1 imports _rel from pkg.c"]
    # a <-> b at import time; b -> c only for type checkers; sub.inner -> sub (Python's
    # import of the parent package on the way to sub.leaf) is no edge: no cycle with sub
    assert import_graph(pkg)["pkg.b"] == {"pkg.a"}
    assert import_cycles(pkg) == ["pkg.a, pkg.b (e.g. pkg.a -> pkg.b -> pkg.a)"]


# ------------------------------------------------------------------ the package itself

PACKAGE = ROOT / "cablefem"


def _report(what: str, offenders: list[str]) -> str:
    return f"{len(offenders)} {what}:\n  " + "\n  ".join(offenders)


def test_no_long_module():
    offenders = long_modules(PACKAGE)
    assert not offenders, _report(f"modules over {MAX_MODULE_LINES} lines", offenders)


def test_no_long_function():
    offenders = long_functions(PACKAGE)
    assert not offenders, _report(f"functions over {MAX_FUNCTION_LINES} lines", offenders)


def test_no_big_class():
    offenders = big_classes(PACKAGE)
    assert not offenders, _report(f"classes over {MAX_CLASS_METHODS} methods", offenders)


def test_no_private_import_across_modules():
    offenders = private_imports(PACKAGE)
    assert not offenders, _report("private names imported from another module", offenders)


def test_no_import_cycle():
    offenders = import_cycles(PACKAGE)
    assert not offenders, _report("import cycles among cablefem's modules", offenders)

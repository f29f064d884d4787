"""The package's shape is checked, not hoped for: each layer imports only from the layers below it, and no two
modules import each other (directly or round a longer loop), deferred imports inside functions included."""

from __future__ import annotations

import ast
from pathlib import Path

import geomech

ROOT = Path(geomech.__file__).parent

#: From the bottom up (docs/DESIGN: lie -> symbolic layer -> systems -> reduction -> integrators -> analysis ->
#: plot -> experiments -> cli). The base modules (errors, validation, version, storage) are below them all.
LAYERS = ["base", "lie", "symbolic", "systems", "reduction", "integrators", "analysis", "plot", "experiments", "cli"]
BASE = {"errors", "_validate", "_version", "_storage", "_display"}


def _module_name(path: Path) -> str:
    parts = ("geomech",) + path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1]) if parts[-1] == "__init__" else ".".join(parts)


def _imports(path: Path) -> set[str]:
    """Every geomech module ``path`` imports, anywhere in it."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not target.startswith("geomech"):
                continue
            # `from .pkg import module` names a module; `from .module import name` the module itself
            for alias in node.names:
                candidate = f"{target}.{alias.name}"
                out.add(candidate if _exists(candidate) else target)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("geomech"))
    return out


def _exists(module: str) -> bool:
    rel = Path(*module.split(".")[1:])
    return (ROOT / rel).with_suffix(".py").is_file() or (ROOT / rel / "__init__.py").is_file()


def _layer(module: str) -> str | None:
    parts = module.split(".")
    if len(parts) < 2:
        return None
    head = parts[1]
    if head in BASE:
        return "base"
    return head if head in LAYERS else None


def _graph() -> dict[str, set[str]]:
    return {_module_name(p): _imports(p) for p in ROOT.rglob("*.py")}


def test_each_layer_imports_only_from_below():
    upward = []
    for module, targets in _graph().items():
        a = _layer(module)
        if a is None:
            continue
        for target in targets:
            b = _layer(target)
            if b is not None and LAYERS.index(b) > LAYERS.index(a):
                upward.append(f"{module} ({a}) imports {target} ({b})")
    assert not upward, "imports up the layers:\n" + "\n".join(sorted(upward))


def test_no_import_cycles_between_modules():
    graph = _graph()
    packages = {m for m in graph if (ROOT / Path(*m.split(".")[1:]) / "__init__.py").is_file() or m == "geomech"}
    # a package's __init__ re-exports its modules: edges into it are not dependencies of one module on another
    edges = {
        m: {t for t in ts if t in graph and t not in packages and t != m}
        for m, ts in graph.items()
        if m not in packages
    }
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in edges:
        if v not in index:
            visit(v)
    assert not cycles, "modules that import each other: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_the_checker_sees_an_upward_import(tmp_path, monkeypatch):
    """The checker can fail: a systems module importing from cli is reported."""
    fake = tmp_path / "geomech"
    (fake / "systems").mkdir(parents=True)
    (fake / "cli").mkdir()
    for pkg in (fake, fake / "systems", fake / "cli"):
        (pkg / "__init__.py").write_text("")
    (fake / "cli" / "main.py").write_text("X = 1\n")
    (fake / "systems" / "model.py").write_text("def f():\n    from ..cli.main import X\n    return X\n")
    monkeypatch.setattr(__import__(__name__), "ROOT", fake)
    graph = _graph()
    assert "geomech.cli.main" in graph["geomech.systems.model"]
    try:
        test_each_layer_imports_only_from_below()
    except AssertionError as exc:
        assert "geomech.systems.model (systems) imports geomech.cli.main (cli)" in str(exc)
    else:
        raise AssertionError("the upward import was not seen")


def test_one_compiler():
    # Every formula-to-function step goes through geomech.symbolic.compile: no other module calls lambdify or
    # prints code from sympy itself.
    compiler = ROOT / "symbolic" / "compile.py"
    offenders = []
    for path in sorted(ROOT.rglob("*.py")):
        if path == compiler:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            name = (
                node.attr
                if isinstance(node, ast.Attribute)
                else node.id
                if isinstance(node, ast.Name)
                else node.name
                if isinstance(node, ast.alias)
                else None
            )
            if name in {"lambdify", "PythonCodePrinter", "NumPyPrinter", "SciPyPrinter", "pycode"}:
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno if hasattr(node, 'lineno') else '?'}")
    assert not offenders, "compile through geomech.symbolic.compile: " + ", ".join(offenders)


def test_every_import_of_the_package_resolves():
    # a relative import with one dot too few (a module moved into a subpackage) fails only when the line runs:
    # deferred imports are checked here, where no test may reach them
    broken = sorted(
        f"{path.relative_to(ROOT)} -> {target}"
        for path in ROOT.rglob("*.py")
        for target in _imports(path)
        if target != "geomech" and not _exists(target)
    )
    assert not broken, "imports of modules that do not exist: " + "; ".join(broken)

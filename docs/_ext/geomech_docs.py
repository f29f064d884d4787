"""Sphinx extension of geomech's site: the API reference generated from the public names, and the Markdown guides'
code run during the build.

- ``builder-inited``: writes ``api/<module>.rst`` for each public module, listing every name of its ``__all__``
  (or, for a module without one, every public function and class defined in it) in an autosummary table, so a
  name added to ``__all__`` appears in the reference without an edit here. A name exported by several modules is
  documented once, at the first module of ``MODULES`` that lists it; the top-level ``geomech`` page links there.
- ``source-read``: runs the ```python blocks of every Markdown guide in a scratch directory; a block that raises
  fails the build with the guide, the block and the error.
"""

from __future__ import annotations

import contextlib
import importlib
import inspect
import io
import tempfile
from pathlib import Path
from typing import Any

from guide_blocks import python_blocks, run_blocks
from sphinx.application import Sphinx
from sphinx.errors import ExtensionError
from sphinx.util import logging

LOG = logging.getLogger(__name__)

# (module, one line on what it holds), in the order of the reference; a module listed in another's __all__ (so3,
# nonholonomic_examples, ...) follows it.
MODULES: list[tuple[str, str]] = [
    ("geomech.systems", "One description of a mechanical system, from a formula, a Lagrangian or a model file."),
    (
        "geomech.reduction",
        "Reduction: the Serret-Andoyer charts, Euler and quaternion coordinates, nonholonomic "
        "reduction (Lagrange-d'Alembert, BKMM, almost-Poisson, Bates-Sniatycki).",
    ),
    (
        "geomech.integrators",
        "`solve` and its methods: the registry, the compiled loops, the exact propagators, the Solution.",
    ),
    ("geomech.analysis", "Stability (Lagrange-Dirichlet, energy-Casimir), equilibria, phases, gaits, studies."),
    ("geomech.lie", "Lie groups: SO(3), SE(2), SE(3), quaternions, Euler angles, products."),
    ("geomech.plot", "Pictures with matplotlib: momentum spheres, phase portraits, stability maps, gaits, phases."),
    ("geomech.plot.interactive", "Interactive figures (plotly) as self-contained HTML files."),
    ("geomech.symbolic", "The symbolic layer: formulas parsed by a whitelist, compilation to numeric code, caches."),
    ("geomech.experiments.serret_andoyer_study", "The Serret-Andoyer paper's integrator study (figures 5-7)."),
    ("geomech.experiments.serret_andoyer_figures", "The figures of that study."),
    ("geomech.experiments.serret_andoyer_sweep", "Sweeps of integrator settings for that study."),
    ("geomech.experiments.rigid_body", "The free rigid body, integrated and checked against the exact solution."),
    ("geomech.errors", "The errors geomech raises: each names what was wrong and how to fix it."),
]


def public_names(module: Any) -> list[str]:
    """The names ``module`` makes public: its ``__all__``, else the functions and classes defined in it."""
    names = getattr(module, "__all__", None)
    if names is not None:
        return [n for n in names if not n.startswith("__")]
    return sorted(
        n
        for n, obj in vars(module).items()
        if not n.startswith("_")
        and (inspect.isfunction(obj) or inspect.isclass(obj))
        and obj.__module__ == module.__name__
    )


def _underline(text: str, char: str = "=") -> str:
    return f"{text}\n{char * len(text)}\n"


def _page(name: str, summary: str, entries: list[str], submodules: list[str]) -> str:
    lines = [_underline(name), f".. automodule:: {name}\n   :no-members:\n", f".. currentmodule:: {name}\n"]
    if summary:
        lines.append(summary + "\n")
    if entries:
        lines.append(".. autosummary::\n   :toctree: generated/\n   :nosignatures:\n")
        lines += [f"   {n}" for n in entries]
        lines.append("")
    if submodules:
        lines.append(".. toctree::\n   :maxdepth: 1\n")
        lines += [f"   {m}" for m in submodules]
        lines.append("")
    return "\n".join(lines)


def write_api(srcdir: Path) -> list[str]:
    """Write ``api/*.rst`` under ``srcdir``; return the names of the pages written (without suffix)."""
    out = srcdir / "api"
    out.mkdir(exist_ok=True)
    home: dict[tuple, str] = {}  # an object's key -> the full name it is documented under
    queue = list(MODULES)
    pages: list[str] = []
    texts: dict[str, str] = {}
    while queue:
        modname, summary = queue.pop(0)
        module = importlib.import_module(modname)
        entries, submodules = [], []
        for n in public_names(module):
            obj = getattr(module, n)
            if inspect.ismodule(obj):
                if obj.__name__.startswith(modname + "."):
                    submodules.append(obj.__name__)
                    queue.insert(0, (obj.__name__, ""))
                continue
            # a function or class once, wherever it is exported; a value (DIM, REGISTRY) under each module's name
            key = ("obj", id(obj)) if (inspect.isclass(obj) or callable(obj)) else ("data", modname, n)
            if key in home:
                continue
            home[key] = f"{modname}.{n}"
            entries.append(n)
        texts[modname] = _page(modname, summary, entries, submodules)
        pages.append(modname)
    top = importlib.import_module("geomech")
    links = []
    for n in public_names(top):
        obj = getattr(top, n)
        target = obj.__name__ if inspect.ismodule(obj) else home.get(("obj", id(obj)))
        if target is not None:
            role = "mod" if inspect.ismodule(obj) else "obj"
            links.append(f"- :{role}:`geomech.{n} <{target}>`")
    index = [
        _underline("API reference"),
        "Every public name of geomech, generated from the docstrings. The names most used are also importable "
        "from the package itself:\n",
        *links,
        "",
        ".. toctree::\n   :maxdepth: 1\n",
        *[f"   {m}" for m, _ in MODULES],
        "",
    ]
    texts["index"] = "\n".join(index)
    for name, text in texts.items():
        path = out / f"{name}.rst"
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")
    return pages


def _generate(app: Sphinx, config: Any) -> None:
    write_api(Path(app.srcdir))


def _run_guide(app: Sphinx, docname: str, source: list[str]) -> None:
    path = Path(app.srcdir) / f"{docname}.md"
    if not path.exists() or not python_blocks(source[0]):
        return
    with tempfile.TemporaryDirectory(prefix="geomech-guide-") as tmp:
        try:
            with contextlib.redirect_stdout(io.StringIO()):  # what the guide prints is shown in the guide
                run_blocks(path, Path(tmp))
        except Exception as exc:  # the build fails, naming the guide and the block
            raise ExtensionError(f"the code of {path.name} does not run: {type(exc).__name__}: {exc}") from exc
    LOG.info("ran the code blocks of %s", path.name)


def _plotly_where_needed(app: Sphinx, pagename: str, templatename: str, context: dict, doctree: Any) -> None:
    """plotly.js (3.5 MB) only on the pages that draw an interactive figure."""
    if "plotly-graph-div" in context.get("body", ""):
        app.add_js_file("plotly.min.js")


def setup(app: Sphinx) -> dict[str, Any]:
    app.connect("html-page-context", _plotly_where_needed)
    app.connect("config-inited", _generate)
    app.connect("source-read", _run_guide)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}

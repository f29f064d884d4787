"""Argument handling shared by the commands: vector options and one-line errors."""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import click
import numpy as np


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _command(root: click.Group, argv: Sequence[str]) -> click.Command:
    """The command ``argv`` invokes (following subcommand names from the root), or the root itself."""
    cmd: click.Command = root
    for tok in argv:
        if tok.startswith("-"):
            continue
        if isinstance(cmd, click.Group) and tok in cmd.commands:
            cmd = cmd.commands[tok]
        else:
            break
    return cmd


def _options(cmd: click.Command) -> list[click.Option]:
    return [p for p in cmd.params if isinstance(p, click.Option)]


def gather_vectors(argv: Sequence[str], root: click.Group) -> list[str]:
    """Join the numbers that follow a vector option (a :class:`FloatVector`) into one comma-separated word, so
    that ``--p0 0.1 0.2`` and ``--p0 0.1,0.2`` mean the same, and a wrong count is reported by the option's own
    check rather than as a stray argument."""
    cmd = _command(root, argv)
    vector = {name for o in _options(cmd) if isinstance(o.type, FloatVector) for name in o.opts}
    out: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        out.append(tok)
        i += 1
        if tok in vector:
            vals = []
            while i < len(argv) and _is_number(argv[i]):
                vals.append(argv[i])
                i += 1
            if vals:
                out.append(",".join(vals))
    return out


def repeated_option(argv: Sequence[str], root: click.Group) -> str | None:
    """The first option given twice that takes one value (click would keep the last silently), or None."""
    cmd = _command(root, argv)
    single = {name: o for o in _options(cmd) if not o.multiple and not o.count for name in o.opts + o.secondary_opts}
    seen: dict[int, str] = {}
    for tok in argv:
        name = tok.split("=", 1)[0]
        if name in single:
            key = id(single[name])
            if key in seen:
                return name if name == seen[key] else f"{seen[key]} / {name}"
            seen[key] = name
    return None


class FloatVector(click.ParamType):
    """A vector of floats with one of the allowed lengths, its numbers separated by commas or spaces."""

    name = "floats"

    def __init__(self, *lengths: int):
        self.lengths = lengths

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        parts = [p for p in re.split(r"[,\s]+", str(value).strip()) if p != ""]
        try:
            vals = tuple(float(p) for p in parts)
        except ValueError:
            self.fail(f"expected numbers, got {value!r}", param, ctx)
        if len(vals) not in self.lengths:
            want = " or ".join(str(n) for n in self.lengths)
            self.fail(f"expected {want} numbers, got {len(vals)} ({', '.join(parts) or 'none'})", param, ctx)
        return vals


def parse_params(items: Sequence[str], option: str = "--param") -> dict[str, float]:
    """Parse repeated ``NAME=VALUE`` options into a dict of finite floats, with one-line errors."""
    values: dict[str, float] = {}
    for item in items:
        name, sep, val = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise click.BadParameter(f"expected NAME=VALUE, got {item!r}", param_hint=f"'{option}'")
        if name in values:
            raise click.BadParameter(f"{name} is given twice", param_hint=f"'{option}'")
        try:
            value = float(val)
        except ValueError:
            raise click.BadParameter(f"{name} = {val!r} is not a number", param_hint=f"'{option}'") from None
        if not np.isfinite(value):
            raise click.BadParameter(f"{name} = {val.strip()} is not a finite number", param_hint=f"'{option}'")
        values[name] = value
    return values


def parse_shape_loop(items: Sequence[str], names: Sequence[str], option: str, owner: str) -> dict[str, Any]:
    """``NAME=EXPR`` items, one for each shape variable in ``names`` (in that order), each formula parsed
    (:func:`~geomech.symbolic.parse_formula`); bad or missing ones are an error naming ``option`` and the
    variables ``owner`` has."""
    from ..errors import InputError, ShapeError
    from ..symbolic.formula import parse_formula

    given: dict[str, str] = {}
    for item in items:
        name, sep, expr = item.partition("=")
        name = name.strip()
        if not sep or not name or not expr.strip():
            raise InputError(f"Expected `{option}` as NAME=EXPR, got {item!r}.")
        if name not in names:
            raise InputError(
                f"`{option}` names {name!r}, which is not a shape variable of {owner} ({', '.join(names) or 'none'})."
            )
        if name in given:
            raise InputError(f"`{option}` gives {name!r} twice.")
        given[name] = parse_formula(expr, f"{option} {name}")
    if len(given) != len(names):
        raise ShapeError(
            f"Expected one `{option}` for each of the {len(names)} shape variables "
            f"({', '.join(names)}) of {owner}, got {len(given)} ({', '.join(given) or 'none'})."
        )
    return {n: given[n] for n in names}


def parse_range(spec: str, hint: str, max_n: int = 1000) -> tuple[str, Any]:
    """``NAME=START:STOP:N``: the name and ``numpy.linspace(START, STOP, N)``, or a bad-parameter error naming the
    option (``hint``)."""
    import numpy as np

    name, sep, rng = spec.partition("=")
    parts = rng.split(":")
    try:
        if not sep or not name.strip() or len(parts) != 3:
            raise ValueError
        a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise click.BadParameter(f"expected NAME=START:STOP:N (e.g. k=0:1:41), got {spec!r}", param_hint=hint) from None
    if not (np.isfinite(a) and np.isfinite(b) and b > a and 2 <= n <= max_n):
        raise click.BadParameter(f"expected START < STOP and 2 <= N <= {max_n}, got {spec!r}", param_hint=hint)
    return name.strip(), np.linspace(a, b, n)


def study_options(store: str) -> Any:
    """``--resume``, ``--scheduler`` and ``--chunk`` of a command that runs a study (its store OUT/``store``)."""

    def decorate(f: Any) -> Any:
        f = click.option("--chunk", type=click.IntRange(1, None), default=None, help="Members (grid points) per task.")(
            f
        )
        f = click.option(
            "--scheduler",
            default=None,
            metavar="ADDRESS",
            help="Run on a dask.distributed cluster (tcp://host:8786) instead of this machine's cores; OUT must be a "
            "path its workers reach.",
        )(f)
        return click.option(
            "--resume",
            is_flag=True,
            help=f"Continue the study in OUT/{store} (the blocks already done are kept): same arguments only.",
        )(f)

    return decorate


class OutDir(click.ParamType):
    """``--out DIR``: checked when the command line is read, before any work (nothing is created then)."""

    name = "directory"

    def convert(self, value, param, ctx):
        from .._storage import check_output_dir
        from ..errors import InputError

        option = param.opts[0] if param is not None and param.opts else "--out"
        try:
            return check_output_dir(value, option)
        except InputError as exc:
            raise click.UsageError(str(exc), ctx) from None


def out_option(help: str, *, required: bool = False) -> Any:
    """The ``--out DIR`` option of a command (checked writable before any work; see :class:`Outputs`)."""
    return click.option("--out", type=OutDir(), required=required, default=None, help=help)


class HtmlFile(click.ParamType):
    """``--html FILE``: an interactive figure, a self-contained HTML file; its directory must exist and be
    writable, checked when the command line is read (before any work)."""

    name = "file"

    def convert(self, value, param, ctx):
        import os

        path = Path(value)
        if path.suffix.lower() not in (".html", ".htm"):
            self.fail(f"expected a file name ending in .html, got {str(value)!r}", param, ctx)
        parent = path.parent if str(path.parent) else Path(".")
        if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
            self.fail(f"cannot write {str(value)!r}: {str(parent)!r} is not a writable directory", param, ctx)
        if path.is_dir():
            self.fail(f"{str(value)!r} is a directory; give a file name ending in .html", param, ctx)
        return path


def html_option(what: str) -> Any:
    """The ``--html FILE`` option of a command that draws: ``what`` as an interactive figure (plotly, no network
    needed to open it), written atomically."""
    return click.option("--html", "html", type=HtmlFile(), default=None, metavar="FILE", help=f"Write {what}.")


class Outputs:
    """The files of one command's ``--out``, written all together at the end, all or nothing
    (:func:`geomech._storage.write_set`): an interrupted or failed run leaves no half set behind."""

    def __init__(self, out: Path):
        self.out = Path(out)
        self._writers: dict[str, Any] = {}

    def figure(self, name: str, ax_or_fig: Any, **savefig: Any) -> None:
        """Render a matplotlib figure (or the figure of axes) now, close it, keep the PNG for the commit."""
        import io

        import matplotlib.pyplot as plt

        fig = ax_or_fig.figure if hasattr(ax_or_fig, "get_figure") and ax_or_fig.figure is not None else ax_or_fig
        buf = io.BytesIO()
        fig.savefig(buf, format="png", **savefig)
        plt.close(fig)
        data = buf.getvalue()
        self._writers[name] = lambda p: p.write_bytes(data)

    def json(self, name: str, obj: Any) -> None:
        from .._storage import dumps_json

        text = dumps_json(obj) + "\n"
        self._writers[name] = lambda p: p.write_text(text)

    def dataset(self, name: str, ds: Any) -> None:
        self._writers[name] = lambda p: ds.to_netcdf(p)

    def file(self, name: str, writer: Any) -> None:
        """``writer(path)`` writes the file at commit time."""
        self._writers[name] = writer

    def paths(self, *extra: str) -> list[str]:
        return [str(self.out / n) for n in (*self._writers, *extra)]

    def commit(self) -> list[Path]:
        from .._storage import write_set

        return write_set(self.out, self._writers)


#: The version of the JSON documents the commands print with ``--json`` (and write as ``NAME.json``); described
#: by ``schema.json`` beside this module and docs/json.md. A change of a name or a type is a new version.
SCHEMA = "geomech-cli/1"


def schema() -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of every command's ``--json`` document."""
    import json
    from importlib.resources import files

    return json.loads(files("geomech.cli").joinpath("schema.json").read_text())


def document(command: str, summary: dict[str, Any], detail: dict[str, Any]) -> dict[str, Any]:
    """A command's JSON document: ``schema`` (:data:`SCHEMA`), ``command``, the ``summary`` block (the answer),
    then the ``detail`` (the evidence)."""
    doc: dict[str, Any] = {"schema": SCHEMA, "command": command, "summary": summary}
    clash = sorted(set(doc) & set(detail))
    if clash:  # pragma: no cover - a programming error, caught by the schema tests
        raise ValueError(f"detail keys {clash} are reserved")
    doc.update(detail)
    return doc


def emit(
    doc: dict, as_json: bool, text: str, outputs: Outputs | None, name: str, written_too: Sequence[Path] = ()
) -> None:
    """Print the document (JSON, checked finite, or ``text``) and, with ``--out``, commit the files with
    ``name.json`` (the document, with ``files`` listing what was written) among them; ``written_too`` are files
    already written elsewhere (``--html``), listed in ``files`` too."""
    from .._storage import dumps_json

    extra = [str(p) for p in written_too]
    if extra:
        text += "\n" + "\n".join(f"interactive figure: {p}" for p in extra)
    if outputs is None and extra:
        doc = {**doc, "files": extra}
    if outputs is not None:
        doc = {**doc, "files": outputs.paths(f"{name}.json") + extra}
        check_document(doc)
        outputs.json(f"{name}.json", doc)
        outputs.commit()
        text += "\n" + written(outputs.out, doc["files"])
    elif as_json:
        check_document(doc)
    click.echo(dumps_json(doc) if as_json else text)


def written(out: Path, files: Any) -> str:
    """``written to OUT:`` and the names of the files, wrapped to 120 columns."""
    import textwrap

    names = ", ".join(Path(f).name for f in files)
    return f"written to {out}:\n" + "\n".join(textwrap.wrap(names, 118, initial_indent="  ", subsequent_indent="  "))


def check_document(doc: dict[str, Any]) -> None:
    """With ``GEOMECH_CHECK_JSON=1`` in the environment, validate ``doc`` against :func:`schema` (needs the
    jsonschema package; the test suite sets it, so that every document any test prints is checked)."""
    import os

    if os.environ.get("GEOMECH_CHECK_JSON", "") in ("", "0"):
        return
    import jsonschema

    jsonschema.validate(doc, schema(), cls=jsonschema.Draft202012Validator)


def model_argument(what: str) -> Any:
    """The one way a command takes its system: ``MODEL`` (a built-in name, or a model file ``.py``) or
    ``--model FILE.py`` (the same file); the command receives ``model`` and ``model_file``, which
    :func:`one_model` turns into one."""

    def decorate(f: Any) -> Any:
        f = click.option(
            "--model",
            "model_file",
            type=click.Path(dir_okay=False),
            default=None,
            help=f"A Python model file defining `system` or `build(**params)` returning {what} (the same as "
            "giving FILE.py as MODEL).",
        )(f)
        return click.argument("model", required=False)(f)

    return decorate


def one_model(model: str | None, model_file: str | None) -> str:
    """The model a command was given, as a name or a file path: exactly one of ``MODEL`` and ``--model``."""
    if model is not None and model_file is not None:
        raise click.UsageError("give MODEL or --model FILE.py, not both")
    if model is None and model_file is None:
        raise click.UsageError("give a MODEL: a built-in name, or a model file (MODEL.py or --model MODEL.py)")
    return str(model_file if model_file is not None else model)


def is_model_file(model: str) -> bool:
    """Whether ``model`` names a model file rather than a built-in model."""
    return model.endswith(".py") or Path(model).is_file()


def events_json(sol: Any) -> dict[str, list[dict[str, Any]]]:
    """A run's events (one trajectory) as JSON: for each name, the times and the states (by label) in time order."""
    return {
        name: [{"t": float(r[1]), "state": {k: float(x) for k, x in zip(sol.labels, r[2:])}} for r in rows]
        for name, rows in sol.events.items()
    }

"""Systems by name or from a user's model file.

A model file is Python that defines ``system`` or ``build(**params)`` returning one. It is code by design,
run as ``python FILE.py`` would run it: use only files you trust. What it prints goes to stderr, so that a
command's JSON on stdout stays valid; an exception or ``sys.exit`` inside it is one
:class:`~geomech.errors.InputError` naming the file, with the original exception chained.
"""

from __future__ import annotations

import contextlib
import importlib.util
import sys
from pathlib import Path
from typing import Any

from ..errors import GeomechError, InputError

__all__ = ["load_model", "example_system"]


def load_model(path: str | Path, params: dict[str, float] | None = None, *, kind: Any = None):
    """Load a model file: it defines ``system`` or ``build(**params)`` returning one, a NonholonomicSystem
    (or, with ``kind=HolonomicSystem``, a holonomic system with symmetry)."""
    from ..systems.nonholonomic import NonholonomicSystem

    kind = NonholonomicSystem if kind is None else kind
    how = f"{kind.__name__}.from_lagrangian(...)"
    path = Path(path)
    if path.suffix != ".py":
        raise InputError(f"Expected a model file to be Python source ending in .py, got {str(path)!r}.")
    if not path.is_file():
        raise InputError(f"Model file {str(path)!r} does not exist.")
    spec = importlib.util.spec_from_file_location(f"geomech_model_{abs(hash(str(path)))}", path)
    assert spec is not None and spec.loader is not None  # always set for a ``.py`` file location
    module = importlib.util.module_from_spec(spec)
    # A model file is code by design; what it prints goes to stderr (stdout may be --json), and neither an
    # exception nor sys.exit inside it escapes as anything but one error naming the file.
    with contextlib.redirect_stdout(sys.stderr):
        try:
            spec.loader.exec_module(module)
        except GeomechError:
            raise
        except (Exception, SystemExit) as exc:
            raise InputError(
                f"Could not run model file {str(path)!r}: {_describe(exc)} (--debug shows where)."
            ) from exc
        params = dict(params or {})
        if hasattr(module, "build") and callable(module.build):
            try:
                system = module.build(**params)
            except GeomechError:
                raise
            except TypeError as exc:
                raise InputError(
                    f"{path.name}: build(**params) rejected the parameters {sorted(params)}: {exc}"
                ) from exc
            except (Exception, SystemExit) as exc:
                raise InputError(
                    f"{path.name}: build(**params) failed: {_describe(exc)} (--debug shows where)."
                ) from exc
            params = {}
        elif hasattr(module, "system"):
            system = module.system
        else:
            raise InputError(
                f"Model file {str(path)!r} defines neither `system` (a {kind.__name__}) nor a "
                "function `build(**params)` returning one; see docs/nonholonomic.md and docs/phases.md."
            )
    if not isinstance(system, kind):
        raise InputError(
            f"{path.name}: expected `system` to be a {kind.__name__} ({how}), got {type(system).__name__}."
        )
    return system.with_parameters(**params) if params else system


def _describe(exc: BaseException) -> str:
    if isinstance(exc, SystemExit):
        return f"it called sys.exit({exc.code!r})"
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def example_system(name: str, params: dict[str, float]):
    """The built-in nonholonomic example ``name`` with parameter values ``params``; unknown names are an error."""
    from ..systems.nonholonomic_examples import EXAMPLES

    system = EXAMPLES[name]()
    names = {p.name for p in system.parameter_symbols}
    unknown = sorted(set(params) - names)
    if unknown:
        raise InputError(f"{name} has no parameter(s) {unknown}; its parameters are {sorted(names)}.")
    return system.with_parameters(**params) if params else system

"""Systems by name or from a user's model file.

A model file is Python that defines ``system`` or ``build(**params)`` returning one. It is code by design,
run as ``python FILE.py`` would run it: use only files you trust. What it prints goes to stderr, so that a
command's JSON on stdout stays valid; an exception or ``sys.exit`` inside it is one
:class:`~geomech.errors.InputError` naming the file, with the original exception chained.
"""

from __future__ import annotations

import contextlib
import importlib.util
import inspect
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..errors import GeomechError, InputError

__all__ = ["load_model", "model_builder", "example_system"]


def _kinds(kind: Any) -> tuple[tuple[type, ...], str]:
    from ..systems.nonholonomic import NonholonomicSystem

    kinds = (NonholonomicSystem,) if kind is None else (kind if isinstance(kind, tuple) else (kind,))
    return kinds, " or ".join(k.__name__ for k in kinds)


def model_builder(path: str | Path, *, kind: Any = None) -> Callable[..., Any]:
    """Run a model file once and return ``build(**params)``: its own ``build``, or, for a file that defines
    ``system``, the system with the values given (through its ``with_parameters``). Every system it returns
    is checked to be a ``kind`` (a class or a tuple of classes; default NonholonomicSystem)."""
    kinds, names = _kinds(kind)
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

    def checked(system: Any) -> Any:
        if not isinstance(system, kinds):
            raise InputError(f"{path.name}: expected `system` to be a {names}, got {type(system).__name__}.")
        return system

    if hasattr(module, "build") and callable(module.build):

        def build(**params: float) -> Any:
            with contextlib.redirect_stdout(sys.stderr):
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
            return checked(system)

        build.__signature__ = inspect.signature(module.build)  # type: ignore[attr-defined]
        return build
    if not hasattr(module, "system"):
        raise InputError(
            f"Model file {str(path)!r} defines neither `system` (a {names}) nor a function `build(**params)` "
            "returning one; see docs/nonholonomic.md and docs/phases.md."
        )
    system = checked(module.system)

    def with_values(**params: float) -> Any:
        if not params:
            return system
        if not hasattr(system, "with_parameters"):
            raise InputError(
                f"{path.name}: its `system` ({type(system).__name__}) takes no parameter values; define "
                f"`build(**params)` returning one to pass {sorted(params)}."
            )
        return system.with_parameters(**params)

    return with_values


def load_model(path: str | Path, params: dict[str, float] | None = None, *, kind: Any = None):
    """Load a model file: it defines ``system`` or ``build(**params)`` returning one, a NonholonomicSystem
    (or a ``kind``: a class, or a tuple of classes)."""
    return model_builder(path, kind=kind)(**dict(params or {}))


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

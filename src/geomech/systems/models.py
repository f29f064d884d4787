"""Systems by name or from a user's model file.

The built-in examples are one registry, :data:`EXAMPLES` (snake_case names; a name with dashes is the same
name): the nonholonomic ones (:mod:`~geomech.systems.nonholonomic_examples`) and those without constraints
(:mod:`~geomech.systems.holonomic_examples`), every one a Lagrangian system on G x S that takes parameter values
through ``with_parameters``. The command line reads the same registry.

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
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..errors import GeomechError, InputError
from .holonomic_examples import EXAMPLES as _WITHOUT_CONSTRAINTS
from .nonholonomic_examples import EXAMPLES as _NONHOLONOMIC

__all__ = ["EXAMPLES", "example_name", "example_system", "load_model", "model_builder"]

#: Every built-in example by name: a function returning the system (its default parameter values, where it has
#: them; ``with_parameters`` gives others).
EXAMPLES: dict[str, Callable[[], Any]] = {**_NONHOLONOMIC, **_WITHOUT_CONSTRAINTS}


def _kinds(kind: Any) -> tuple[tuple[type, ...], str]:
    from ..systems.nonholonomic import NonholonomicSystem

    kinds = (NonholonomicSystem,) if kind is None else (kind if isinstance(kind, tuple) else (kind,))
    return kinds, " or ".join(k.__name__ for k in kinds)


_BUILDING = threading.RLock()


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
            # sys.stdout is one for the process: threads building at once (a study's tasks) take turns, or one
            # could restore another's redirection and leave stdout pointing at stderr
            with _BUILDING, contextlib.redirect_stdout(sys.stderr):
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


def example_name(name: str) -> str | None:
    """The registry's name for ``name`` (dashes read as underscores), or None when it names no example."""
    key = name.strip().replace("-", "_")
    return key if key in EXAMPLES else None


def example_system(name: str, params: dict[str, float] | None = None, *, kind: Any = None, purpose: str = "") -> Any:
    """The built-in example ``name`` with parameter values ``params``; an unknown name, an unknown parameter, or
    (with ``kind``) an example of another kind is an :class:`InputError` that says what fits."""
    kinds, names = _kinds(kind)
    key = example_name(name)
    if key is None:
        fitting = [n for n in EXAMPLES if kind is None or _is_kind(n, kinds)]
        raise InputError(f"Unknown example {name!r}; choose one of {', '.join(fitting)}, or give a model file (.py).")
    system: Any = EXAMPLES[key]()
    if not _has_kind(system, kinds):
        fitting = [n for n in EXAMPLES if _is_kind(n, kinds)]
        raise InputError(
            f"{key} is a {type(system).__name__}, and {purpose or 'this'} needs a {names}: choose one of "
            f"{', '.join(fitting)}, or give a model file (.py)."
        )
    params = dict(params or {})
    known = {p.name for p in system.parameter_symbols}
    unknown = sorted(set(params) - known)
    if unknown:
        raise InputError(f"{key} has no parameter(s) {unknown}; its parameters are {sorted(known)}.")
    return system.with_parameters(**params) if params else system


def _has_kind(system: Any, kinds: tuple[type, ...]) -> bool:
    return isinstance(system, kinds)


def _is_kind(name: str, kinds: tuple[type, ...]) -> bool:
    """Whether the example ``name`` is one of ``kinds``, without building it (the registry's two parts are its
    two kinds)."""
    from .holonomic import HolonomicSystem
    from .nonholonomic import NonholonomicSystem

    cls: type = HolonomicSystem if name in _WITHOUT_CONSTRAINTS else NonholonomicSystem
    return issubclass(cls, kinds)

"""numba's names in a generated kernel module, bound at the module's first use of numba: importing the module does
not import numba.

A compiled model whose loops load as machine code of their own (:mod:`._native`) needs the generated module for
its data (the Taylor tape, the sizes) and the Python source of its functions, not numba: importing numba and
initialising its CPU target is most of such a model's load. So the header of a generated module takes ``kernel``,
``inlined``, ``numba`` and the intrinsics of :mod:`._fptr` from a :class:`Deferred` of the module's namespace:
``@kernel`` gives a :class:`Pending` function (its ``py_func`` the Python function), and the first call of one,
or the first use of a dispatcher's attribute, binds the whole module at once (and first the modules whose
kernels it uses, the shared helpers): every name is replaced in the namespace by numba's object (a dispatcher
made by ``numba.njit`` with the options given, numba itself, the intrinsic), so that numba, compiling or loading
a loop, reads real dispatchers from its globals as before. The machine code, numba's disk cache and the
dispatchers are the same as those of a module that imported numba at once.
"""

from __future__ import annotations

import threading
from typing import Any

from ._k_common import MODEL_ARRAYS

__all__ = ["Deferred", "Pending", "c_signature"]

_LOCK = threading.RLock()
#: the names of :mod:`._fptr` a generated module uses inside its kernels
INTRINSICS = ("borrowed", "call_model", "call_model4", "call_model6", "kept", "shaped")


def c_signature(name: str) -> str:
    """The C signature of the twin of model function ``name`` (:mod:`._fptr`)."""
    return "void(" + "CPointer(float64), " * (len(MODEL_ARRAYS[name]) + 1) + "int64, int64)"


class Pending:
    """A kernel of a generated module before the module is bound: ``py_func`` is its Python function; calling it,
    or reading any dispatcher attribute, binds the module and goes to numba's dispatcher."""

    def __init__(self, function: Any, options: dict[str, Any], home: Deferred):
        self.py_func = function
        self.options = options
        self.home = home
        self.real: Any = None
        self.__name__ = function.__name__
        self.__doc__ = function.__doc__

    def resolve(self) -> Any:
        """numba's dispatcher of the function (the module bound first, where it is not)."""
        if self.real is None:
            self.home.bind()
        return self.real

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self.resolve()(*args, **kwargs)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.resolve(), name)


class _Name:
    """numba, or one of :mod:`._fptr`'s intrinsics, in a module not bound yet (read only inside kernels)."""

    def __init__(self, name: str):
        self.name = name

    def resolve(self) -> Any:
        if self.name == "numba":
            import numba

            return numba
        from . import _fptr

        return getattr(_fptr, self.name)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.resolve(), name)


class Deferred:
    """The numba names of the generated module whose globals are ``namespace``."""

    def __init__(self, namespace: dict[str, Any]):
        self._namespace = namespace
        self.bound = False
        self.numba = _Name("numba")

    def kernel(self, **options: Any) -> Any:
        """The decorator ``numba.njit(**options)``, applied when the module is bound."""

        def decorate(function: Any) -> Pending:
            return Pending(function, options, self)

        return decorate

    def intrinsics(self) -> tuple[_Name, ...]:
        """Placeholders of :data:`INTRINSICS`, in that order."""
        return tuple(_Name(n) for n in INTRINSICS)

    def bind(self) -> None:
        """Replace every pending name of the module by numba's object (the modules its kernels come from first)."""
        with _LOCK:
            if self.bound:
                return
            import numba

            ns = self._namespace
            for value in list(ns.values()):
                if isinstance(value, Pending) and value.home is not self:
                    value.home.bind()
            for value in list(ns.values()):
                if isinstance(value, Pending) and value.home is self and value.real is None:
                    value.real = numba.njit(**value.options)(value.py_func)
            for name, value in list(ns.items()):
                if isinstance(value, Pending):
                    ns[name] = value.real
                elif isinstance(value, _Name):
                    ns[name] = value.resolve()
            self.bound = True

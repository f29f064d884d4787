"""Integrals of the closed-loop constructions: definite integrals from 0 by sympy where the integrand is in a
class sympy integrates reliably (an explicit, documented rule), and vectorised Gauss-Legendre quadrature from 0
otherwise."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import sympy as sp

from ..errors import ConvergenceError, InputError, NumericalError

__all__ = [
    "INTEGRAL_CHOICES",
    "integral_choice",
    "symbolic_friendly",
    "integral_from_zero",
    "quadrature_from_zero",
    "ray_quadrature",
]

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(16)


#: How an integral is done (an explicit choice: never a timer, so an output's form never depends on the machine).
INTEGRAL_CHOICES = ("auto", "symbolic", "quadrature")
#: "auto" integrates with sympy only integrands at most this large (sympy's operation count) ...
_AUTO_MAX_OPS = 60
#: ... whose polynomial factors have at most this degree in the variable.
_AUTO_MAX_DEGREE = 6


def integral_choice(value: Any, name: str = "integral") -> str:
    """Validate ``integral=`` (one of :data:`INTEGRAL_CHOICES`)."""
    if value not in INTEGRAL_CHOICES:
        raise InputError(f"Expected `{name}` to be one of {', '.join(map(repr, INTEGRAL_CHOICES))}, got {value!r}.")
    return value


def symbolic_friendly(expr: sp.Expr, var: sp.Symbol) -> bool:
    """Whether ``integral="auto"`` hands ``expr`` (a function of ``var``) to sympy.

    The rule, on the expression and never on the time taken (so a result's form is the same on every machine):
    at most :data:`_AUTO_MAX_OPS` operations, and after expansion every term is a product of

    - rational functions of ``var`` (numerator and denominator of degree at most :data:`_AUTO_MAX_DEGREE`), and
    - powers (up to 4) of sin, cos, exp, sinh, cosh of arguments linear in ``var``; or, alone or with a factor
      linear in ``var`` only for log and atan, one power of tan, tanh, log or atan of such an argument

    (the class sympy integrates in closed form quickly and reliably).
    """
    if sp.count_ops(expr) > _AUTO_MAX_OPS:
        return False
    for term in sp.Add.make_args(sp.expand(expr, trig=False)):
        rational_degree, smooth, awkward = 0, 0, []
        for factor in sp.Mul.make_args(term):
            if not factor.has(var):
                continue
            if factor.is_rational_function(var):
                num, den = sp.fraction(sp.together(factor))
                rational_degree = max(rational_degree, sp.degree(num, var), sp.degree(den, var))
                if rational_degree > _AUTO_MAX_DEGREE:
                    return False
                continue
            base, power = (factor, sp.Integer(1)) if isinstance(factor, sp.exp) else factor.as_base_exp()
            if not (power.is_Integer and 1 <= power <= 4) or len(base.args) != 1:
                return False
            arg = base.args[0]
            if not (arg.is_polynomial(var) and sp.degree(arg, var) <= 1):
                return False
            if isinstance(base, (sp.sin, sp.cos, sp.exp, sp.sinh, sp.cosh)):
                smooth += 1
            elif isinstance(base, (sp.tan, sp.tanh, sp.log, sp.atan)):
                awkward.append(base)
            else:
                return False
        if awkward:
            linear_ok = all(isinstance(b, (sp.log, sp.atan)) for b in awkward)
            if len(awkward) > 1 or smooth or rational_degree > (1 if linear_ok else 0):
                return False
    return True


def integral_from_zero(integrand: sp.Expr, var: sp.Symbol, upper: sp.Expr, integral: str = "auto") -> sp.Expr | None:
    """:math:`\\int_0^{upper} f(s)\\,ds` with ``f = integrand(var -> s)``, or None when it is to be done by
    quadrature: ``integral="quadrature"``, or ``"auto"`` with an integrand outside :func:`symbolic_friendly`'s
    class, or when sympy returns an unevaluated integral or an infinite value."""
    s = sp.Dummy("s", real=True)
    f = integrand.xreplace({var: s})
    if not f.has(s):
        return sp.expand(f * upper)
    if integral == "quadrature" or (integral == "auto" and not symbolic_friendly(f, s)):
        return None
    try:
        res = sp.integrate(f, (s, 0, upper))
    except (NotImplementedError, ValueError, TypeError, AttributeError, RecursionError):
        return None
    if res.has(sp.Integral) or res.has(sp.oo, -sp.oo, sp.zoo, sp.nan) or res.has(sp.exp_polar):
        return None
    return res


def _panels(n_panels: int) -> tuple[np.ndarray, np.ndarray]:
    edges = np.linspace(0.0, 1.0, n_panels + 1)
    h = np.diff(edges)
    t = (edges[:-1, None] + h[:, None] * (_NODES + 1.0) / 2.0).ravel()
    w = (h[:, None] * _WEIGHTS / 2.0).ravel()
    return t, w


def _adaptive(values_at: Callable[[np.ndarray], np.ndarray], what: str, tol: float, max_panels: int) -> np.ndarray:
    """Composite 16-point Gauss-Legendre on [0, 1] in the path parameter, panels doubled until two
    successive estimates agree to ``tol`` (relative, with an absolute floor of ``tol``)."""
    prev = None
    n = 1
    while n <= max_panels:
        t, w = _panels(n)
        with np.errstate(all="ignore"):
            vals = values_at(t)
        if not np.all(np.isfinite(vals)):
            raise NumericalError(
                f"{what}: the integrand is not finite on the path from 0 (is phi defined on the whole segment "
                "from 0 to this momentum?)."
            )
        est = vals @ w
        if prev is not None and np.all(np.abs(est - prev) <= tol * np.maximum(1.0, np.abs(est))):
            return est
        prev = est
        n *= 2
    raise ConvergenceError(
        f"{what}: Gauss-Legendre quadrature did not converge with {max_panels} panels (relative change "
        f"{np.max(np.abs(est - prev) / np.maximum(1.0, np.abs(est))):.3g}); the integrand may be singular there."
    )


def quadrature_from_zero(
    f: Callable[[np.ndarray], np.ndarray],
    x: np.ndarray,
    *,
    what: str = "quadrature",
    tol: float = 1e-14,
    max_panels: int = 256,
) -> np.ndarray:
    """:math:`\\int_0^x f(s)\\,ds` for an array ``x`` (vectorised ``f``), error about ``tol`` relative."""
    x = np.asarray(x, dtype=float)
    return _adaptive(lambda t: x[..., None] * f(x[..., None] * t), what, tol, max_panels)


def ray_quadrature(
    g: Callable[[np.ndarray], np.ndarray],
    m: np.ndarray,
    *,
    what: str = "quadrature",
    tol: float = 1e-14,
    max_panels: int = 256,
) -> np.ndarray:
    """The potential :math:`\\psi(m) = \\int_0^1 g(t m)\\cdot m\\, dt` of a curl-free field ``g`` with
    :math:`\\psi(0) = 0` (``m`` of shape ``(..., 3)``)."""
    m = np.asarray(m, dtype=float)

    def values(t: np.ndarray) -> np.ndarray:
        pts = m[..., None, :] * t[:, None]
        return np.einsum("...ki,...i->...k", g(pts), m)

    return _adaptive(values, what, tol, max_panels)

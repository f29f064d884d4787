"""The source of a compiled model: its functions (``rhs``, ``fjac``, ``grad``, ...) generated from the system's
formulas by the symbolic layer, with the coefficients that depend on the parameters alone hoisted into derived
parameters computed once per run; and the source of its variational equations (the state transition matrix and
the sensitivities to parameters, integrated with the state).
"""

from __future__ import annotations

import functools
from typing import Any

import sympy as sp

from ..symbolic.compile import M_SYMBOLS, compile_vector
from ..symbolic.taylor import taylor_tape
from . import _codegen

__all__ = ["R_SYMBOLS", "model_source", "variational_equations", "variational_source", "vector_field"]

R_SYMBOLS = sp.symbols("r0:9", real=True)


_GF_STUBS = """

@kernel
def gf_all(y, out0, out1, out2, out3, prm):
    return


@kernel
def gf_grads(y, out0, out1, prm):
    return
"""


# -- generated model source ---------------------------------------------------------------------------
@functools.lru_cache(maxsize=64)
def model_source(
    kind: str, layout: str, expr: sp.Expr, variables: tuple, parameters: tuple, features: frozenset[str]
) -> tuple[str, Any]:
    """The model functions' source, and the function that computes the derived parameters they read after the
    given ones (None without any)."""

    def FS(name: str, outputs: tuple, args: tuple, scalar_args: bool = False) -> Any:
        return (name, outputs, args, scalar_args)

    def emit(specs: list, suffix: str = "") -> tuple[str, Any]:
        src, derived = _emit(specs, parameters, suffix)
        if "taylor" in features:
            src += _taylor(kind, layout, expr, variables, parameters)
        return src, derived

    if kind == "rotor":  # the equations of a body with rotors and its torque law, a vector field
        f = list(expr)
        return emit(
            [FS("rhs", (f,), variables), FS("fjac", (f, [[sp.diff(fi, v) for v in variables] for fi in f]), variables)]
        )
    if kind == "canonical":
        n = len(variables) // 2
        g = [sp.diff(expr, v) for v in variables]
        hm = [[sp.diff(gi, v) for v in variables] for gi in g]
        f = g[n:] + [-gi for gi in g[:n]]
        jf = [row for row in hm[n:]] + [[-e for e in row] for row in hm[:n]]
        specs = [
            FS("ham", (expr,), variables),
            FS("grad", (g,), variables),
            FS("ghess", (g, hm), variables),
            FS("rhs", (f,), variables),
            FS("fjac", (f, jf), variables),
        ]
        if "gf" in features:
            w = sum(g[i] * g[n + i] for i in range(n))
            gw = [sp.diff(w, v) for v in variables]
            hw = [[sp.diff(e, v) for v in variables] for e in gw]
            specs += [FS("gf_all", (g, hm, gw, hw), variables), FS("gf_grads", (g, gw), variables)]
            return emit(specs)
        # the symplectic-Euler loop shares code with the generating-function one and numba types every
        # name it calls, taken branch or not: without "gf", inert stand-ins
        return emit(specs, _GF_STUBS)
    # One module per layout, m (d = 3) or (m, R) (d = 12): a module for both, rhs dispatching on the state's
    # length, compiled each loop once for both but cost 40 % of a rigid body's run time in that call.
    m = list(M_SYMBOLS)
    g = [sp.diff(expr, s) for s in m]
    hm = [[sp.diff(gi, s) for s in m] for gi in g]
    fm = [m[1] * g[2] - m[2] * g[1], m[2] * g[0] - m[0] * g[2], m[0] * g[1] - m[1] * g[0]]
    state, f = m, fm
    if layout == "mR":
        R = sp.Matrix(3, 3, R_SYMBOLS)
        w = sp.Matrix([[0, -g[2], g[1]], [g[2], 0, -g[0]], [-g[1], g[0], 0]])
        state, f = m + list(R_SYMBOLS), fm + list(R * w)
    specs = [
        FS("ham", (expr,), tuple(m)),
        FS("ghess3", (g, hm), tuple(m)),
        FS("rhs", (f,), tuple(state)),
        FS("fjac", (f, [[sp.diff(fi, s) for s in state] for fi in f]), tuple(state)),
    ]
    if "split" in features:
        for i in range(3):
            part = g[i].subs({m[j]: 0 for j in range(3) if j != i})
            specs.append(FS(f"dh{i}", (part,), (m[i],), scalar_args=True))
    return emit(specs)


def _taylor(kind: str, layout: str, expr: Any, variables: tuple, parameters: tuple) -> str:
    """The Taylor coefficients of the solution of the model's equations (``taylor_coeffs``, and the rows of its work
    array ``TAYLOR_ROWS``), from the vector field's formulas with their common subexpressions shared."""
    f, state = vector_field(kind, layout, expr, variables)
    replacements, reduced = sp.cse([sp.sympify(e) for e in f], symbols=sp.numbered_symbols("_tc"), order="none")
    return taylor_tape(replacements, state, reduced, list(parameters)).module_source()


def _emit(entries: list, parameters: tuple, suffix: str) -> tuple[str, Any]:
    """Source of the model functions ``entries`` (name, outputs, variables, scalar_args) with the parameter-only
    coefficients hoisted (:func:`_hoist`), and the compiled function of the derived parameters."""
    table: dict[sp.Expr, sp.Symbol] = {}
    pset = frozenset(parameters)

    def hoisted(out: Any) -> Any:
        if isinstance(out, (list, tuple)):
            return [hoisted(o) for o in out]
        return _hoist(sp.sympify(out), pset, table) if pset else out

    entries = [(n, tuple(hoisted(o) for o in outs), v, sc) for n, outs, v, sc in entries]
    derived = list(table.items())
    names = tuple(parameters) + tuple(sym for _, sym in derived)
    specs = [_codegen.FunctionSpec(n, outs, v, scalar_args=sc, parameters=names) for n, outs, v, sc in entries]
    fn = compile_vector([c for c, _ in derived], list(parameters)) if derived else None
    return _codegen.kernel_source(specs) + suffix, fn


def _hoist(e: sp.Expr, pset: frozenset, table: dict) -> sp.Expr:
    """``e`` with every sum's terms grouped by their state-dependent factor and each group's coefficient, an
    expression in the parameters alone, replaced by a derived parameter computed once per run (in ``table``):
    ``m2 m3 / I3 - m3 m2 / I2`` becomes ``m2 m3 d`` with ``d = 1/I3 - 1/I2``, the arithmetic a formula with the
    values written in would have after constant folding. No expansion: each sum is grouped as it stands."""
    if e.is_Atom or not (e.free_symbols & pset):
        return e
    if e.free_symbols <= pset:
        return _derived(e, pset, table)
    args = [_hoist(a, pset, table) for a in e.args]
    if e.is_Add:
        groups: dict[sp.Expr, list[sp.Expr]] = {}
        for t in args:
            c, rest = _coefficient(t, pset)
            groups.setdefault(rest, []).append(c)
        return sp.Add(*(_derived(sp.Add(*cs), pset, table) * rest for rest, cs in groups.items()))
    if e.is_Mul:
        c, rest = _coefficient(sp.Mul(*args), pset)
        return _derived(c, pset, table) * rest
    return e.func(*args)


def _coefficient(t: sp.Expr, pset: frozenset) -> tuple[sp.Expr, sp.Expr]:
    """``t = c * rest`` with ``c`` the factors of ``t`` in the parameters alone (numbers included)."""
    factors = sp.Mul.make_args(t)
    c = [f for f in factors if f.free_symbols <= pset]
    rest = [f for f in factors if not f.free_symbols <= pset]
    return sp.Mul(*c), sp.Mul(*rest)


def _derived(c: sp.Expr, pset: frozenset, table: dict) -> sp.Expr:
    """``c`` itself when it costs nothing (a number, a parameter, a number times a parameter), else its
    derived parameter."""
    if c.is_Number or c in pset:
        return c
    if c.is_Mul and len(c.args) == 2 and c.args[0].is_Number and c.args[1] in pset:
        return c
    if c not in table:
        table[c] = sp.Symbol(f"geomech_derived_{len(table)}", real=True)
    return table[c]


# -- Python model functions (systems from callables, or formulas numba cannot compile) -------------


def vector_field(kind: str, layout: str, expr: Any, variables: tuple) -> tuple[list[sp.Expr], tuple[sp.Symbol, ...]]:
    """The equations of motion ``y' = f(y)`` as formulas and the state's symbols: Hamilton's equations of a
    canonical H(q, p), the Lie-Poisson equations m' = m x grad H (with R' = R (grad H)^ for the layout
    ``"mR"``), or a body with rotors' vector field as it is."""
    if kind == "rotor":
        return list(expr), tuple(variables)
    if kind == "canonical":
        n = len(variables) // 2
        g = [sp.diff(expr, v) for v in variables]
        return g[n:] + [-gi for gi in g[:n]], tuple(variables)
    m = list(M_SYMBOLS)
    g = [sp.diff(expr, s) for s in m]
    f = [m[1] * g[2] - m[2] * g[1], m[2] * g[0] - m[0] * g[2], m[0] * g[1] - m[1] * g[0]]
    if layout != "mR":
        return f, tuple(m)
    R = sp.Matrix(3, 3, R_SYMBOLS)
    w = sp.Matrix([[0, -g[2], g[1]], [g[2], 0, -g[0]], [-g[1], g[0], 0]])
    return f + list(R * w), tuple(m) + tuple(R_SYMBOLS)


@functools.lru_cache(maxsize=32)
def variational_equations(
    kind: str, layout: str, expr: Any, variables: tuple, parameters: tuple, wrt: tuple[str, ...]
) -> tuple[list[sp.Expr], tuple[sp.Symbol, ...]]:
    """The variational equations and their state: for the state y (d numbers), the state transition matrix
    Phi = dy/dy0 (d x d, row-major) and the sensitivities S = dy/dp to the parameters named in ``wrt`` (d x k,
    row-major), ``y' = f(y)``, ``Phi' = J(y) Phi``, ``S' = J(y) S + df/dp`` (from Phi(0) = I and S(0) = 0). A
    parameter the model reads as its reciprocal too (``I1`` and ``I1__inverse``) is differentiated through both."""
    f, state = vector_field(kind, layout, expr, variables)
    d, k = len(state), len(wrt)
    J = sp.Matrix([[sp.diff(fi, v) for v in state] for fi in f])
    Phi = sp.Matrix(d, d, sp.symbols(f"_Phi0:{d * d}", real=True))
    S = sp.Matrix(d, k, sp.symbols(f"_S0:{d * k}", real=True)) if k else sp.zeros(d, 0)
    by_name = {s.name: s for s in parameters}
    Fp = sp.zeros(d, k)
    for j, name in enumerate(wrt):
        p, inverse = by_name[name], by_name.get(f"{name}__inverse")
        for i, fi in enumerate(f):
            Fp[i, j] = sp.diff(fi, p) - (sp.diff(fi, inverse) * inverse**2 if inverse is not None else 0)
    outputs = list(f) + list(J * Phi) + (list(J * S + Fp) if k else [])
    return outputs, tuple(state) + tuple(Phi) + tuple(S)


@functools.lru_cache(maxsize=32)
def variational_source(
    kind: str, layout: str, expr: Any, variables: tuple, parameters: tuple, wrt: tuple[str, ...]
) -> tuple[str, Any]:
    """The source of the right-hand side of :func:`variational_equations` and the derived parameters' function,
    as :func:`model_source`."""
    outputs, aug = variational_equations(kind, layout, expr, variables, parameters, wrt)
    return _emit([("rhs", (outputs,), aug, False)], parameters, "")

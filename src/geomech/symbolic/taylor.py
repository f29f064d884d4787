"""Taylor-mode code: the Taylor coefficients in t of the solution of an ODE whose right-hand side is straight-line
code, by the recurrences of its elementary operations (automatic differentiation in one variable, as in Jorba &
Zou's and heyoka's Taylor methods).

:func:`taylor_source` takes the assignments of a right-hand side (``name = expr``, in order: those
:class:`~geomech.symbolic.compile.StraightLine` records), splits every expression into elementary operations
(sums, products, quotients, powers, exp, log, sin and cos, sinh and cosh, the inverse trigonometric functions)
and prints a numba function ``name(X, W, order, prm)``: ``X[:, 0]`` holds the state x(t0); it fills ``X[:, k]``,
k = 1..order, with the Taylor coefficients x^[k] = x^(k)(t0)/k!, each operation's own coefficients kept in a row
of the work array ``W``. Order k of every operation follows from orders 0..k of its operands (and, for the
functions defined by their derivative, the orders below k of that derivative), so a pass over the operations per
order, ``order`` passes in all, costs O(order^2) per product and function.

The recurrences, for w = F(a), with a^[k] the coefficients (Griewank & Walther, Evaluating derivatives, 13.2;
each is the coefficient of t^k of an identity between series):

- w = a b: w^[k] = sum_{j=0..k} a^[j] b^[k-j];
- w = a / b: w^[k] = (a^[k] - sum_{j=1..k} b^[j] w^[k-j]) / b^[0];
- w = sqrt(a): w^[k] = (a^[k] - sum_{j=1..k-1} w^[j] w^[k-j]) / (2 w^[0]);
- w = a^e, e a constant: w^[k] = sum_{j=0..k-1} (e (k - j) - j) a^[k-j] w^[j] / (k a^[0]);
- w = F(a) with F' = r: w' = r(a) a', so w^[k] = (1/k) sum_{j=1..k} j a^[j] r^[k-j] (exp: r = w; log:
  r = 1/a; sin and cos: r = cos a and -sin a, the one the other's; atan: r = 1/(1 + a^2); ...).

The generated code calls the helpers ``tk_mul``, ``tk_quot``, ``tk_sqrt``, ``tk_pow`` and ``tk_int`` of the
Taylor loop's template (``geomech.integrators._k_taylor``), compiled with it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import sympy as sp

from .compile import _Printer

__all__ = ["taylor_source", "TAYLOR_FUNCTIONS"]

#: The functions the Taylor code knows, with the derivative that defines each (``x`` its argument, ``w`` its value).
_X, _WV = sp.symbols("x w")
_DEFINED_BY_DERIVATIVE = {
    sp.exp: _WV,
    sp.log: 1 / _X,
    sp.sin: sp.cos(_X),
    sp.cos: -sp.sin(_X),
    sp.sinh: sp.cosh(_X),
    sp.cosh: sp.sinh(_X),
    sp.tanh: 1 - _WV**2,
    sp.atan: 1 / (1 + _X**2),
    sp.asin: 1 / sp.sqrt(1 - _X**2),
    sp.acos: -1 / sp.sqrt(1 - _X**2),
    sp.asinh: 1 / sp.sqrt(1 + _X**2),
    sp.acosh: 1 / sp.sqrt(_X**2 - 1),
    sp.atanh: 1 / (1 - _X**2),
}
#: The functions written by others (for real arguments, in sympy's conventions).
_REWRITTEN = {
    sp.tan: lambda u: sp.sin(u) / sp.cos(u),
    sp.cot: lambda u: sp.cos(u) / sp.sin(u),
    sp.sec: lambda u: 1 / sp.cos(u),
    sp.csc: lambda u: 1 / sp.sin(u),
    sp.coth: lambda u: sp.cosh(u) / sp.sinh(u),
    sp.acot: lambda u: sp.atan(1 / u),
}
TAYLOR_FUNCTIONS = (*(f.__name__ for f in (*_DEFINED_BY_DERIVATIVE, *_REWRITTEN)), "sqrt", "powers")


class _Tape:
    """The operations of a Taylor pass: series rows (``_x{i}`` of the state, ``_w{i}`` of the work array) and
    scalar constants (``_k{i}``: of the parameters and numbers only, computed once before the loop)."""

    def __init__(self) -> None:
        self.printer = _Printer({"fully_qualified_modules": True, "standard": "python3"})
        self.series: set[sp.Symbol] = set()
        self.constants: list[str] = []
        self.ops: list[str] = []
        self.memo: dict[sp.Expr, sp.Expr] = {}
        self.n_rows = 0
        self.n_constants = 0

    def code(self, e: sp.Expr) -> str:
        text = self.printer.doprint(e)
        if self.printer._not_supported:
            raise NotImplementedError(f"cannot print {sorted(map(str, self.printer._not_supported))} for numba")
        return text

    # -- references ----------------------------------------------------------------------------------------
    def constant(self, e: sp.Expr) -> sp.Expr:
        """``e`` (of numbers and constants) as a number or a named constant."""
        if e.is_number:
            if e.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
                raise NotImplementedError(f"a formula is not finite: {e}")
            return e
        if isinstance(e, sp.Symbol):
            return e
        if e in self.memo:
            return self.memo[e]
        name = sp.Symbol(f"_k{self.n_constants}")
        self.n_constants += 1
        self.constants.append(f"{name} = {self.code(e)}")
        self.memo[e] = name
        return name

    def row(self) -> sp.Symbol:
        name = sp.Symbol(f"_w{self.n_rows}")
        self.n_rows += 1
        self.series.add(name)
        return name

    def is_series(self, e: sp.Expr) -> bool:
        return isinstance(e, sp.Symbol) and e in self.series

    def at_k(self, e: sp.Expr) -> str:
        """Order k of a reference: the row's entry, or a constant at order 0 only."""
        if self.is_series(e):
            return f"{e}[k]"
        return f"({self.code(e)} if k == 0 else 0.0)"

    # -- the operations ------------------------------------------------------------------------------------
    def lower(self, e: sp.Expr) -> sp.Expr:
        """A reference (series row or constant) to the value of ``e``, whose symbols are references."""
        if e.is_Atom:
            return e if (isinstance(e, sp.Symbol) or e.is_number) else self.constant(e)
        if isinstance(e, sp.Add):
            return self._add(e)
        if isinstance(e, sp.Mul):
            return self._mul(e)
        args = [self.lower(a) for a in e.args]
        if not any(self.is_series(a) for a in args):
            return self.constant(e.func(*args))
        key = e.func(*args)
        if key in self.memo:
            return self.memo[key]
        if isinstance(e, sp.Pow):
            out = self._pow(*args)
        elif e.func in _REWRITTEN:
            out = self.lower(_REWRITTEN[e.func](args[0]))
        elif e.func in _DEFINED_BY_DERIVATIVE:
            out = self._by_derivative(e.func, args[0])
        else:
            raise NotImplementedError(f"no Taylor recurrence for {e.func}")
        self.memo[key] = out
        return out

    def _add(self, e: sp.Expr) -> sp.Expr:
        """A sum: one row, its numeric coefficients folded in, its constant terms at order 0."""
        const: list[sp.Expr] = []
        terms: list[tuple[sp.Expr, sp.Expr]] = []
        for a in e.args:
            c, rest = a.as_coeff_Mul()
            ref = self.lower(rest)
            if self.is_series(ref):
                terms.append((c, ref))
            else:
                const.append(c * ref)
        if not terms:
            return self.constant(sp.Add(*const))
        key = sp.Add(*const, *[c * r for c, r in terms])
        if key in self.memo:
            return self.memo[key]
        w = self.row()
        text = " + ".join(f"{r}[k]" if c == 1 else f"{self.code(c)} * {r}[k]" for c, r in terms)
        if const:
            text += f" + ({self.code(self.constant(sp.Add(*const)))} if k == 0 else 0.0)"
        self.ops.append(f"{w}[k] = {text}")
        self.memo[key] = w
        return w

    def _mul(self, e: sp.Expr) -> sp.Expr:
        """A product, with its factors of negative integer power as one quotient."""
        num: list[sp.Expr] = []
        den: list[sp.Expr] = []
        for a in e.args:
            if isinstance(a, sp.Pow) and a.exp.is_Integer and a.exp < 0:
                den.append(self.lower(a.base ** (-a.exp)))
            else:
                num.append(self.lower(a))
        c = sp.Mul(*[a for a in num if not self.is_series(a)])
        d = sp.Mul(*[a for a in den if not self.is_series(a)])
        num = [a for a in num if self.is_series(a)]
        den = [a for a in den if self.is_series(a)]
        c = self.constant(c / d) if d != 1 else c
        if not num and not den:
            return self.constant(c)
        key = sp.Mul(c, *num, *[sp.Pow(b, -1) for b in den])
        if key in self.memo:
            return self.memo[key]
        top = self._product(num)
        bottom = self._product(den)
        if bottom is None:
            assert top is not None
            out = top if c == 1 else self._scaled(c, top)
        else:
            w = self.row()
            at = (f"{top}[k]" if c == 1 else f"{self.code(c)} * {top}[k]") if top is not None else self.at_k(c)
            self.ops.append(f"{w}[k] = tk_quot({at}, {w}, {bottom}, k)")
            out = w
        self.memo[key] = out
        return out

    def _product(self, factors: list[sp.Expr]) -> sp.Expr | None:
        """The product of series rows (None for none), pairwise."""
        if not factors:
            return None
        out = factors[0]
        for b in factors[1:]:
            key = sp.Mul(out, b)
            if key not in self.memo:
                w = self.row()
                self.ops.append(f"{w}[k] = tk_mul({out}, {b}, k)")
                self.memo[key] = w
            out = self.memo[key]
        return out

    def _scaled(self, c: sp.Expr, a: sp.Expr) -> sp.Expr:
        w = self.row()
        self.ops.append(f"{w}[k] = {self.code(c)} * {a}[k]")
        return w

    def _pow(self, base: sp.Expr, e: sp.Expr) -> sp.Expr:
        if not self.is_series(base):  # c**a(t) = exp(a log c)
            return self.lower(sp.exp(e * sp.log(base)))
        if self.is_series(e):
            return self.lower(sp.exp(e * sp.log(base)))
        if e.is_Integer:
            n = int(e)
            if n < 0:
                return self._reciprocal(self._pow(base, sp.Integer(-n)))
            if n == 0:
                return sp.Integer(1)
            if n == 1:
                return base
            half = self._pow(base, sp.Integer(n // 2))
            square = self._product([half, half])
            assert square is not None
            return square if n % 2 == 0 else self._product([square, base])
        if e.is_Rational and e.q == 2:
            root = self.memo.get(sp.sqrt(base))
            if root is None:
                root = self.row()
                self.ops.append(f"{root}[k] = math.sqrt({base}[0]) if k == 0 else tk_sqrt({root}, {base}, k)")
                self.memo[sp.sqrt(base)] = root
            return self._pow(root, sp.Integer(e.p))
        w = self.row()
        self.ops.append(f"{w}[k] = {base}[0] ** {self.code(e)} if k == 0 else tk_pow({w}, {base}, {self.code(e)}, k)")
        return w

    def _reciprocal(self, b: sp.Expr) -> sp.Expr:
        key = sp.Pow(b, -1)
        if key in self.memo:
            return self.memo[key]
        w = self.row()
        self.ops.append(f"{w}[k] = tk_quot((1.0 if k == 0 else 0.0), {w}, {b}, k)")
        self.memo[key] = w
        return w

    def _by_derivative(self, f: Any, a: sp.Expr) -> sp.Expr:
        w = self.row()
        self.memo[f(a)] = w  # before its derivative, which may read it (exp, tanh) or its twin (sin and cos)
        self.ops.append(f"{w}[k] = {self.code(f(sp.Symbol(f'{a}[0]')))} if k == 0 else tk_int({a}, RDER, k)")
        at = len(self.ops) - 1
        r = self.lower(_DEFINED_BY_DERIVATIVE[f].xreplace({_X: a, _WV: w}))
        if not self.is_series(r):  # pragma: no cover - every function above has a derivative varying with a
            raise NotImplementedError(f"{f}: a constant derivative")
        self.ops[at] = self.ops[at].replace("RDER", str(r))
        return w


def taylor_source(
    name: str,
    assignments: Sequence[tuple[sp.Symbol, sp.Expr]],
    state: Sequence[sp.Symbol | None],
    derivatives: Sequence[Any],
    parameters: Sequence[sp.Symbol],
) -> tuple[str, int]:
    """The numba source of ``name(X, W, order, prm)``: the Taylor coefficients to ``order`` of the solution of
    ``x_i' = derivatives[i]`` from ``X[:, 0]``, and the number of rows its work array ``W`` needs.

    ``assignments`` (``symbol = expression``, in order) define the derivatives from the state's symbols
    (``state[i]`` the symbol of ``X[i]``, None where the right-hand side does not read it) and the ``parameters``
    (``parameters[i]`` read as ``prm[i]``). Raises ``NotImplementedError`` for a function with no recurrence here
    (:data:`TAYLOR_FUNCTIONS` lists those there are).
    """
    tape = _Tape()
    env: dict[sp.Symbol, sp.Expr] = {}
    for i, s in enumerate(state):
        if s is not None:
            row = sp.Symbol(f"_x{i}")
            tape.series.add(row)
            env[s] = row
    for i, p in enumerate(parameters):
        env[p] = sp.Symbol(f"_p{i}")
    for sym, e in assignments:
        env[sym] = tape.lower(sp.sympify(e).xreplace(env))
    outs = [tape.lower(sp.sympify(e).xreplace(env)) for e in derivatives]
    lines = [f"@kernel\ndef {name}(X, W, order, prm):"]
    lines += [f"    _p{i} = prm[{i}]" for i in range(len(parameters))]
    lines += [f"    {c}" for c in tape.constants]
    lines += [f"    _x{i} = X[{i}]" for i, s in enumerate(state) if s is not None]
    lines += [f"    _w{i} = W[{i}]" for i in range(tape.n_rows)]
    lines.append("    for k in range(order):")
    lines += [f"        {op}" for op in tape.ops]
    lines += [f"        X[{i}, k + 1] = {tape.at_k(o)} / (k + 1)" for i, o in enumerate(outs)]
    return "\n".join(lines) + "\n", tape.n_rows

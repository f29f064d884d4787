"""Taylor-mode code: the Taylor coefficients in t of the solution of an ODE whose right-hand side is straight-line
code, by the recurrences of its elementary operations (automatic differentiation in one variable, as in Jorba &
Zou's and heyoka's Taylor methods).

:func:`taylor_tape` takes the assignments of a right-hand side (``name = expr``, in order: those
:class:`~geomech.symbolic.compile.StraightLine` records) and splits every expression into elementary operations
(sums, products, quotients, powers, exp, log, sin, cos and tan, sinh, cosh and tanh, the inverse functions):
a :class:`TaylorTape`, plain data. Its :meth:`~TaylorTape.source` prints a numba function
``name(X, W, order, prm)``: ``X[:, 0]`` holds the state x(t0); it fills ``X[:, k]``, k = 1..order, with the
Taylor coefficients x^[k] = x^(k)(t0)/k!, each operation's own coefficients kept in a row of the work array
``W``. Order k of every operation follows from orders 0..k of its operands (and, for the functions defined by
their derivative, the orders below k of that derivative), so a pass over the operations per order, ``order``
passes in all, costs O(order^2) per product and function. That loop runs every operation at a run-time order;
:mod:`geomech.integrators._taylor_llvm` compiles the same tape for one order with every sum written out, as
heyoka does, for a few times less work per step (the loop is the "compact" form, for tapes too large to unroll).

The recurrences, for w = F(a), with a^[k] the coefficients (Griewank & Walther, Evaluating derivatives, 13.2;
each is the coefficient of t^k of an identity between series):

- w = a b: w^[k] = sum_{j=0..k} a^[j] b^[k-j];
- w = a / b: w^[k] = (a^[k] - sum_{j=1..k} b^[j] w^[k-j]) / b^[0];
- w = sqrt(a): w^[k] = (a^[k] - sum_{j=1..k-1} w^[j] w^[k-j]) / (2 w^[0]);
- w = a^e, e a constant: w^[k] = sum_{j=0..k-1} (e (k - j) - j) a^[k-j] w^[j] / (k a^[0]);
- w = F(a) with F' = r: w' = r(a) a', so w^[k] = (1/k) sum_{j=1..k} j a^[j] r^[k-j] (exp: r = w; log:
  r = 1/a; sin and cos: r = cos a and -sin a, the one the other's; tan: r = 1 + w^2, one product, where
  sin a / cos a took two functions and a quotient; atan: r = 1/(1 + a^2); ...).

The generated code calls the helpers ``tk_mul``, ``tk_quot``, ``tk_sqrt``, ``tk_pow`` and ``tk_int`` of the
Taylor loop's template (``geomech.integrators._k_taylor``), compiled with it.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import sympy as sp

from .compile import _Printer

__all__ = ["TaylorTape", "taylor_tape", "TAYLOR_FUNCTIONS"]

#: The functions the Taylor code knows, with the derivative that defines each (``x`` its argument, ``w`` its value).
_X, _WV = sp.symbols("x w")
_DEFINED_BY_DERIVATIVE = {
    sp.exp: _WV,
    sp.log: 1 / _X,
    sp.sin: sp.cos(_X),
    sp.cos: -sp.sin(_X),
    sp.sinh: sp.cosh(_X),
    sp.cosh: sp.sinh(_X),
    sp.tan: 1 + _WV**2,
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
    sp.cot: lambda u: sp.cos(u) / sp.sin(u),
    sp.sec: lambda u: 1 / sp.cos(u),
    sp.csc: lambda u: 1 / sp.sin(u),
    sp.coth: lambda u: sp.cosh(u) / sp.sinh(u),
    sp.acot: lambda u: sp.atan(1 / u),
}
TAYLOR_FUNCTIONS = (*(f.__name__ for f in (*_DEFINED_BY_DERIVATIVE, *_REWRITTEN)), "sqrt", "powers")


Ref = Any  # a series row's name ("_x3", "_w7"), a constant's ("_k2", "_p0"), or a float


@dataclass(frozen=True)
class TaylorTape:
    """The elementary operations of a Taylor pass, as plain data (a Python literal: the generated model module
    keeps it, and :mod:`geomech.integrators._taylor_llvm` compiles it for one order, unrolled).

    A reference is a series row (``_x{i}`` the state's row ``X[i]``, ``_w{i}`` the work array's ``W[i]``), a
    constant (``_p{i}`` the parameter ``prm[i]``, ``_k{i}`` one of ``constants``) or a float. The operations, in
    order, each filling the row ``w``:

    - ``("lin", w, ((c, a), ...), c0)``: sum of c a (c a float or constant), plus c0 (None or a constant) at
      order 0;
    - ``("mul", w, a, b)``: the product a b (a square when a is b);
    - ``("quot", w, c, a, b)``: c a / b, or c / b where ``a`` is None;
    - ``("sqrt", w, a)``, ``("pow", w, a, e)`` (e a float or a constant);
    - ``("int", w, f, a, r)``: w = f(a) with f' (a) = r, f a name of :data:`TAYLOR_FUNCTIONS`' first part.

    ``outputs`` are the derivatives of the state (references), ``constants`` the ``(name, code)`` of the
    parameter-only constants (numba code of the ``_p{i}`` and the constants before them), ``state`` the rows of
    ``X`` the operations read.
    """

    n_rows: int
    n_parameters: int
    constants: tuple[tuple[str, str], ...]
    state: tuple[int, ...]
    ops: tuple[tuple[Any, ...], ...]
    outputs: tuple[Ref, ...]

    def data(self) -> tuple[Any, ...]:
        """The tape as a Python literal (``repr`` of it is valid source); :meth:`from_data` inverts it."""
        return (self.n_rows, self.n_parameters, self.constants, self.state, self.ops, self.outputs)

    @classmethod
    def from_data(cls, data: tuple[Any, ...]) -> TaylorTape:
        return cls(*data)

    def multiply_adds(self, order: int) -> int:
        """The multiply-adds of the recurrences' sums for the orders 0..order-1 (the size of a pass)."""
        sums = sum(1 for op in self.ops if op[0] in ("mul", "quot", "sqrt", "pow", "int"))
        linear = sum(len(op[2]) for op in self.ops if op[0] == "lin")
        return sums * order * (order + 1) // 2 + linear * order

    def source(self, name: str) -> str:
        """The numba source of ``name(X, W, order, prm)``: the coefficients to ``order`` by a loop over the orders
        (its work array ``W`` of ``n_rows`` rows)."""

        def at(r: Ref) -> str:
            if isinstance(r, str) and r[1] in "xw":
                return f"{r}[k]"
            return f"({_number(r)} if k == 0 else 0.0)"

        def scaled(c: Ref, r: str) -> str:
            return f"{r}[k]" if c == 1.0 else f"{_number(c)} * {r}[k]"

        body: list[str] = []
        for op in self.ops:
            kind, w = op[0], op[1]
            if kind == "lin":
                text = " + ".join(scaled(c, r) for c, r in op[2])
                if op[3] is not None:
                    text += f" + ({_number(op[3])} if k == 0 else 0.0)"
            elif kind == "mul":
                text = f"tk_mul({op[2]}, {op[3]}, k)"
            elif kind == "quot":
                top = at(op[2]) if op[3] is None else scaled(op[2], op[3])
                text = f"tk_quot({top}, {w}, {op[4]}, k)"
            elif kind == "sqrt":
                text = f"math.sqrt({op[2]}[0]) if k == 0 else tk_sqrt({w}, {op[2]}, k)"
            elif kind == "pow":
                e = _number(op[3])
                text = f"{op[2]}[0] ** {e} if k == 0 else tk_pow({w}, {op[2]}, {e}, k)"
            else:  # "int"
                text = f"math.{op[2]}({op[3]}[0]) if k == 0 else tk_int({op[3]}, {op[4]}, k)"
            body.append(f"        {w}[k] = {text}")
        lines = [f"@kernel\ndef {name}(X, W, order, prm):"]
        lines += [f"    _p{i} = prm[{i}]" for i in range(self.n_parameters)]
        lines += [f"    {c} = {code}" for c, code in self.constants]
        lines += [f"    _x{i} = X[{i}]" for i in self.state]
        lines += [f"    _w{i} = W[{i}]" for i in range(self.n_rows)]
        lines.append("    for k in range(order):")
        lines += body
        lines += [f"        X[{i}, k + 1] = {at(o)} / (k + 1)" for i, o in enumerate(self.outputs)]
        return "\n".join(lines) + "\n"

    def constants_source(self, name: str) -> str:
        """The numba source of ``name(K, prm)``: the constants ``_k{i}`` into ``K[i]`` (for the unrolled code,
        which reads them there)."""
        lines = [f"@kernel\ndef {name}(K, prm):"]
        lines += [f"    _p{i} = prm[{i}]" for i in range(self.n_parameters)]
        for c, code in self.constants:
            lines += [f"    {c} = {code}", f"    K[{c[2:]}] = {c}"]
        lines.append("    return None")
        return "\n".join(lines) + "\n"

    def module_source(self) -> str:
        """The part of a generated model module Taylor's method reads: ``TAYLOR_ROWS``, ``TAYLOR_TAPE`` (this tape's
        data), ``taylor_coeffs`` (:meth:`source`) and ``taylor_constants`` (:meth:`constants_source`)."""
        return (
            f"\n\nTAYLOR_ROWS = {self.n_rows}\nTAYLOR_TAPE = {self.data()!r}\n\n\n"
            + self.source("taylor_coeffs")
            + "\n\n"
            + self.constants_source("taylor_constants")
        )


def _number(r: Ref) -> str:
    return repr(r) if isinstance(r, float) else str(r)


def _row_order(row: sp.Symbol) -> tuple[str, int]:
    """The state's rows, then the work array's in the order they were made."""
    return (row.name[1], int(row.name[2:]))


class _Tape:
    """The lowering of straight-line assignments to the operations of a :class:`TaylorTape`."""

    def __init__(self) -> None:
        self.printer = _Printer({"fully_qualified_modules": True, "standard": "python3"})
        self.series: set[sp.Symbol] = set()
        self.constants: list[tuple[str, str]] = []
        self.ops: list[tuple[Any, ...]] = []
        self.memo: dict[sp.Expr, sp.Expr] = {}
        # the products made, by their factors' names sorted (a multiset), and each factor's products
        self.products: dict[tuple[str, ...], sp.Symbol] = {}
        self.with_factor: dict[str, list[tuple[str, ...]]] = {}
        self.n_rows = 0

    def code(self, e: sp.Expr) -> str:
        text = self.printer.doprint(e)
        if self.printer._not_supported:
            raise NotImplementedError(f"cannot print {sorted(map(str, self.printer._not_supported))} for numba")
        return text

    # -- references ----------------------------------------------------------------------------------------
    def constant(self, e: sp.Expr) -> sp.Expr:
        """``e`` (of numbers and constants) as a number or a named constant."""
        if e.is_number:
            if e.has(sp.zoo, sp.oo, -sp.oo, sp.nan) or not e.is_finite:
                raise NotImplementedError(f"a formula is not finite: {e}")
            return e
        if isinstance(e, sp.Symbol):
            return e
        if e in self.memo:
            return self.memo[e]
        name = sp.Symbol(f"_k{len(self.constants)}")
        self.constants.append((str(name), self.code(e)))
        self.memo[e] = name
        return name

    def ref(self, e: sp.Expr) -> Ref:
        """The tape's reference to a series row or constant (a float for a number)."""
        if isinstance(e, sp.Symbol):
            return str(e)
        if not e.is_number:
            return str(self.constant(e))
        value = complex(sp.N(e, 20))
        if value.imag != 0.0:
            raise NotImplementedError(f"a formula is not real: {e}")
        return float(value.real)

    def row(self) -> sp.Symbol:
        name = sp.Symbol(f"_w{self.n_rows}")
        self.n_rows += 1
        self.series.add(name)
        return name

    def is_series(self, e: sp.Expr) -> bool:
        return isinstance(e, sp.Symbol) and e in self.series

    def varies(self, e: sp.Expr) -> bool:
        """Whether ``e`` reads a series row (else it is a constant: numbers, parameters, constants)."""
        return not self.series.isdisjoint(e.free_symbols)

    def split(self, e: sp.Expr) -> tuple[sp.Expr, sp.Expr]:
        """``e`` as (constant factor, varying factor): ``(2*_p0, _w3*_w5)`` for ``2*_p0*_w3*_w5``."""
        factors = e.args if isinstance(e, sp.Mul) else (e,)
        fixed = [f for f in factors if not self.varies(f)]
        return sp.Mul(*fixed), sp.Mul(*[f for f in factors if self.varies(f)])

    def lower_scaled(self, e: sp.Expr) -> sp.Expr:
        """Like :meth:`lower`, but a constant multiple ``c r`` of a series row ``r`` is kept as that product (an
        assignment's value, folded by sympy into the coefficients of the sums and products that read it) rather
        than written to a row of its own."""
        c, rest = self.split(e)
        if c == 1 or rest == 1:
            return self.lower(e)
        ref = self.lower(rest)
        return self.constant(c) * ref if self.is_series(ref) else self.constant(c * ref)

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
        """A sum: one row, its coefficients (numbers and constants) folded in, its constant terms at order 0."""
        const: list[sp.Expr] = []
        terms: dict[sp.Expr, list[sp.Expr]] = {}
        for a in e.args:
            c, rest = self.split(a)  # its coefficient (numbers, parameters, constants) apart from what varies
            ref = self.lower(rest)
            if self.is_series(ref):
                terms.setdefault(ref, []).append(c)
            else:
                const.append(c * ref)
        terms = {r: cs for r, cs in terms.items() if sp.Add(*cs) != 0}
        if not terms:
            return self.constant(sp.Add(*const))
        key = sp.Add(*const, *[sp.Add(*cs) * r for r, cs in terms.items()])
        if key in self.memo:
            return self.memo[key]
        w = self.row()
        pairs = tuple((self.ref(self.constant(sp.Add(*cs))), str(r)) for r, cs in terms.items())
        c0 = self.ref(self.constant(sp.Add(*const))) if const else None
        self.ops.append(("lin", str(w), pairs, c0))
        self.memo[key] = w
        return w

    def _mul(self, e: sp.Expr) -> sp.Expr:
        """A product, with its factors of negative integer power as one quotient."""
        num: list[sp.Expr] = []
        den: list[sp.Expr] = []
        for a in e.args:
            if isinstance(a, sp.Pow) and a.exp.is_Integer and a.exp < 0:
                b = self.lower(a.base)
                inverse = self.memo.get(sp.Pow(b, -1)) if self.is_series(b) else None
                # a reciprocal already made is a factor of the product (1/b^2: its square, one product)
                (den if inverse is None else num).extend([b if inverse is None else inverse] * int(-a.exp))
            else:
                num.append(self.lower(a))
        c = sp.Mul(*[a for a in num if not self.is_series(a)])
        d = sp.Mul(*[a for a in den if not self.is_series(a)])
        num = [a for a in num if self.is_series(a)]
        den = [a for a in den if self.is_series(a)]
        c = self.constant(c / d) if d != 1 else self.constant(c)
        if not num and not den:
            return c
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
            self.ops.append(("quot", str(w), self.ref(c), None if top is None else str(top), str(bottom)))
            out = w
        self.memo[key] = out
        return out

    def _product(self, factors: list[sp.Expr]) -> sp.Expr | None:
        """The product of series rows (None for none), by products of two: the largest product already made of some
        of them reused (the tape's products of three or more rows share their common parts, whatever the order
        sympy gave each), the others taken in the order of their rows."""
        if not factors:
            return None
        if len(factors) == 1:
            return factors[0]
        order = sorted(factors, key=_row_order)
        key = tuple(str(f) for f in order)
        if key in self.products:
            return self.products[key]
        need = Counter(key)
        best: tuple[str, ...] = ()
        for name in need:
            for made in self.with_factor.get(name, ()):
                if len(best) < len(made) < len(key) and not Counter(made) - need:
                    best = made
        if best:
            rest = list((need - Counter(best)).elements())
            a, b = self.products[best], self._product([sp.Symbol(n) for n in rest])
        else:
            a, b = self._product(order[:-1]), order[-1]
        assert a is not None and b is not None
        w = self.row()
        self.ops.append(("mul", str(w), str(a), str(b)))
        self.products[key] = w
        for name in need:
            self.with_factor.setdefault(name, []).append(key)
        return w

    def _scaled(self, c: sp.Expr, a: sp.Expr) -> sp.Expr:
        w = self.row()
        self.ops.append(("lin", str(w), ((self.ref(c), str(a)),), None))
        return w

    def _pow(self, base: sp.Expr, e: sp.Expr) -> sp.Expr:
        if not self.is_series(base):  # c**a(t) = exp(a log c)
            return self.lower(sp.exp(e * sp.log(base)))
        if self.is_series(e):
            return self.lower(sp.exp(e * sp.log(base)))
        if e.is_Integer:
            n = int(e)
            if n < 0:
                inverse = self.memo.get(sp.Pow(base, -1))
                if inverse is not None:  # 1/b^n from 1/b already made: products only
                    return self._pow(inverse, sp.Integer(-n))
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
                self.ops.append(("sqrt", str(root), str(base)))
                self.memo[sp.sqrt(base)] = root
            return self._pow(root, sp.Integer(e.p))
        w = self.row()
        self.ops.append(("pow", str(w), str(base), self.ref(self.constant(e))))
        return w

    def _reciprocal(self, b: sp.Expr) -> sp.Expr:
        key = sp.Pow(b, -1)
        if key in self.memo:
            return self.memo[key]
        w = self.row()
        self.ops.append(("quot", str(w), 1.0, None, str(b)))
        self.memo[key] = w
        return w

    def _by_derivative(self, f: Any, a: sp.Expr) -> sp.Expr:
        w = self.row()
        self.memo[f(a)] = w  # before its derivative, which may read it (exp, tanh) or its twin (sin and cos)
        at = len(self.ops)
        self.ops.append(("int", str(w), f.__name__, str(a), None))
        r = self.lower(_DEFINED_BY_DERIVATIVE[f].xreplace({_X: a, _WV: w}))
        if not self.is_series(r):  # pragma: no cover - every function above has a derivative varying with a
            raise NotImplementedError(f"{f}: a constant derivative")
        self.ops[at] = ("int", str(w), f.__name__, str(a), str(r))
        return w


def taylor_tape(
    assignments: Sequence[tuple[sp.Symbol, sp.Expr]],
    state: Sequence[sp.Symbol | None],
    derivatives: Sequence[Any],
    parameters: Sequence[sp.Symbol],
) -> TaylorTape:
    """The Taylor pass of ``x_i' = derivatives[i]``: its operations, from which :meth:`TaylorTape.source` prints
    the coefficients' loop and :mod:`geomech.integrators._taylor_llvm` the same unrolled for one order.

    ``assignments`` (``symbol = expression``, in order) define the derivatives from the state's symbols
    (``state[i]`` the symbol of ``X[i]``, None where the right-hand side does not read it) and the ``parameters``
    (``parameters[i]`` read as ``prm[i]``). Raises ``NotImplementedError`` for a function with no recurrence here
    (:data:`TAYLOR_FUNCTIONS` lists those there are).
    """
    tape = _Tape()
    env: dict[sp.Symbol, sp.Expr] = {}
    rows: list[int] = []
    for i, s in enumerate(state):
        if s is not None:
            row = sp.Symbol(f"_x{i}")
            tape.series.add(row)
            env[s] = row
            rows.append(i)
    for i, p in enumerate(parameters):
        env[p] = sp.Symbol(f"_p{i}")
    for sym, e in assignments:
        env[sym] = tape.lower_scaled(sp.sympify(e).xreplace(env))
    outs = tuple(tape.ref(tape.lower(sp.sympify(e).xreplace(env))) for e in derivatives)
    return TaylorTape(tape.n_rows, len(parameters), tuple(tape.constants), tuple(rows), tuple(tape.ops), outs)

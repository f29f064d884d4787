"""Formulas to numeric functions: canonical symbols, binding a user formula to its variables and parameters, and
compiling expressions to numeric functions: vectorised numpy functions (:func:`compile_vector` and its kin) and
the source of numba kernels (:func:`kernel_source`), both with their common subexpressions shared. Every
formula-to-function step of the package goes through here."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from ..errors import InputError, SymbolicError
from .formula import parse_formula

#: Body angular momentum components, the variables of a left-invariant Hamiltonian H(m).
M_SYMBOLS: tuple[sp.Symbol, sp.Symbol, sp.Symbol] = sp.symbols("m1 m2 m3", real=True)


def bind_expression(
    expression: Any,
    parameters: Mapping[str, float] | None,
    variables: Sequence[sp.Symbol],
    argname: str,
) -> tuple[sp.Expr, dict[str, float]]:
    """Parse a user formula, rename its variables to the canonical ``variables`` (matched by name),
    make every other symbol a real parameter, and check that each parameter has a finite value.

    Returns the expression (with parameters still symbolic) and the parameter values by name.
    """
    if isinstance(expression, str):
        expression = parse_formula(expression, argname)
    if not isinstance(expression, sp.Basic):
        raise SymbolicError(
            f"Expected `{argname}` to be a sympy expression or a string, got {type(expression).__name__}."
        )
    expr = expression
    undefined = sorted({str(f.func) for f in expr.atoms(sp.Function) if isinstance(f, sp.core.function.AppliedUndef)})
    if undefined:
        raise SymbolicError(
            f"`{argname}` calls unknown function(s) {undefined}; use sympy's functions (sin, exp, "
            "sqrt, tanh, ...), or build the system from a Python callable instead of a formula."
        )
    names = {str(v): v for v in variables}
    rename = {}
    params_in_expr = set()
    for s in expr.free_symbols:
        if str(s) in names:
            rename[s] = names[str(s)]
        else:
            params_in_expr.add(str(s))
            rename[s] = sp.Symbol(str(s), real=True)
    expr = expr.xreplace(rename)
    given = dict(parameters or {})
    missing = sorted(params_in_expr - set(given))
    if missing:
        raise SymbolicError(
            f"`{argname}` has symbols {missing} that are neither variables {sorted(names)} nor given in "
            f"`parameters`; pass parameters={{{', '.join(repr(m) + ': ...' for m in missing)}}}."
        )
    unused = sorted(set(given) - params_in_expr)
    values: dict[str, float] = {}
    for k in sorted(params_in_expr):
        try:
            v = float(given[k])
        except (TypeError, ValueError) as exc:
            raise SymbolicError(f"Expected parameter `{k}` to be a number, got {given[k]!r}.") from exc
        if not np.isfinite(v):
            raise SymbolicError(f"Expected parameter `{k}` to be finite, got {v}.")
        values[k] = v
    if unused:
        raise SymbolicError(f"`parameters` names {unused}, which do not appear in `{argname}`.")
    if expr.has(sp.I) or expr.has(sp.zoo, sp.oo, sp.nan):
        raise SymbolicError(f"`{argname}` must be a finite real expression, got {expr}.")
    if values:
        with_values = expr.subs({sp.Symbol(k, real=True): v for k, v in values.items()})
        if with_values.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
            shown = ", ".join(f"{k} = {v:g}" for k, v in values.items())
            raise SymbolicError(
                f"`{argname}` is not finite at the parameter values {shown} (a division by zero "
                "or a pole there); choose other values."
            )
    return expr, values


def _lambdify(exprs: Any, variables: Sequence[sp.Symbol]):
    flat = exprs if isinstance(exprs, list) else [exprs]
    if any(isinstance(e, sp.Basic) and e.has(sp.zoo, sp.oo, -sp.oo, sp.nan) for e in flat):
        raise SymbolicError(
            "A formula to compile is not finite (it holds a division by zero or a pole at the "
            "given parameter values): "
            + ", ".join(str(e) for e in flat if isinstance(e, sp.Basic) and e.has(sp.zoo, sp.oo, sp.nan))[:300]
            + "."
        )
    # numpy for the elementary functions, scipy.special for the rest (elliptic integrals, erf, ...): scipy only
    # where a formula needs it (importing scipy.special costs more than compiling a small formula)
    special = any(
        type(f).__name__ not in _NUMPY_FUNCTIONS for e in flat if isinstance(e, sp.Basic) for f in e.atoms(sp.Function)
    )
    # numpy as the module rather than its name: sympy then takes the module's namespace as it is, where by name it
    # runs ``from numpy import *``, which imports every lazily loaded submodule of numpy (numpy.testing, f2py, ...:
    # 0.1 s, a third of a compiled model's first solve from a warm cache); the printed code is the same
    return sp.lambdify(list(variables), exprs, modules=["scipy", "numpy"] if special else [np], cse=True)


#: The functions (sympy's class names) that sympy's numpy printer writes with numpy alone.
_NUMPY_FUNCTIONS = frozenset(
    "sin cos tan asin acos atan atan2 sinh cosh tanh asinh acosh atanh exp log sign floor ceiling Abs Min Max "
    "Piecewise re im arg".split()
)


def compile_scalar(expr: sp.Expr, variables: Sequence[sp.Symbol]):
    """Compile ``expr`` to ``f(x)`` with ``x`` of shape ``(..., n)``, returning shape ``(...)``."""
    f = _lambdify(expr, variables)

    def scalar(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        out = f(*np.moveaxis(x, -1, 0))
        return np.broadcast_to(np.asarray(out, dtype=float), x.shape[:-1]).copy()

    return scalar


def compile_vector(exprs: Any, variables: Sequence[sp.Symbol], *, dtype: Any = float):
    """Compile a (nested) list of expressions to ``f(x)`` with ``x`` of shape ``(..., n)``, returning
    an array of shape ``(..., *shape)``; constant entries are broadcast. ``dtype=complex`` evaluates at
    complex points (derivatives by complex step)."""
    arr = np.array(exprs, dtype=object)
    shape = arr.shape
    flat = list(arr.ravel())
    if not flat:

        def empty(x: np.ndarray) -> np.ndarray:
            return np.zeros(np.shape(x)[:-1] + shape, dtype=dtype)

        return empty
    f = _lambdify(flat, variables)

    def vector(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=dtype)
        batch = x.shape[:-1]
        if not batch:  # one point: every entry is a scalar (the common case inside an integrator's step)
            return np.array(f(*x), dtype=dtype).reshape(shape)
        vals = f(*np.moveaxis(x, -1, 0))
        out = np.empty(batch + (len(vals),), dtype=dtype)
        for i, v in enumerate(vals):  # an assignment broadcasts the constant entries
            out[..., i] = v
        return out.reshape(batch + shape)

    return vector


def evaluate(exprs: Any, variables: Sequence[sp.Symbol], points: Any, *, dtype: Any = float) -> np.ndarray:
    """The (nested list, or matrix, of) expressions at ``points`` (shape ``(..., n)``, the ``variables``' values)
    by one walk of their graph, each distinct subexpression once, on numpy arrays of the points: shape
    ``(..., *shape)``. For formulas wanted at a few points (the checks of a derivation: invariance, Jacobi's
    identity), where compiling them (printing, common subexpressions, Python's compiler: a third of a second for the
    three-link chain's bracket) costs a hundred times the evaluation. The values are :func:`compile_vector`'s to
    round-off; a function outside numpy's elementary ones is compiled by it, alone. ``dtype=complex`` evaluates at
    complex points (derivatives by complex step)."""
    if isinstance(exprs, sp.MatrixBase):
        exprs = exprs.tolist()
    arr = np.array(exprs, dtype=object)
    shape = arr.shape
    x = np.asarray(points, dtype=dtype)
    batch = x.shape[:-1]
    memo: dict[Any, Any] = {v: x[..., i] for i, v in enumerate(variables)}
    with np.errstate(all="ignore"):  # a pole gives inf or nan, as the compiled function does; the callers check
        _walk(arr.ravel(), memo, variables, dtype)
    values = [memo[sp.sympify(e)] for e in arr.ravel()]
    out = np.empty(batch + (len(values),), dtype=dtype)
    for i, v in enumerate(values):  # an assignment broadcasts the constant entries
        out[..., i] = v
    return out.reshape(batch + shape)


def _walk(roots: Any, memo: dict, variables: Sequence[sp.Symbol], dtype: Any) -> None:
    """:func:`evaluate`'s walk: every node's value in ``memo``, its arguments' first (no recursion)."""
    for root in roots:
        root = sp.sympify(root)
        stack = [(root, False)]
        while stack:
            e, ready = stack.pop()
            if e in memo:
                continue
            if e.is_Number or e.is_NumberSymbol or e is sp.I:
                real = dtype is not complex and e.is_extended_real
                memo[e] = np.float64(float(e)) if real else np.complex128(complex(e))
                continue
            if not e.args:
                raise SymbolicError(f"Cannot evaluate {e}: it is not among the variables {list(variables)}.")
            if not ready:
                stack.append((e, True))
                stack.extend((a, False) for a in e.args if a not in memo)
                continue
            args = [memo[a] for a in e.args]
            if e.is_Add:
                out = args[0]
                for a in args[1:]:
                    out = out + a
            elif e.is_Mul:
                out = args[0]
                for a in args[1:]:
                    out = out * a
            elif e.is_Pow:
                b, k = args[0], e.exp
                if k.is_Integer:
                    out = 1 / b if k == -1 else b ** int(k)
                elif k == sp.S.Half or k == -sp.S.Half:
                    out = np.sqrt(b) if k > 0 else 1 / np.sqrt(b)
                else:
                    out = b ** (float(k) if k.is_Number else args[1])
            elif type(e).__name__ in _ELEMENTARY and len(args) == 1:
                out = _ELEMENTARY[type(e).__name__](args[0])
            else:
                free = sorted(e.free_symbols, key=sp.default_sort_key)
                f = _lambdify([e], free)
                out = f(*[memo[v] for v in free])[0] if free else f()[0]
            memo[e] = out


#: sympy's elementary functions of one argument and their numpy twins, for :func:`evaluate`.
_ELEMENTARY = {
    "sin": np.sin,
    "cos": np.cos,
    "tan": np.tan,
    "exp": np.exp,
    "log": np.log,
    "asin": np.arcsin,
    "acos": np.arccos,
    "atan": np.arctan,
    "sinh": np.sinh,
    "cosh": np.cosh,
    "tanh": np.tanh,
    "Abs": np.abs,
}


def stack_last(*arrays: Any) -> np.ndarray:
    """Concatenate along the last axis after broadcasting the leading (batch) axes only."""
    arrs = [np.asarray(a, dtype=float) for a in arrays]
    arrs = [a[..., None] if a.ndim == 0 else a for a in arrs]
    batch = np.broadcast_shapes(*(a.shape[:-1] for a in arrs))
    return np.concatenate([np.broadcast_to(a, batch + a.shape[-1:]) for a in arrs], axis=-1)


def compile_matrix(e: sp.Matrix, variables: Sequence[sp.Symbol], *, dtype: Any = float):
    """A sympy matrix to ``f(x)`` of shape ``(..., rows, cols)``, like :func:`compile_vector`, also for matrices with a
    zero dimension."""
    if e.rows == 0 or e.cols == 0:
        shape = e.shape

        def empty(x: np.ndarray) -> np.ndarray:
            x = np.asarray(x, dtype=dtype)
            return np.zeros(x.shape[:-1] + shape, dtype=dtype)

        return empty
    if not variables:
        const = np.array(e.evalf(), dtype=dtype)

        def constant(x: np.ndarray) -> np.ndarray:
            x = np.asarray(x, dtype=dtype)
            return np.broadcast_to(const, x.shape[:-1] + const.shape).copy()

        return constant
    return compile_vector(e.tolist(), variables, dtype=dtype)


def column(seq: Sequence[Any]) -> sp.Matrix:
    """A column vector, also with no entries (``sp.Matrix(())`` would be 0 x 0)."""
    return sp.Matrix(len(seq), 1, list(seq))


def suffixed_symbols(suffix: str, names: Sequence[str]) -> tuple[sp.Symbol, ...]:
    """Real symbols ``name_suffix`` (or ``name`` with no suffix), e.g. the velocities ``x_dot`` of ``x``."""
    return tuple(sp.Symbol(f"{n}_{suffix}" if suffix else n, real=True) for n in names)


# -- numba kernels: the same expressions printed as Python source for numba ----------------------------------
class _Printer(PythonCodePrinter):
    """Python code for numba: ``math`` functions, floats printed so that they read back exactly."""

    def _print_Float(self, expr: sp.Float) -> str:
        value = float(expr)
        return repr(value) if np.isfinite(value) else f"float('{value}')"

    def _print_Rational(self, expr: sp.Rational) -> str:
        return f"({expr.p}/{expr.q})"

    def _print_Half(self, expr: sp.Rational) -> str:
        return "0.5"


@dataclass(frozen=True)
class FunctionSpec:
    """One generated model function.

    ``outputs`` is a tuple of sympy objects: a single scalar gives ``def name(y): return ...``; otherwise
    each output (a list or a nested list) is an array argument written in place,
    ``def name(y, out0, out1, ...)``. With ``scalar_args`` the arguments are the variables themselves,
    ``def name(x0, x1, ...)``. Every function takes last the array ``prm`` of the values of
    ``parameters`` (symbols of the outputs that are not variables, in this order), read at run time: one
    compiled function serves every value of the parameters.
    """

    name: str
    outputs: tuple[Any, ...]
    variables: tuple[sp.Symbol, ...]
    scalar_args: bool = False
    parameters: tuple[sp.Symbol, ...] = ()


def _function_source(spec: FunctionSpec, printer: _Printer) -> str:
    alias = {v: sp.Symbol(f"_a{i}") for i, v in enumerate(spec.variables)}
    alias.update({v: sp.Symbol(f"_p{i}") for i, v in enumerate(spec.parameters)})
    shapes: list[tuple[int, ...]] = []
    flat: list[Any] = []
    for out in spec.outputs:
        arr = np.array(out, dtype=object)
        shapes.append(arr.shape)
        flat.extend(sp.sympify(e).xreplace(alias) for e in arr.ravel())
    bad = [e for e in flat if e.has(sp.zoo, sp.oo, -sp.oo, sp.nan)]
    if bad:
        raise SymbolicError(
            f"{spec.name}: the formula is not finite at the given parameter values (a division by "
            f"zero or a pole there): {str(bad[0])[:200]}; choose other values."
        )
    stray = set().union(*(e.free_symbols for e in flat)) - set(alias.values()) if flat else set()
    if stray:
        raise ValueError(f"{spec.name}: symbols {sorted(map(str, stray))} are not variables of the model")
    replacements, reduced = sp.cse(flat, symbols=sp.numbered_symbols("_c"), order="none")
    scalar_return = len(spec.outputs) == 1 and shapes[0] == ()
    if spec.scalar_args:
        args = [f"_a{i}" for i in range(len(spec.variables))]
    else:
        args = ["y"]
    if not scalar_return:
        args += [f"out{k}" for k in range(len(spec.outputs))]
    args.append("prm")
    lines = ["@kernel", f"def {spec.name}({', '.join(args)}):"]
    if not spec.scalar_args:
        lines += [f"    _a{i} = y[{i}]" for i in range(len(spec.variables))]
    used = set().union(*(e.free_symbols for e in flat)) if flat else set()
    lines += [f"    _p{i} = prm[{i}]" for i in range(len(spec.parameters)) if sp.Symbol(f"_p{i}") in used]
    for sym, expr in replacements:
        lines.append(f"    {sym} = {printer.doprint(expr)}")
    if scalar_return:
        lines.append(f"    return {printer.doprint(reduced[0])}")
    else:
        pos = 0
        for k, shape in enumerate(shapes):
            for index in np.ndindex(*shape):
                target = f"out{k}[{', '.join(map(str, index))}]" if index else f"out{k}[0]"
                lines.append(f"    {target} = {printer.doprint(reduced[pos])}")
                pos += 1
    if len(lines) == 2:
        lines.append("    return")
    if printer._not_supported:
        raise NotImplementedError(f"{spec.name}: cannot print {sorted(map(str, printer._not_supported))} for numba")
    return "\n".join(lines) + "\n"


def kernel_source(specs: Sequence[FunctionSpec]) -> str:
    """Python (numba-compatible) source of the model functions ``specs``.

    Each function is decorated ``@kernel`` (the loader defines it, e.g. as ``numba.njit``). Raises
    ``NotImplementedError`` when an expression uses a function numba's ``math`` lacks; the caller then
    falls back to the Python backend.
    """
    printer = _Printer({"fully_qualified_modules": True, "standard": "python3"})
    return "\n\n".join(_function_source(s, printer) for s in specs)


class StraightLine:
    """The body of a numba function as straight-line code, built in stages: :meth:`value` queues an assignment
    ``name = expr`` and returns the new name (or ``expr`` itself where it is a number, so that zeros and constants
    propagate into what follows); :meth:`flush` prints the queued assignments with their common subexpressions
    shared; :meth:`line` adds a statement of its own (a check, a store). Expressions read the names made so far
    and the names the caller assigns in its own lines. Raises ``NotImplementedError`` where an expression uses a
    function numba's ``math`` lacks.
    """

    def __init__(self, prefix: str = "_v"):
        self.lines: list[str] = []
        #: every assignment printed so far, in order (the Taylor-mode code of :mod:`.taylor` replays them)
        self.assignments: list[tuple[sp.Symbol, sp.Expr]] = []
        self._queue: list[tuple[sp.Symbol, sp.Expr]] = []
        self._pending: set[sp.Symbol] = set()
        self._prefix = prefix
        self._count = 0
        self._cse = 0
        self._printer = _Printer({"fully_qualified_modules": True, "standard": "python3"})

    def value(self, expr: Any) -> sp.Expr:
        e = sp.sympify(expr)
        if e.is_number:
            if e.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
                raise SymbolicError(f"a formula is not finite at the given parameter values: {e}")
            return e
        if isinstance(e, sp.Symbol):
            return e
        if self._pending and not e.free_symbols.isdisjoint(self._pending):
            self.flush()  # it reads a queued value: print those first
        name = sp.Symbol(f"{self._prefix}{self._count}")
        self._count += 1
        self._queue.append((name, e))
        self._pending.add(name)
        return name

    def values(self, exprs: Any) -> list[sp.Expr]:
        return [self.value(e) for e in exprs]

    def matrix(self, M: sp.Matrix) -> sp.Matrix:
        """Each entry of ``M`` as a value (the matrix of the names)."""
        return sp.Matrix(M.rows, M.cols, self.values(list(M)))

    def flush(self) -> None:
        if not self._queue:
            return
        names, exprs = zip(*self._queue)
        self._queue = []
        self._pending = set()
        temps = sp.numbered_symbols(f"{self._prefix}c{self._cse}_")
        self._cse += 1
        replacements, reduced = sp.cse(list(exprs), symbols=temps, order="none")
        for sym, e in [*replacements, *zip(names, reduced)]:
            self.lines.append(f"{sym} = {self.code(e)}")
            self.assignments.append((sym, e))

    def code(self, expr: Any) -> str:
        text = self._printer.doprint(sp.sympify(expr))
        if self._printer._not_supported:
            raise NotImplementedError(f"cannot print {sorted(map(str, self._printer._not_supported))} for numba")
        return text

    def line(self, text: str) -> None:
        self.flush()
        self.lines.extend(text.splitlines())

    def body(self, indent: str = "    ") -> str:
        self.flush()
        return "\n".join(indent + line for line in self.lines) + "\n"

    def copy(self) -> StraightLine:
        """The code so far, continued apart: two functions that share their beginning (the values named so far)."""
        self.flush()
        other = StraightLine(self._prefix)
        other.lines, other._count, other._cse = list(self.lines), self._count, self._cse
        other.assignments = list(self.assignments)
        return other


def _hoist_numbers(e: sp.Expr, table: dict[sp.Symbol, float], first: int) -> sp.Expr:
    """``e`` with its numeric coefficients and terms (not its exponents, not +-1) replaced by the parameters
    ``_p{first}``, ``_p{first + 1}``, ... (their values into ``table``): gaits and torques that differ only in
    their numbers (amplitudes, frequencies, phases, gains) then share one compiled function."""
    if e.is_Atom:
        return e
    if isinstance(e, sp.Pow):
        return sp.Pow(_hoist_numbers(e.base, table, first), e.exp)
    if isinstance(e, (sp.Mul, sp.Add)):
        args = []
        for a in e.args:
            if a.is_Number and a not in (sp.S.One, sp.S.NegativeOne):
                name = sp.Symbol(f"_p{first + len(table)}")
                table[name] = float(a)
                args.append(name)
            else:
                args.append(_hoist_numbers(a, table, first))
        return e.func(*args)
    return e.func(*[_hoist_numbers(a, table, first) for a in e.args])


def number_form(e: sp.Expr, table: dict[sp.Symbol, float], first: int) -> sp.Expr:
    """``e`` written ``c + s f`` with its offset c and scale s (0 and 1 where it has none) and the numbers of f
    as the run-time parameters ``_p{first}``, ``_p{first + 1}``, ... (their values into ``table``, in order):
    ``sin(2*pi*t)``, ``0.5*sin(3*pi*t)`` and ``0.1 + 2*sin(pi*t)`` are one form. Formulas that differ only in
    their numbers (amplitudes, frequencies, phases, gains of gaits and torques) then share one compiled
    function."""
    c, rest = sp.sympify(e).as_coeff_Add()
    scale, f = rest.as_coeff_Mul()
    offset_name, scale_name = (sp.Symbol(f"_p{first + len(table) + i}") for i in range(2))
    table[offset_name], table[scale_name] = float(c), float(scale)
    return offset_name + scale_name * _hoist_numbers(f, table, first)


def runtime_parameters(expr: Any, variables: tuple, values: Mapping[str, float]) -> dict[str, Any]:
    """``expr``'s symbols other than ``variables``, sorted by name, and their ``values`` as an array: the fields
    ``model_expression``, ``parameter_symbols``, ``prm`` and ``parameter_recipe`` (for each entry of ``prm``, the
    name of the parameter it is the value of, and whether it is its reciprocal) of the solver's problem.

    A parameter in a denominator (``m1**2 / (2 I1)``) is read as its reciprocal, a parameter of its own whose
    value is computed here once: the compiled functions multiply where a formula with the values written in
    would have. The parameters are constants of the motion, so the derivatives the loops need are unchanged.
    """
    symbols = sorted(expr.free_symbols - set(variables), key=lambda s: s.name)
    missing = [s.name for s in symbols if s.name not in values]
    if missing:  # pragma: no cover - the systems substitute or validate every parameter they hold
        raise InputError(f"The formula has symbols {missing} without values.")
    inverse = {s: sp.Symbol(f"{s.name}__inverse", real=True) for s in symbols}
    expr = expr.replace(
        lambda e: e.is_Pow and e.base in inverse and e.exp.is_number and e.exp.is_negative,
        lambda e: inverse[e.base] ** (-e.exp),
    )
    used = [inverse[s] for s in symbols if inverse[s] in expr.free_symbols]
    names = {v: k.name for k, v in inverse.items()}
    prm = [float(values[s.name]) for s in symbols] + [1.0 / float(values[names[r]]) for r in used]
    if isinstance(expr, sp.MatrixBase):
        expr = sp.ImmutableMatrix(expr)  # hashable: the generated source is cached by it
    recipe = tuple((s.name, False) for s in symbols) + tuple((names[r], True) for r in used)
    return {
        "model_expression": expr,
        "parameter_symbols": (*symbols, *used),
        "prm": np.array(prm, dtype=float),
        "parameter_recipe": recipe,
    }

"""User formulas as data: a whitelist parser from text to sympy, never Python's ``eval``.

``sympy.sympify`` evaluates its input as Python, so ``"0*len(open('x','w').name)"`` or
``"__import__('os').system(...)"`` given as a Hamiltonian would run. Every formula a user writes (on the
command line, in a model description, in the API) goes through :func:`parse_formula` instead: the text is
parsed by :mod:`ast` and only these nodes are accepted

- numbers (integers and finite decimals), names (symbols; ``pi`` is the constant),
- ``+ - * / **`` (``^`` is read as a power, as in mathematics), unary ``+`` and ``-``,
- calls of the functions in :data:`FUNCTIONS`, with positional arguments;

anything else is a :class:`~geomech.errors.SymbolicError` naming the formula and the offending part. The
sympy expression is then built node by node, and the work it can cost is bounded before it is done: the
text's length, its nesting, and every power of numbers (``10**10**10`` would take sympy minutes and
gigabytes) are checked first; a constant sub-expression that is not a finite real number (``1/0``,
``acos(2)``, ``log(0)``, ``sqrt(-1)``) is refused where it appears.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable, Mapping

import sympy as sp

from ..errors import SymbolicError

__all__ = ["FUNCTIONS", "MAX_FORMULA_LENGTH", "parse_formula", "to_expression"]

#: Longest formula accepted, in characters (a model's Lagrangian written out is a few hundred).
MAX_FORMULA_LENGTH = 20_000
#: Largest magnitude, as a power of ten, of a constant in a formula: beyond it no float holds the value.
_MAX_DECADE = 300
#: Largest integer exponent of a non-constant base: (m1 + m2)**n expands to n + 1 terms and its
#: derivatives keep n; mechanics has no use for more.
_MAX_EXPONENT = 1000


def _arity(*counts: int) -> tuple[int, ...]:
    return counts


#: Allowed functions: name -> (sympy function, numbers of arguments accepted).
FUNCTIONS: dict[str, tuple[Callable[..., sp.Expr], tuple[int, ...]]] = {
    "sin": (sp.sin, _arity(1)),
    "cos": (sp.cos, _arity(1)),
    "tan": (sp.tan, _arity(1)),
    "cot": (sp.cot, _arity(1)),
    "sec": (sp.sec, _arity(1)),
    "csc": (sp.csc, _arity(1)),
    "asin": (sp.asin, _arity(1)),
    "acos": (sp.acos, _arity(1)),
    "atan": (sp.atan, _arity(1)),
    "acot": (sp.acot, _arity(1)),
    "atan2": (sp.atan2, _arity(2)),
    "sinh": (sp.sinh, _arity(1)),
    "cosh": (sp.cosh, _arity(1)),
    "tanh": (sp.tanh, _arity(1)),
    "coth": (sp.coth, _arity(1)),
    "asinh": (sp.asinh, _arity(1)),
    "acosh": (sp.acosh, _arity(1)),
    "atanh": (sp.atanh, _arity(1)),
    "exp": (sp.exp, _arity(1)),
    "log": (sp.log, _arity(1, 2)),
    "ln": (sp.log, _arity(1)),
    "sqrt": (sp.sqrt, _arity(1)),
    "cbrt": (sp.cbrt, _arity(1)),
    "Abs": (sp.Abs, _arity(1)),
    "abs": (sp.Abs, _arity(1)),
    "sign": (sp.sign, _arity(1)),
    "Min": (sp.Min, _arity(2, 3, 4)),
    "min": (sp.Min, _arity(2, 3, 4)),
    "Max": (sp.Max, _arity(2, 3, 4)),
    "max": (sp.Max, _arity(2, 3, 4)),
}
_ALLOWED = ", ".join(sorted(FUNCTIONS))
_CONSTANTS = {"pi": sp.pi}
_NOT_FINITE = {"oo", "zoo", "nan", "inf", "infinity"}
_BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**", ast.BitXor: "^"}


class _Builder:
    def __init__(self, text: str, argname: str, symbols: Mapping[str, sp.Symbol]):
        self.text, self.argname, self.symbols = text, argname, dict(symbols)

    def fail(self, node: ast.AST | None, why: str) -> SymbolicError:
        part = ast.get_source_segment(self.text, node) if node is not None else None
        where = f" in `{part}`" if part and part.strip() != self.text.strip() else ""
        return SymbolicError(f"`{self.argname}` = {_short(self.text)!r}: {why}{where}.")

    def build(self, node: ast.AST) -> sp.Expr:
        if isinstance(node, ast.Expression):
            return self.build(node.body)
        if isinstance(node, ast.Constant):
            return self.number(node)
        if isinstance(node, ast.Name):
            return self.name(node)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            value = self.build(node.operand)
            return -value if isinstance(node.op, ast.USub) else value
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return self.binary(node)
        if isinstance(node, ast.Call):
            return self.call(node)
        raise self.fail(
            node,
            f"{_describe(node)} is not allowed in a formula (numbers, symbols, + - * / ** "
            f"and the functions {_ALLOWED} are)",
        )

    def number(self, node: ast.Constant) -> sp.Expr:
        value = node.value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(node, f"{value!r} is not a number")
        if isinstance(value, int):
            if value.bit_length() > _MAX_DECADE * 3.33:
                raise self.fail(node, f"the integer has more than {_MAX_DECADE} digits")
            return sp.Integer(value)
        if not math.isfinite(value):
            raise self.fail(node, "the number is beyond the range of floating point")
        return sp.Float(value)

    def name(self, node: ast.Name) -> sp.Expr:
        ident = node.id
        if ident.startswith("_"):
            raise self.fail(node, f"the name {ident!r} is not allowed (names start with a letter)")
        if ident in self.symbols:
            return self.symbols[ident]
        if ident in _CONSTANTS:
            return _CONSTANTS[ident]
        if ident.lower() in _NOT_FINITE:
            raise self.fail(node, f"{ident!r} is not a finite number; formulas take finite real values")
        if ident in FUNCTIONS:
            raise self.fail(node, f"{ident!r} is a function: write {ident}(x)")
        symbol = sp.Symbol(ident, real=True)
        self.symbols[ident] = symbol
        return symbol

    def binary(self, node: ast.BinOp) -> sp.Expr:
        a, b = self.build(node.left), self.build(node.right)
        op = type(node.op)
        if op is ast.Add:
            out = a + b
        elif op is ast.Sub:
            out = a - b
        elif op is ast.Mult:
            out = a * b
        elif op is ast.Div:
            if b.is_zero:
                raise self.fail(node, "division by zero")
            out = a / b
        else:
            self.check_power(node, a, b)
            out = a**b
        return self.checked_constant(node, out)

    def check_power(self, node: ast.AST, base: sp.Expr, exponent: sp.Expr) -> None:
        if base.is_number and exponent.is_number:
            if base.is_zero and exponent.is_extended_negative:
                raise self.fail(node, "division by zero (zero to a negative power)")
            # log10 |base**exponent| = exponent * log10 |base|, judged before sympy computes the power.
            decade = abs(complex(sp.N(exponent, 15)).real) * abs(_log10(base))
            if decade > _MAX_DECADE:
                raise self.fail(node, f"the power is beyond 1e{_MAX_DECADE} or below 1e-{_MAX_DECADE}")
        elif exponent.is_Integer and abs(int(exponent)) > _MAX_EXPONENT:
            raise self.fail(node, f"the exponent {exponent} is above {_MAX_EXPONENT}")

    def call(self, node: ast.Call) -> sp.Expr:
        if not isinstance(node.func, ast.Name):
            raise self.fail(
                node,
                f"{_describe(node.func)} cannot be called; only the functions " + ", ".join(sorted(FUNCTIONS)) + " can",
            )
        name = node.func.id
        if name not in FUNCTIONS:
            raise self.fail(node, f"it calls unknown function(s) [{name!r}] (allowed: {_ALLOWED})")
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            raise self.fail(node, f"{name}() takes plain positional arguments")
        fn, counts = FUNCTIONS[name]
        if len(node.args) not in counts:
            raise self.fail(node, f"{name}() takes {' or '.join(map(str, counts))} argument(s), got {len(node.args)}")
        args = [self.build(a) for a in node.args]
        if name == "log" and len(args) == 2:
            if args[1].is_number and (args[1].is_extended_nonpositive or args[1] == 1):
                raise self.fail(node, f"the base of a logarithm must be positive and not 1, got {args[1]}")
            return self.checked_constant(node, sp.log(args[0], args[1]))
        return self.checked_constant(node, fn(*args))

    def checked_constant(self, node: ast.AST, value: sp.Expr) -> sp.Expr:
        """A sub-expression without symbols must be a finite real number."""
        if value.has(sp.zoo, sp.oo, sp.nan, -sp.oo):
            raise self.fail(node, "the value is not finite (a division by zero or a pole)")
        if value.free_symbols:
            return value
        try:
            number = complex(sp.N(value, 20))
        except (TypeError, ValueError) as exc:  # pragma: no cover - every allowed node evaluates
            raise self.fail(node, "the value cannot be evaluated") from exc
        if not (math.isfinite(number.real) and math.isfinite(number.imag)) or abs(number.real) >= 10.0**_MAX_DECADE:
            raise self.fail(node, f"the value is beyond 1e{_MAX_DECADE}")
        if abs(number.imag) > 1e-15 * max(1.0, abs(number.real)):
            raise self.fail(node, f"the value is not real ({sp.N(value, 6)})")
        return value


def _log10(value: sp.Expr) -> float:
    """log10 |value| of a number (0 for 0), computed without forming huge intermediate values."""
    number = sp.N(value, 15)
    return 0.0 if number.is_zero else float(sp.log(abs(number), 10).evalf(15))


def _describe(node: ast.AST) -> str:
    names = {
        ast.Attribute: "an attribute",
        ast.Subscript: "a subscript",
        ast.Compare: "a comparison",
        ast.BoolOp: "a boolean operation",
        ast.Lambda: "a lambda",
        ast.IfExp: "a conditional",
        ast.List: "a list",
        ast.Tuple: "a tuple",
        ast.Dict: "a dict",
        ast.Set: "a set",
        ast.ListComp: "a comprehension",
        ast.GeneratorExp: "a generator",
        ast.JoinedStr: "an f-string",
        ast.NamedExpr: "an assignment",
        ast.Starred: "a starred argument",
        ast.Call: "a call",
        ast.Name: "a name",
        ast.Await: "await",
        ast.Yield: "yield",
    }
    if isinstance(node, ast.BinOp):
        return f"the operator {type(node.op).__name__}"
    if isinstance(node, ast.UnaryOp):
        return f"the operator {type(node.op).__name__}"
    return names.get(type(node), type(node).__name__)


def _short(text: str, limit: int = 80) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def parse_formula(text: str, argname: str, symbols: Mapping[str, sp.Symbol] | None = None) -> sp.Expr:
    """Parse a user formula into a sympy expression, by a whitelist (see the module's docstring).

    Parameters
    ----------
    text : str
        The formula, e.g. ``"m1**2/(2*I1) + k*sin(t)"``.
    argname : str
        How the caller names it in errors: an API argument (``"hamiltonian"``) or a CLI option
        (``"--hamiltonian"``).
    symbols : mapping, optional
        Names that stand for given sympy symbols (the variables of the formula, ``t``); every other
        name becomes a real symbol of that name (a parameter), and ``pi`` is the constant.

    Raises
    ------
    SymbolicError
        For text that is not a formula of the allowed form, one that is too long or too deeply nested,
        a power of numbers beyond the float range, or a constant part that is not a finite real number.
    """
    if not isinstance(text, str):
        raise SymbolicError(f"Expected `{argname}` to be a formula (a string), got {type(text).__name__}.")
    if not text.strip():
        raise SymbolicError(f"`{argname}` is empty; give a formula such as 'm1**2/2'.")
    if len(text) > MAX_FORMULA_LENGTH:
        raise SymbolicError(f"`{argname}` has {len(text)} characters, above the limit of {MAX_FORMULA_LENGTH}.")
    if "\x00" in text:
        raise SymbolicError(f"`{argname}` contains a NUL character.")
    # `^` is a power in mathematics (as sympify reads it); the text holds no strings, so this is safe.
    text = text.strip().replace("^", "**")
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        col = f" at column {exc.offset}" if exc.offset else ""
        raise SymbolicError(f"Could not parse `{argname}` {_short(text)!r}: {exc.msg}{col}.") from None
    except (RecursionError, MemoryError, ValueError):
        raise SymbolicError(f"`{argname}` is nested too deeply to parse.") from None
    builder = _Builder(text, argname, symbols or {})
    try:
        return builder.build(tree)
    except RecursionError:
        raise SymbolicError(f"`{argname}` is nested too deeply to parse.") from None


def to_expression(value: object, argname: str, symbols: Mapping[str, sp.Symbol] | None = None) -> sp.Expr:
    """A formula given as text (parsed by :func:`parse_formula`), a sympy expression, or a finite number.

    Names in a sympy expression that match ``symbols`` by name are replaced by them, so that ``t`` typed
    by a user and ``t`` of the library are one symbol.
    """
    if isinstance(value, str):
        return parse_formula(value, argname, symbols)
    if isinstance(value, bool):
        raise SymbolicError(f"Expected `{argname}` to be a formula, got {value!r}.")
    if isinstance(value, (int, float)) or (hasattr(value, "dtype") and getattr(value, "shape", None) == ()):
        number = float(value)  # type: ignore[arg-type]
        if not math.isfinite(number):
            raise SymbolicError(f"Expected `{argname}` to be finite, got {number}.")
        return sp.Integer(int(value)) if isinstance(value, int) else sp.Float(number)
    if isinstance(value, sp.Basic):
        if value.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
            raise SymbolicError(f"`{argname}` must be finite, got {value}.")
        names = dict(symbols or {})
        return value.xreplace(
            {s: names[s.name] for s in value.free_symbols if isinstance(s, sp.Symbol) and s.name in names}
        )
    raise SymbolicError(
        f"Expected `{argname}` to be a formula (a string or a sympy expression), got {type(value).__name__}."
    )

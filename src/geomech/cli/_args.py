"""Argument handling shared by the commands: vector options and one-line errors."""

from __future__ import annotations

from collections.abc import Sequence

import click

#: Options that take a vector of numbers, written either as separate words (--inertia 3 2 1) or
#: comma-separated (--inertia 3,2,1).
VECTOR_OPTIONS = ("--inertia", "--momentum", "--attitude", "--lambda", "--p", "--near", "--mu")


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def gather_vectors(argv: Sequence[str]) -> list[str]:
    """Join the numbers that follow a vector option into one comma-separated word, so that a wrong
    count is reported by the option's own check rather than as a stray argument."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        out.append(tok)
        i += 1
        if tok in VECTOR_OPTIONS:
            vals = []
            while i < len(argv) and _is_number(argv[i]):
                vals.append(argv[i])
                i += 1
            if vals:
                out.append(",".join(vals))
    return out


class FloatVector(click.ParamType):
    """A comma-separated vector of floats with one of the allowed lengths."""

    name = "floats"

    def __init__(self, *lengths: int):
        self.lengths = lengths

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        parts = [p for p in str(value).split(",") if p.strip() != ""]
        try:
            vals = tuple(float(p) for p in parts)
        except ValueError:
            self.fail(f"expected numbers, got {value!r}", param, ctx)
        if len(vals) not in self.lengths:
            want = " or ".join(str(n) for n in self.lengths)
            self.fail(f"expected {want} numbers, got {len(vals)} ({', '.join(parts) or 'none'})", param, ctx)
        return vals


def parse_params(items: Sequence[str], option: str = "--param") -> dict[str, float]:
    """Parse repeated ``NAME=VALUE`` options into a dict of floats, with one-line errors."""
    values: dict[str, float] = {}
    for item in items:
        name, sep, val = item.partition("=")
        if not sep or not name.strip():
            raise click.BadParameter(f"expected NAME=VALUE, got {item!r}", param_hint=f"'{option}'")
        try:
            values[name.strip()] = float(val)
        except ValueError:
            raise click.BadParameter(f"{name.strip()} = {val!r} is not a number", param_hint=f"'{option}'") from None
    return values


def parse_shape_loop(items: Sequence[str], names: Sequence[str], option: str, owner: str) -> dict[str, str]:
    """``NAME=EXPR`` items, one for each shape variable in ``names`` (in that order); bad or missing ones
    are an error naming ``option`` and the variables ``owner`` has."""
    from ..errors import InputError, ShapeError

    given: dict[str, str] = {}
    for item in items:
        name, sep, expr = item.partition("=")
        name = name.strip()
        if not sep or not name or not expr.strip():
            raise InputError(f"Expected `{option}` as NAME=EXPR, got {item!r}.")
        if name not in names:
            raise InputError(f"`{option}` names {name!r}, which is not a shape variable of {owner} "
                             f"({', '.join(names) or 'none'}).")
        if name in given:
            raise InputError(f"`{option}` gives {name!r} twice.")
        given[name] = expr.strip()
    if len(given) != len(names):
        raise ShapeError(f"Expected one `{option}` for each of the {len(names)} shape variables "
                         f"({', '.join(names)}) of {owner}, got {len(given)} ({', '.join(given) or 'none'}).")
    return {n: given[n] for n in names}

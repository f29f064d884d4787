"""The closed-form groups of the compiled maps on a group: which kernels of ``_k_groups.py`` serve a group of
:mod:`geomech.lie` (a factor at a time for a product), and the lines of generated code that call them."""

from __future__ import annotations

from typing import Any

__all__ = ["group_kernels", "exp_lines", "jacobian_lines"]

#: The groups whose exponential, logarithm and Jacobians ``_k_groups.py`` has, by their kernels' names.
_KERNELS = {"SO2": "so2", "Rn": "rn", "SE2": "se2", "SO3": "so3", "SE3": "se3"}
#: The abelian ones: their Jacobians are the identity.
ABELIAN = ("so2", "rn")


def group_kernels(group: Any) -> list[tuple[str, int, int, int]] | None:
    """The kernels of ``group`` (a :mod:`geomech.lie` group), a factor at a time: (name, the factor's row in the
    block-diagonal element, its first algebra index, its dimension); None where a factor has none (a general
    matrix group, whose logarithm is ``logm``)."""
    from ..lie.group import Product

    factors = group.factors if isinstance(group, Product) else (group,)
    out, row, first = [], 0, 0
    for f in factors:
        name = _KERNELS.get(type(f).__name__)
        if name is None or type(f).__module__ != "geomech.lie.groups":
            return None
        out.append((name, row, first, int(f.dim)))
        row, first = row + int(f.matrix_size), first + int(f.dim)
    return out


def exp_lines(kernels: list[tuple[str, int, int, int]], u: str, E: str) -> list[str]:
    """``E = exp(u)`` (``E`` zero before), a factor's block at a time."""
    return [
        f"exp_rn({u}, {first}, {m}, {E}, {row})" if name == "rn" else f"exp_{name}({u}, {first}, {E}, {row})"
        for name, row, first, m in kernels
    ]


def jacobian_lines(kernels: list[tuple[str, int, int, int]], u: str, sign: float, J: str) -> list[str]:
    """``J = J_l^-1(sign u)`` (``J`` zero before): ``sign = -1`` gives :math:`J_r^{-1}(u)`."""
    return [
        f"jlinv_identity({m}, {J}, {first})" if name in ABELIAN else f"jlinv_{name}({u}, {first}, {sign}, {J}, {first})"
        for name, row, first, m in kernels
    ]

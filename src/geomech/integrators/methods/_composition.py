"""Symmetric compositions of a symmetric method: the weights (the triple jump and Suzuki's fractal, recursively,
and the optimised constants tabulated in [HLW] V.3.2) and :class:`Composition`, the composition of
Gauss-Legendre steps (of the implicit midpoint rule for ``stages=1``) to order 6, 8 or 10."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ...errors import InputError
from ._base import Method, Structure
from ._canonical import gauss_constants

__all__ = ["COMPOSITION_TABLES", "composition_weights", "Composition"]

#: Symmetric compositions of a symmetric method of order 2, by (order, scheme ``s<J>``, J the number of
#: steps): the first half of the weights and the middle one, to 26 digits, as [HLW] V.3.2 tabulates them
#: after Yoshida (1990), McLachlan (1995) and Kahan & Li (1997).
COMPOSITION_TABLES: dict[tuple[int, str], tuple[tuple[float, ...], float]] = {
    (6, "s7"): (
        (0.78451361047755726381949763, 0.23557321335935813368479318, -1.17767998417887100694641568),
        1.31518632068391121888424973,
    ),
    (6, "s9"): (
        (
            0.39216144400731413927925056,
            0.33259913678935943859974864,
            -0.70624617255763935980996482,
            0.08221359629355080023149045,
        ),
        0.79854399093482996339895035,
    ),
    (8, "s15"): (
        (
            0.74167036435061295344822780,
            -0.40910082580003159399730010,
            0.19075471029623837995387626,
            -0.57386247111608226665638773,
            0.29906418130365592384446354,
            0.33462491824529818378495798,
            0.31529309239676659663205666,
        ),
        -0.79688793935291635401978884,
    ),
    (8, "s17"): (
        (
            0.13020248308889008087881763,
            0.56116298177510838456196441,
            -0.38947496264484728640807860,
            0.15884190655515560089621075,
            -0.39590389413323757733623154,
            0.18453964097831570709183254,
            0.25837438768632204729397911,
            0.29501172360931029887096624,
        ),
        -0.60550853383003451169892108,
    ),
    (10, "s35"): (
        (
            0.07879572252168641926390768,
            0.31309610341510852776481247,
            0.02791838323507806610952027,
            -0.22959284159390709415121340,
            0.13096206107716486317465686,
            -0.26973340565451071434460973,
            0.07497334315589143566613711,
            0.11199342399981020488957508,
            0.36613344954622675119314812,
            -0.39910563013603589787862981,
            0.10308739852747107731580277,
            0.41143087395589023782070412,
            -0.00486636058313526176219566,
            -0.39203335370863990644808194,
            0.05194250296244964703718290,
            0.05066509075992449633587434,
            0.04967437063972987905456880,
        ),
        0.04931773575959453791768001,
    ),
}

#: The scheme of each order when none is named: the most accurate of [HLW]'s tables.
DEFAULT_SCHEME = {4: "yoshida", 6: "s9", 8: "s17", 10: "s35"}
RECURSIVE = ("yoshida", "suzuki")


def composition_weights(order: int, scheme: str, base_order: int = 2) -> tuple[float, ...]:
    """The weights gamma_1..gamma_J of a symmetric composition of a symmetric method of order ``base_order``
    that has order ``order``: ``"yoshida"`` (the triple jump gamma_1 = gamma_3 = 1/(2 - 2^(1/(p+1))), applied
    from p = base_order up), ``"suzuki"`` (the fractal of five, gamma = 1/(4 - 4^(1/(p+1))) four times), or a
    table of :data:`COMPOSITION_TABLES` (for a base of order 2; a base of higher order keeps the order)."""
    if order <= base_order:
        return (1.0,)
    if scheme in RECURSIVE:
        inner = composition_weights(order - 2, scheme, base_order)
        p = order - 2
        outer: tuple[float, ...]
        if scheme == "yoshida":
            g = 1.0 / (2.0 - 2.0 ** (1.0 / (p + 1)))
            outer = (g, 1.0 - 2.0 * g, g)
        else:
            g = 1.0 / (4.0 - 4.0 ** (1.0 / (p + 1)))
            outer = (g, g, 1.0 - 4.0 * g, g, g)
        return tuple(o * w for o in outer for w in inner)
    if (order, scheme) not in COMPOSITION_TABLES:
        raise InputError(
            f"No composition {scheme!r} of order {order}: the tables are "
            f"{', '.join(f'{s} (order {p})' for p, s in sorted(COMPOSITION_TABLES))}; 'yoshida' and 'suzuki' reach "
            "any even order."
        )
    half, middle = COMPOSITION_TABLES[(order, scheme)]
    return half + (middle,) + half[::-1]


def check_composition(order: int, scheme: str, orders: tuple[int, ...]) -> None:
    if order not in orders or isinstance(order, bool):
        raise InputError(f"Expected `order` to be one of {orders}, got {order!r}.")
    if scheme not in RECURSIVE and (order, scheme) not in COMPOSITION_TABLES:
        composition_weights(order, scheme)  # raises, naming what exists


@dataclass(frozen=True)
class Composition(Method):
    """A symmetric composition of Gauss-Legendre steps: ``stages=1`` composes the implicit midpoint rule.

    A step of size h is the sequence of ``stages``-stage Gauss-Legendre steps of sizes gamma_1 h, ...,
    gamma_J h (:func:`composition_weights`): ``scheme`` ``"s7"`` or ``"s9"`` (order 6), ``"s15"`` or ``"s17"``
    (order 8), ``"s35"`` (order 10), the optimised compositions of [HLW] V.3.2 for a base of order 2, the
    midpoint rule (the default is the most accurate of each order), or ``"yoshida"`` / ``"suzuki"`` (the triple
    jump and the fractal of five, applied recursively from the base's order 2s). Order ``order`` (6, 8 or 10);
    symplectic (canonical systems), symmetric, preserves quadratic invariants (so :math:`|m|^2`), as its
    base does. Structure: any ODE with a Jacobian. Cost per step: J Gauss-Legendre steps (J = 9, 17, 35 for
    the default schemes of orders 6, 8, 10 on the midpoint rule). Reference: [HLW] II.4, V.3; [Y].

    Parameters
    ----------
    order : {6, 8, 10}
    scheme : str
    stages : int
        Stages of the Gauss-Legendre base, 1 to 3 (order 2s < ``order``).
    """

    order: int = 6
    scheme: str = ""
    stages: int = 1
    structure: ClassVar[Structure] = Structure.ODE
    symplectic: ClassVar[bool] = True
    symmetric: ClassVar[bool] = True
    preserves_casimirs: ClassVar[bool] = True
    kernel: ClassVar[str] = "gauss_run"
    features: ClassVar[frozenset[str]] = frozenset({"rhs", "fjac"})

    def __post_init__(self) -> None:
        if self.stages not in (1, 2, 3) or isinstance(self.stages, bool):
            raise InputError(f"Expected `stages` of the base to be 1, 2 or 3, got {self.stages!r}.")
        if not self.scheme:
            object.__setattr__(self, "scheme", DEFAULT_SCHEME.get(self.order, "yoshida"))
        check_composition(self.order, self.scheme, (6, 8, 10))
        if self.stages > 1 and self.scheme not in RECURSIVE:
            raise InputError(
                f"The composition {self.scheme!r} is made for a base of order 2, the midpoint rule (stages=1); compose "
                f"Gauss-Legendre with {self.stages} stages by 'yoshida' or 'suzuki'."
            )
        if self.order <= 2 * self.stages:
            raise InputError(
                f"Expected `order` above the base's {2 * self.stages} (Gauss-Legendre with {self.stages} stages), "
                f"got {self.order}."
            )

    @property
    def key(self) -> str:
        base = "midpoint" if self.stages == 1 else f"gauss_legendre_{self.stages}"
        return f"{base}_{self.scheme}_{self.order}"

    def weights(self) -> tuple[float, ...]:
        return composition_weights(self.order, self.scheme, 2 * self.stages)

    def constants(self, problem: Any) -> np.ndarray:
        return gauss_constants(self.stages, self.weights())

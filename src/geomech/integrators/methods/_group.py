"""Methods for a motion on a Lie group given by its body velocity (a :class:`~geomech.systems.GroupFlow`): the
Runge-Kutta-Munthe-Kaas methods, which write :math:`g = g_c\\exp(u)` about a centre :math:`g_c` and integrate
:math:`\\dot u = \\mathrm{dexp}_{-u}^{-1}\\xi = J_r(u)^{-1}\\xi(t, g_c\\exp u)`, so that every state is on the group
exactly.

References: [MK] Munthe-Kaas, High order Runge-Kutta methods on manifolds, Appl. Numer. Math. 29 (1999);
[IMNZ] Iserles, Munthe-Kaas, Norsett & Zanna, Lie-group methods, Acta Numerica 9 (2000); [HNW] II.5 (DOP853).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from ...errors import InputError
from ._base import Method, Structure
from ._general import ScipyStepped


@dataclass(frozen=True)
class RKMK(ScipyStepped):
    """Runge-Kutta-Munthe-Kaas with an adaptive solver (scipy's, or its compiled twin) in exponential coordinates.

    The ODE :math:`\\dot u = J_r(u)^{-1}\\xi(t, g_c\\exp u)` is solved by ``solver`` (DOP853 by default) from
    :math:`u = 0`; when a component of :math:`u` reaches :math:`\\pm` ``chart_radius`` (well inside the
    injectivity radius of exp) the centre moves to :math:`g_c\\exp u` and the solve restarts (never on an abelian
    group, where exp is a global chart of the cover). The angles of the group's angle components are carried
    unwrapped. Kind: adaptive (``rtol``, ``atol``; default 1e-10, 1e-12). Order: that of ``solver`` (DOP853: 8).
    Stays on the group to round-off. Structure: a body velocity on a Lie group (the reconstruction equation).
    Cost per evaluation: the body velocity, one exp and one inverse right Jacobian of the group; as many
    evaluations as the tolerances require. Compiled (the whole run in one numba call, the compiled Dormand-Prince
    pair of the same name, the exit of the box located on its continuous extension) where the body velocity is
    formulas on SO(2), R^n, SE(2), SO(3), SE(3) or their products and ``solver`` is DOP853 or RK45; scipy's
    ``solve_ivp`` in Python otherwise, or with ``backend="python"``.
    Reference: [MK]; [IMNZ] section 6; [HNW] II.5.

    Parameters
    ----------
    solver : {"DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA"}
    chart_radius : float
        The largest :math:`|u_i|` about a centre (0 < chart_radius <= 2).
    """

    chart_radius: float = 1.0
    structure: ClassVar[Structure] = Structure.GROUP_FLOW

    def __post_init__(self) -> None:
        super().__post_init__()
        r = self.chart_radius
        if isinstance(r, bool) or not isinstance(r, (int, float)) or not (0 < r <= 2 and math.isfinite(r)):
            raise InputError(f"Expected `chart_radius` in (0, 2], got {r!r}.")

    @property
    def key(self) -> str:
        return "rkmk"


@dataclass(frozen=True)
class RKMK4(Method):
    """The classical Runge-Kutta-Munthe-Kaas method of order 4, a new centre every step.

    One step of the classical Runge-Kutta method on :math:`\\dot u = J_r(u)^{-1}\\xi(t, g_k\\exp u)` from
    :math:`u = 0`, then :math:`g_{k+1} = g_k\\exp(u_1)`. Kind: fixed step. Order 4; explicit; not symplectic
    nor symmetric; stays on the group to round-off. Structure: a body velocity on a Lie group (the
    reconstruction equation). Cost per step: 4 evaluations of the body velocity, 4 exps and 3 inverse right
    Jacobians; compiled (the whole run in one numba call) where the body velocity is formulas on SO(2), R^n,
    SE(2), SO(3), SE(3) or their products, in Python otherwise. Reference: [MK]; [IMNZ] section 6.
    """

    structure: ClassVar[Structure] = Structure.GROUP_FLOW
    explicit: ClassVar[bool] = True

    @property
    def order(self) -> int:
        return 4

    @property
    def key(self) -> str:
        return "rkmk4"

"""The seed's closed forms of the reduced closed-loop Hamiltonian (eqs. 32, 34, 42, 43), built directly from
their printed formulas, for comparison with :math:`h_p = H_c\\circ U_p` from the generic Serret-Andoyer
machinery (:meth:`GeneralizedSerretAndoyer.h_p`).

Each function returns a sympy expression in ``l, L, G`` (the symbols of
:mod:`geomech.reduction.serret_andoyer`) with the control's parameter values substituted; integrals
:math:`\\int_0^L` are evaluated by sympy independently of the closed loop's own integration (an
unevaluated ``Integral`` is left where sympy finds no antiderivative).

* eq. (32), one rotor: :math:`h_p = \\tfrac12(G^2-L^2)(\\sin^2 l/\\lambda_1 + \\cos^2 l/\\lambda_2) + L^2/(2I_3)
  - \\tfrac1{I_3}\\int_0^L(\\varphi + p)`; equal to :math:`H_c\\circ U_p`.
* eq. (34), :math:`\\varphi(v) = kv + c`: the printed square
  :math:`((1-k)L - p)^2/(2I_3(1-k))` (with :math:`p + c` for :math:`p`) exceeds :math:`h_p` by the constant
  :math:`(p + c)^2/(2I_3(1-k))` (immaterial for the dynamics).
* eq. (43), Corollary 3 (:math:`\\varphi_1 = \\varphi_2 = 0`, so :math:`\\Gamma_1 = p_1`, :math:`\\Gamma_2 = p_2`):
  equal to :math:`H_c\\circ U_p`.
* eq. (42), Theorem 6, **is not well defined as printed**: its last term is an antiderivative in
  :math:`l` at fixed :math:`L`,
  :math:`-\\sqrt{G^2-L^2}\\int[(\\tilde\\varphi_1 + p_1)\\cos l/\\lambda_1
  - (\\tilde\\varphi_2 + p_2)\\sin l/\\lambda_2]\\,dl`,
  which fixes :math:`\\partial h_p/\\partial l` but leaves an arbitrary function :math:`f(L)`, and
  :math:`f` changes :math:`\\dot l = \\partial h_p/\\partial L`. With the integral taken from
  :math:`l = 0` the missing term is
  :math:`f(L) = -\\tfrac1{\\lambda_2}\\int_0^{\\sqrt{G^2-L^2}}(\\varphi_2(u) + p_2)\\,du`
  (:func:`eq42_missing_term`), nonzero even for :math:`\\varphi_2 = 0, p_2 \\ne 0`. The correct
  :math:`h_p` is :math:`H_c\\circ U_p` with :math:`H_c` of eq. (41).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import sympy as sp

from ..errors import InputError, SymbolicError
from ..symbolic.integrals import integral_from_zero
from ..systems.control import V_SYMBOL, StructurePreservingControl
from ..systems.rotors import RotorBody
from .serret_andoyer import G_SYM, L_SYM, GeneralizedSerretAndoyer, l_SYM

__all__ = [
    "eq32_reduced_hamiltonian",
    "eq34_reduced_hamiltonian",
    "eq42_reduced_hamiltonian",
    "eq42_missing_term",
    "eq43_reduced_hamiltonian",
    "locked_rotor_control",
    "theorem5_boundary",
]


def _values(control: StructurePreservingControl) -> dict[sp.Symbol, sp.Expr]:
    return {sp.Symbol(k, real=True): sp.Float(v) for k, v in control.parameters.items()}


def _sym(name: str) -> sp.Symbol:
    return sp.Symbol(name, real=True)


def _int0(f: sp.Expr, upper: sp.Expr) -> sp.Expr:
    val = integral_from_zero(f, V_SYMBOL, upper, "auto")
    if val is None:
        s = sp.Dummy("s", real=True)
        return sp.Integral(f.xreplace({V_SYMBOL: s}), (s, 0, upper))
    return val


def _require(control: StructurePreservingControl, kind: str, what: str) -> tuple[sp.Expr, ...]:
    if not isinstance(control, StructurePreservingControl) or control.kind != kind or control.phi_of_v is None:
        raise InputError(
            f"{what} needs a symbolic {kind} control (StructurePreservingControl."
            f"{'one_rotor' if kind == 'one-rotor' else 'diagonal'} with phi a formula in v)."
        )
    want = np.array([[0.0, 0.0, 1.0]]) if kind == "one-rotor" else np.eye(3)
    if (
        control.body.axes.shape != want.shape
        or not np.array_equal(control.body.axes, want)
        or not control.body.is_principal
    ):
        raise InputError(
            f"{what} is the seed's formula for rotors along the principal axes "
            f"{'e3' if kind == 'one-rotor' else 'e1, e2, e3'} of a diagonal Lambda."
        )
    return control.phi_of_v


def _quadratic() -> sp.Expr:
    return (G_SYM**2 - L_SYM**2) / 2 * (sp.sin(l_SYM) ** 2 / _sym("lambda1") + sp.cos(l_SYM) ** 2 / _sym("lambda2"))


def eq32_reduced_hamiltonian(control: StructurePreservingControl) -> sp.Expr:
    """Eq. (32) of Theorem 4 for one rotor on axis 3, from its printed formula."""
    (phi,) = _require(control, "one-rotor", "Eq. (32)")
    I3, p = _sym("I3"), _sym("p")
    h = _quadratic() + L_SYM**2 / (2 * I3) - (_int0(phi, L_SYM) + p * L_SYM) / I3
    return h.subs(_values(control))


def eq34_reduced_hamiltonian(control: StructurePreservingControl) -> sp.Expr:
    """Eq. (34) as printed, for :math:`\\varphi(v) = kv + c` (:math:`c` joins :math:`p`); :math:`k \\ne 1`.

    It equals :math:`h_p + (p + c)^2/(2 I_3 (1 - k))`: the printed square differs from eq. (32) by a constant.
    """
    (phi,) = _require(control, "one-rotor", "Eq. (34)")
    phi = phi.subs(_values(control))
    poly = sp.Poly(phi, V_SYMBOL) if phi.is_polynomial(V_SYMBOL) else None
    if poly is None or poly.degree() > 1:
        raise InputError(f"Eq. (34) is for a linear phi(v) = k v + c, got phi = {phi}.")
    k, c = poly.coeff_monomial(V_SYMBOL), poly.coeff_monomial(1)
    if sp.simplify(k - 1) == 0:
        raise InputError("Eq. (34) divides by 1 - k; k = 1 is the non-hyperregular case it excludes.")
    I3, p = _sym("I3"), _sym("p")
    h = _quadratic() + ((1 - k) * L_SYM - (p + c)) ** 2 / (2 * I3 * (1 - k))
    return h.subs(_values(control))


def eq43_reduced_hamiltonian(control: StructurePreservingControl) -> sp.Expr:
    """Eq. (43) of Corollary 3: three rotors on the principal axes, :math:`\\varphi_1 = \\varphi_2 = 0`."""
    phis = _require(control, "diagonal", "Eq. (43)")
    if len(phis) != 3 or sp.simplify(phis[0]) != 0 or sp.simplify(phis[1]) != 0:
        raise InputError(f"Eq. (43) is for three rotors with phi_1 = phi_2 = 0, got phi = {list(phis)}.")
    lam3 = _sym("lambda3")
    G1, G2, p3 = _sym("p1"), _sym("p2"), _sym("p3")
    s = sp.sqrt(G_SYM**2 - L_SYM**2)
    h = (
        _quadratic()
        - (G1 * sp.sin(l_SYM) / _sym("lambda1") + G2 * sp.cos(l_SYM) / _sym("lambda2")) * s
        + L_SYM**2 / (2 * lam3)
        - (_int0(phis[2], L_SYM) + p3 * L_SYM) / lam3
    )
    return h.subs(_values(control))


def eq42_reduced_hamiltonian(control: StructurePreservingControl) -> sp.Expr:
    """Eq. (42) of Theorem 6 as printed, its :math:`l`-antiderivative taken from :math:`l = 0`.

    Not :math:`h_p`: it misses the function of :math:`L` returned by :func:`eq42_missing_term` (see the
    module docstring); ``eq42 + eq42_missing_term == H_c o U_p``.
    """
    phis = _require(control, "diagonal", "Eq. (42)")
    if len(phis) != 3:
        raise InputError("Eq. (42) is for three rotors on the principal axes.")
    lam1, lam2, lam3 = _sym("lambda1"), _sym("lambda2"), _sym("lambda3")
    p1, p2, p3 = _sym("p1"), _sym("p2"), _sym("p3")
    s = sp.sqrt(G_SYM**2 - L_SYM**2)
    t = sp.Dummy("t", real=True)
    integrand = (phis[0].xreplace({V_SYMBOL: s * sp.sin(t)}) + p1) * sp.cos(t) / lam1 - (
        phis[1].xreplace({V_SYMBOL: s * sp.cos(t)}) + p2
    ) * sp.sin(t) / lam2
    integrand = integrand.subs(_values(control))
    lint = sp.integrate(integrand, (t, 0, l_SYM))
    h = _quadratic() + L_SYM**2 / (2 * lam3) - (_int0(phis[2], L_SYM) + p3 * L_SYM) / lam3 - s * lint
    return h.subs(_values(control))


def eq42_missing_term(control: StructurePreservingControl) -> sp.Expr:
    """The function of :math:`L` that eq. (42) leaves undetermined, for the antiderivative from :math:`l = 0`:
    :math:`f(L) = -\\tfrac{1}{\\lambda_2}\\int_0^{\\sqrt{G^2 - L^2}} (\\varphi_2(u) + p_2)\\,du`."""
    phis = _require(control, "diagonal", "Eq. (42)")
    s = sp.sqrt(G_SYM**2 - L_SYM**2)
    f = -(_int0(phis[1], s) + _sym("p2") * s) / _sym("lambda2")
    return f.subs(_values(control))


def locked_rotor_control(body: RotorBody) -> StructurePreservingControl:
    """The control that locks the rotor on axis 3: :math:`\\varphi(v) = kv`, :math:`k = J_3/(I_3 + J_3)`,
    :math:`p = 0` (section 6, after eq. 34). Started with :math:`\\Gamma = k m_3` it keeps the rotor's
    rate :math:`\\dot\\gamma = \\Gamma/J_3 - \\omega_3` at zero, and :math:`H_c` is the free rigid body
    with inertias :math:`(\\lambda_1, \\lambda_2, I_3 + J_3)`."""
    J3 = float(body.require_rotor_inertia("The locked-rotor control")[0])
    if body.n_rotors != 1 or abs(body.axes[0, 2]) != 1.0 or not body.is_principal:
        raise InputError("The locked-rotor control of section 6 is for one rotor on body axis 3.")
    I3 = float(body.inertia[2, 2])
    return StructurePreservingControl.one_rotor(body, "k*v", parameters={"k": J3 / (I3 + J3)}, p=0.0)


def theorem5_boundary(lambda2: Any, I3: Any) -> Any:
    """Theorem 5: the spin about the intermediate axis is stable for :math:`\\varphi'(0) > 1 - I_3/\\lambda_2`
    (when :math:`\\varphi(0) + p = 0`, :math:`\\lambda_1 > \\lambda_2`); for :math:`\\varphi = kv` the
    boundary is :math:`k = 1 - I_3/\\lambda_2`, unstable (a real pair) below it."""
    return 1 - I3 / lambda2


def closed_loop_h_p(control: StructurePreservingControl, axis: int = 2) -> sp.Expr:
    """:math:`h_p(l, L) = H_c(U_p(l, L))` of a closed loop (Theorems 4 and 6), from the generic Serret-Andoyer
    machinery."""
    if not control.hamiltonian_is_closed_form:
        raise SymbolicError(
            "The symbolic reduced Hamiltonian needs a closed-form H_c; sympy found no "
            "antiderivative of phi, so H_c is computed by quadrature. Use "
            "GeneralizedSerretAndoyer(control.closed_loop()).reduced_system(G) numerically."
        )
    return GeneralizedSerretAndoyer(control.closed_loop()).h_p(axis)

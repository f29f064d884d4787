"""Stability of relative equilibria of left-invariant systems, three ways (section 6.3 of the
Serret-Andoyer paper and its reference [7]).

For a relative equilibrium :math:`m_e` (a critical point of :math:`h_p = H\\circ U_p` on :math:`|m| = G`):

* **Lagrange-Dirichlet** on the reduced canonical system :math:`(l, L)`: a definite Hessian
  :math:`\\delta^2 h_p` (either sign) proves Lyapunov stability, :math:`\\pm h_p` being a Lyapunov
  function. An indefinite Hessian leaves the criterion *silent*: it is reported as inconclusive, never as
  instability.
* **Energy-Casimir** on the Lie-Poisson form: with :math:`\\nabla H(m_e) = \\mu m_e` and the Casimir
  :math:`C(m) = \\Phi(|m|^2/2)`, :math:`\\Phi'(G^2/2) = -\\mu`, the first variation of :math:`H + C`
  vanishes at :math:`m_e`, and the second variation is :math:`D^2H - \\mu I + \\Phi'' m_e m_e^T`.
  Definiteness of :math:`D^2H - \\mu I` on :math:`m_e^\\perp` (the tangent space of the coadjoint orbit)
  lets :math:`\\Phi''` make the whole second variation definite: Arnold's criterion then proves stability.
  Computed in :math:`\\mathbb R^3` with no chart, it is an independent route to the same question.
* **Linearisation**: the eigenvalues of the reduced linear system
  :math:`\\dot\\xi = J\\,\\delta^2 h_p\\,\\xi`, :math:`J = \\begin{pmatrix}0&1\\\\-1&0\\end{pmatrix}`, which are
  :math:`\\pm\\sqrt{-\\det\\delta^2 h_p}`, and those of Euler's equation linearised in :math:`\\mathbb R^3`,
  :math:`\\widehat{m_e}\\,D^2H(m_e) - \\widehat{\\nabla H(m_e)}`, which are the same pair and a zero (the
  Casimir direction). A real pair proves instability (Lyapunov's indirect method); an
  imaginary pair decides nothing about nonlinear stability.

Theorem 5 of the seed: for one rotor on axis 3 with :math:`\\varphi(0) + p = 0`, the spin about the
intermediate axis, :math:`(l, L) = (0, 0)`, has :math:`\\delta^2 h_p = \\operatorname{diag}(-G^2(1/\\lambda_2
- 1/\\lambda_1),\\ 1/I_3 - 1/\\lambda_2 - \\varphi'(0)/I_3)`, definite iff
:math:`\\varphi'(0) > 1 - I_3/\\lambda_2`; below that value the pair is real, so the boundary is sharp.
:func:`stability_boundary` finds it (and boundaries with no closed form) by root-finding on the
determinant of the energy-Casimir second variation along a continued equilibrium.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _validate as V
from .._display import ShowsItselfAsHTML
from ..errors import ConvergenceError, InputError, NumericalError
from ..lie.so3 import hat
from ..systems import as_left_invariant
from .equilibria import Equilibrium, EquilibriumSet, find_equilibria, refine_equilibrium

__all__ = [
    "Verdict",
    "StabilityReport",
    "StabilityAnalysis",
    "StabilityBoundary",
    "PerturbationGrowth",
    "lagrange_dirichlet",
    "energy_casimir",
    "linearisation",
    "assess",
    "analyse_stability",
    "stability_boundary",
    "perturbation_growth",
    "VERDICT_CODES",
]

#: Codes used in data files: stable 1, inconclusive 0, unstable -1, no equilibrium found -9.
VERDICT_CODES = {"stable": 1, "inconclusive": 0, "unstable": -1, "none": -9}

_DEGENERATE = 1e-9


@dataclass(frozen=True)
class Verdict(ShowsItselfAsHTML):
    """One method's verdict: ``"stable"``, ``"unstable"`` or ``"inconclusive"``, with the evidence.

    ``matrix`` is the matrix the verdict rests on (the Hessian of :math:`h_p`, the energy-Casimir second
    variation on :math:`m_e^\\perp`, or the reduced linearisation) and ``eigenvalues`` its eigenvalues.
    """

    method: str
    verdict: str
    reason: str
    matrix: np.ndarray
    eigenvalues: np.ndarray
    extra: Mapping[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        ev = np.asarray(self.eigenvalues)
        eig = (
            [{"re": float(z.real), "im": float(z.imag)} for z in ev]
            if np.iscomplexobj(ev)
            else ev.astype(float).tolist()
        )
        extra = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.extra.items()}
        return {
            "verdict": self.verdict,
            "reason": self.reason,
            "matrix": np.asarray(self.matrix).tolist(),
            "eigenvalues": eig,
            **extra,
        }


def _definiteness(ev: np.ndarray) -> str:
    scale = max(np.abs(ev).max(), 1e-300)
    if np.abs(ev).min() <= _DEGENERATE * scale or np.abs(ev).max() == 0:
        return "degenerate"
    if np.all(ev > 0):
        return "positive"
    if np.all(ev < 0):
        return "negative"
    return "indefinite"


def lagrange_dirichlet(equilibrium: Equilibrium) -> Verdict:
    """The Lagrange-Dirichlet criterion on the reduced canonical system (section 6.3).

    Definite :math:`\\delta^2 h_p` -> ``"stable"`` (Lyapunov); indefinite or degenerate -> ``"inconclusive"``.
    """
    H = equilibrium.hessian
    ev = np.linalg.eigvalsh(H)
    kind = _definiteness(ev)
    chart = f"chart about axis {equilibrium.axis + 1}"
    if kind in ("positive", "negative"):
        what = "minimum" if kind == "positive" else "maximum"
        return Verdict(
            "lagrange-dirichlet",
            "stable",
            f"the Hessian of h_p ({chart}) is {kind} definite: a strict local {what} of h_p, so "
            f"{'+' if kind == 'positive' else '-'}h_p is a Lyapunov function (Lyapunov stable).",
            H,
            ev,
        )
    if kind == "indefinite":
        return Verdict(
            "lagrange-dirichlet",
            "inconclusive",
            f"the Hessian of h_p ({chart}) is indefinite (a saddle of h_p): the Lagrange-Dirichlet "
            "criterion is silent here; it does not prove instability (see the linearisation).",
            H,
            ev,
        )
    return Verdict(
        "lagrange-dirichlet",
        "inconclusive",
        f"the Hessian of h_p ({chart}) is singular (a degenerate critical point): the criterion "
        "needs a definite Hessian; higher-order terms decide.",
        H,
        ev,
    )


def _tangent_basis(m: np.ndarray) -> np.ndarray:
    u = m / np.linalg.norm(m)
    q, _ = np.linalg.qr(np.column_stack([u, np.eye(3)[np.argsort(np.abs(u))[:2]].T]))
    return q[:, 1:3]


def energy_casimir(system: Any, equilibrium: Equilibrium) -> Verdict:
    """The energy-Casimir method on the Lie-Poisson form (the method of the seed's reference [7]).

    Returns the second variation :math:`D^2H - \\mu I` restricted to :math:`m_e^\\perp` (orthonormal basis),
    its eigenvalues, and in ``extra`` the Casimir :math:`\\Phi'`, a :math:`\\Phi''` that makes the full
    3x3 second variation of :math:`H + C` definite, and that matrix's eigenvalues.
    """
    system = as_left_invariant(system)
    m = equilibrium.m
    G2 = float(m @ m)
    g = system.gradient(m)
    D2 = system.hessian(m)
    mu = float(g @ m) / G2
    A = D2 - mu * np.eye(3)
    B = _tangent_basis(m)
    Q = B.T @ A @ B
    Q = 0.5 * (Q + Q.T)
    ev = np.linalg.eigvalsh(Q)
    kind = _definiteness(ev)
    extra: dict[str, Any] = {"mu": mu, "casimir_dphi": -mu}
    if kind in ("positive", "negative"):
        sgn = 1.0 if kind == "positive" else -1.0
        c = sgn * (np.abs(A).max() + 1.0) / G2
        for _ in range(60):
            full = A + c * np.outer(m, m)
            fe = np.linalg.eigvalsh(full)
            if np.all(sgn * fe > 0):
                break
            c *= 4.0
        extra.update(
            {"casimir_ddphi": float(c), "full_second_variation": full, "full_second_variation_eigenvalues": fe}
        )
        return Verdict(
            "energy-casimir",
            "stable",
            f"with C(m) = Phi(|m|^2/2), Phi' = {-mu:.6g}, Phi'' = {c:.6g}, the second variation of "
            f"H + C at m_e is {kind} definite: nonlinearly stable (Arnold's energy-Casimir criterion).",
            Q,
            ev,
            extra,
        )
    reason = (
        "the second variation of H + C on the tangent space of the momentum sphere is indefinite: no "
        "Casimir makes it definite, and the energy-Casimir method is silent (it does not prove instability)."
        if kind == "indefinite"
        else "the second variation of H + C on the tangent space of the momentum sphere is singular: the "
        "energy-Casimir method needs it definite."
    )
    return Verdict("energy-casimir", "inconclusive", reason, Q, ev, extra)


def linearisation(system: Any, equilibrium: Equilibrium) -> Verdict:
    """Eigenvalues of the linearised reduced flow, and of Euler's equation linearised in :math:`\\mathbb R^3`.

    A real pair (:math:`\\det\\delta^2h_p < 0`) -> ``"unstable"`` (Lyapunov's indirect method); an
    imaginary pair or zeros -> ``"inconclusive"``.
    """
    system = as_left_invariant(system)
    H = equilibrium.hessian
    Jlin = np.array([[H[1, 0], H[1, 1]], [-H[0, 0], -H[0, 1]]])
    ev = np.linalg.eigvals(Jlin).astype(complex)
    m = equilibrium.m
    lp = hat(m) @ system.hessian(m) - hat(system.gradient(m))
    lp_ev = np.linalg.eigvals(lp).astype(complex)
    det = float(np.linalg.det(H))
    scale = max(np.abs(H).max() ** 2, 1e-300)
    extra = {
        "lie_poisson_matrix": lp,
        "lie_poisson_eigenvalues": [{"re": float(z.real), "im": float(z.imag)} for z in lp_ev],
    }
    if det < -_DEGENERATE * scale:
        sigma = float(np.sqrt(-det))
        return Verdict(
            "linearisation",
            "unstable",
            f"the linearised reduced flow has the real pair +-{sigma:.6g}: perturbations grow like "
            f"exp({sigma:.4g} t), the equilibrium is unstable (Lyapunov's indirect method).",
            Jlin,
            ev,
            extra,
        )
    if det > _DEGENERATE * scale:
        return Verdict(
            "linearisation",
            "inconclusive",
            f"the linearised reduced flow has the imaginary pair +-{np.sqrt(det):.6g} i (spectrally "
            "stable): linearisation does not decide nonlinear stability.",
            Jlin,
            ev,
            extra,
        )
    return Verdict(
        "linearisation",
        "inconclusive",
        "the linearised reduced flow is degenerate (zero eigenvalues): linearisation decides nothing.",
        Jlin,
        ev,
        extra,
    )


@dataclass(frozen=True)
class StabilityReport(ShowsItselfAsHTML):
    """The three verdicts on one relative equilibrium, and the combined one.

    ``verdict`` is ``"stable"`` if Lagrange-Dirichlet or energy-Casimir proves it, ``"unstable"`` if the
    linearisation proves it, ``"inconclusive"`` otherwise.
    """

    equilibrium: Equilibrium
    lagrange_dirichlet: Verdict
    energy_casimir: Verdict
    linearisation: Verdict

    @property
    def verdict(self) -> str:
        if "stable" in (self.lagrange_dirichlet.verdict, self.energy_casimir.verdict):
            return "stable"
        if self.linearisation.verdict == "unstable":
            return "unstable"
        return "inconclusive"

    def to_json(self) -> dict[str, Any]:
        eq = self.equilibrium.to_json()
        return {
            **eq,
            "linearisation_eigenvalues": self.linearisation.to_json()["eigenvalues"],
            "verdicts": {
                "lagrange_dirichlet": self.lagrange_dirichlet.verdict,
                "energy_casimir": self.energy_casimir.verdict,
                "linearisation": self.linearisation.verdict,
            },
            "verdict": self.verdict,
            "evidence": {
                "lagrange_dirichlet": self.lagrange_dirichlet.to_json(),
                "energy_casimir": self.energy_casimir.to_json(),
                "linearisation": self.linearisation.to_json(),
            },
        }


def assess(system: Any, equilibrium: Equilibrium) -> StabilityReport:
    """All three verdicts on ``equilibrium``."""
    return StabilityReport(
        equilibrium,
        lagrange_dirichlet(equilibrium),
        energy_casimir(system, equilibrium),
        linearisation(system, equilibrium),
    )


@dataclass(frozen=True)
class StabilityAnalysis(ShowsItselfAsHTML):
    """Every relative equilibrium on :math:`|m| = G` with its :class:`StabilityReport`."""

    reports: tuple[StabilityReport, ...]
    equilibria: EquilibriumSet

    def __iter__(self):
        return iter(self.reports)

    def __len__(self) -> int:
        return len(self.reports)

    def nearest(self, m: Any) -> StabilityReport:
        eq = self.equilibria.nearest(m)
        return next(r for r in self.reports if r.equilibrium is eq)

    def to_json(self) -> dict[str, Any]:
        return {
            "G": self.equilibria.G,
            "complete": self.equilibria.complete,
            "index_sum": self.equilibria.index_sum,
            "message": self.equilibria.message,
            "equilibria": [r.to_json() for r in self.reports],
        }


def analyse_stability(system: Any, G: float = 1.0, *, n_points: int = 1500) -> StabilityAnalysis:
    """Find every relative equilibrium on :math:`|m| = G` and assess each (three verdicts)."""
    system = as_left_invariant(system)
    eqs = find_equilibria(system, G, n_points=n_points)
    return StabilityAnalysis(tuple(assess(system, e) for e in eqs), eqs)


def _ec_determinant(system: Any, m: np.ndarray) -> float:
    """det of the energy-Casimir second variation on m^perp, in units of its natural scale (chart-free, so
    continuous along a parameter)."""
    g = system.gradient(m)
    D2 = system.hessian(m)
    mu = float(g @ m) / float(m @ m)
    B = _tangent_basis(m)
    Q = B.T @ (D2 - mu * np.eye(3)) @ B
    return float(np.linalg.det(Q)) / max(np.abs(D2).max() ** 2, 1e-300)


@dataclass(frozen=True)
class StabilityBoundary:
    """Where the verdict on a continued equilibrium changes along ``parameter``.

    ``value`` is the root of the energy-Casimir determinant (equivalently :math:`\\det\\delta^2 h_p`);
    ``stable_side`` is ``"above"`` or ``"below"`` it (the definite side); ``m`` the equilibrium there.
    """

    parameter: str
    value: float
    bracket: tuple[float, float]
    stable_side: str
    m: np.ndarray
    evaluations: int


def stability_boundary(
    family: Callable[..., Any],
    parameter: str,
    bracket: tuple[float, float],
    *,
    G: float = 1.0,
    near: Any = None,
    fixed: Mapping[str, float] | None = None,
    xtol: float = 1e-13,
) -> StabilityBoundary:
    """Find the parameter value where the relative equilibrium near ``near`` changes stability.

    Parameters
    ----------
    family : callable ``family(**parameters) -> LeftInvariantSystem`` (e.g. ``control.family()``).
    parameter : the parameter varied over ``bracket``, at whose ends the verdicts must differ.
    near : (3,) the equilibrium followed (continued by Newton from one evaluation to the next);
        default :math:`(0, G, 0)`, the spin about the intermediate axis, the seed's :math:`(l, L) = (0, 0)`.
    fixed : other parameter values passed to ``family``.
    """
    from scipy.optimize import brentq

    G = V.positive_scalar(G, "G")
    a, b = (float(x) for x in V.finite(bracket, "bracket"))
    near = np.array([0.0, G, 0.0]) if near is None else V.exact_shape(near, "near", (3,))
    fixed = dict(fixed or {})
    known: dict[float, np.ndarray] = {}
    count = [0]

    def f(x: float) -> float:
        seed = near if not known else known[min(known, key=lambda k: abs(k - x))]
        system = family(**{**fixed, parameter: x})
        try:
            eq = refine_equilibrium(system, seed, G)
        except ConvergenceError as exc:
            raise ConvergenceError(f"While following the equilibrium along {parameter} = {x:.12g}: {exc}") from exc
        known[x] = eq.m
        count[0] += 1
        return _ec_determinant(system, eq.m)

    fa, fb = f(a), f(b)
    if fa * fb > 0:
        raise InputError(
            f"Expected the stability of the equilibrium near {near.tolist()} to change between "
            f"{parameter} = {a:g} and {b:g}; the determinant of the second variation has the same sign "
            f"({fa:.3g}, {fb:.3g}) at both ends. Widen or move `bracket`."
        )
    root = brentq(f, a, b, xtol=xtol, rtol=4 * np.finfo(float).eps, maxiter=200)
    stable_side = "above" if (fb > 0) == (b > a) else "below"
    m = known[min(known, key=lambda k: abs(k - root))]
    return StabilityBoundary(parameter, float(root), (a, b), stable_side, m, count[0])


@dataclass(frozen=True)
class PerturbationGrowth:
    """A simulation of Euler's equation from :math:`m_e` perturbed by ``delta`` along the sphere.

    ``ratio`` = max over time of :math:`|m(t) - m_e|` divided by ``delta``: of order one for a stable
    equilibrium, large (:math:`\\gg 1`) when the perturbation grows.
    """

    t: np.ndarray
    deviation: np.ndarray
    delta: float
    ratio: float


def perturbation_growth(
    system: Any,
    m_e: Any,
    *,
    delta: float = 1e-3,
    t_final: float = 200.0,
    direction: Any = None,
    samples: int = 2001,
    rtol: float = 1e-11,
) -> PerturbationGrowth:
    """Integrate Euler's equation :math:`\\dot m = m\\times\\nabla H` from :math:`m_e + \\delta\\,u` (projected
    back to :math:`|m| = |m_e|`) and record the deviation :math:`|m(t) - m_e|`."""
    from scipy.integrate import solve_ivp

    system = as_left_invariant(system)
    m_e = V.exact_shape(m_e, "m_e", (3,))
    G = float(np.linalg.norm(m_e))
    delta = V.positive_scalar(delta, "delta")
    t_final = V.positive_scalar(t_final, "t_final")
    if direction is None:
        B = _tangent_basis(m_e)
        direction = B @ np.array([1.0, 1.0]) / np.sqrt(2.0)
    u = V.exact_shape(direction, "direction", (3,))
    u = u - (u @ m_e) * m_e / G**2
    if np.linalg.norm(u) == 0:
        raise InputError("Expected `direction` to have a component tangent to the sphere at m_e.")
    m0 = m_e + delta * G * u / np.linalg.norm(u)
    m0 *= G / np.linalg.norm(m0)
    t = np.linspace(0.0, t_final, int(samples))
    sol = solve_ivp(
        lambda _t, m: system.euler_vector_field(m),
        (0.0, t_final),
        m0,
        method="DOP853",
        t_eval=t,
        rtol=rtol,
        atol=rtol * G,
    )
    if sol.status < 0:
        raise NumericalError(f"Perturbation growth: integration failed at t = {sol.t[-1]:.6g}: {sol.message}")
    dev = np.linalg.norm(sol.y.T - m_e, axis=-1)
    return PerturbationGrowth(t, dev, delta * G, float(dev.max() / (delta * G)))

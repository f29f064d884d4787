"""Hyperregularity of a closed-loop Hamiltonian H_c: where phi'(v) = 1, or det(I - A Dphi(m)) = 0."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from ..symbolic.compile import M_SYMBOLS
from ..symbolic.integrals import symbolic_friendly

#: The variable of a scalar phi(v) (v = m3 for the rotor on axis 3; v = m_i for phi_i of Corollary 2).
V_SYMBOL = sp.Symbol("v", real=True)

HYPERREGULARITY_COST = (
    "Where H_c is not hyperregular, its fibre derivative m -> omega = grad H_c(m) is not invertible, so the "
    "Lagrangian side is lost there: the closed-loop Lagrangian, the inverse Legendre transform omega -> m "
    "(Lemma 1, eq. 14) and the 3-1-3 Euler-angle velocities. The Hamiltonian side uses grad H_c only and is "
    "unaffected: Euler's equation m' = m x grad H_c, the attitude equation, the Serret-Andoyer reduction "
    "h_p = H_c o U_p with its reconstruction, and the stability analysis."
)


@dataclass(frozen=True)
class HyperregularityReport:
    """Hyperregularity of :math:`H_c` (:math:`\\varphi'(v)\\ne 1`; :math:`\\det(I - A D\\varphi)\\ne 0`).

    ``status`` is ``"yes"`` (proved), ``"no"`` (a point where it fails is known: ``where``, ``points``)
    or ``"unknown"`` (no failure found on the probed region, nothing proved). ``cost`` says what is lost
    where it fails and what still works.
    """

    status: str
    where: str
    points: tuple[float, ...]
    cost: str = HYPERREGULARITY_COST

    def to_json(self) -> dict[str, Any]:
        return {"status": self.status, "where": self.where, "points": list(self.points), "cost": self.cost}


def hyperregularity_report(c: Any, R: float) -> HyperregularityReport:
    """The report of :meth:`StructurePreservingControl.hyperregularity` on |m| <= R."""
    if c._separable:
        fails, unknown, pts = [], [], []
        for i in range(c.n_rotors):
            status, where, roots = _scalar(c, i, R)
            label = "phi'(v)" if c.n_rotors == 1 else f"phi_{i + 1}'(v)"
            if status == "no":
                fails.append(f"{label} = 1 {where}")
                pts.extend(roots)
            elif status == "unknown":
                unknown.append(f"{label}: {where}")
        if fails:
            return HyperregularityReport("no", "; ".join(fails), tuple(pts))
        if unknown:
            return HyperregularityReport("unknown", "; ".join(unknown), ())
        return HyperregularityReport(
            "yes",
            "phi'(v) != 1 for every real v (sympy)"
            if c.n_rotors == 1
            else "phi_i'(v) != 1 for every real v and every i (sympy)",
            (),
        )
    return _scan_determinant(c, R)


def _scalar(c: Any, i: int, R: float) -> tuple[str, str, list[float]]:
    from scipy.optimize import brentq

    if c._phi_1d_exprs is not None:
        th = dict(zip(c._psyms, c.theta()))
        d = sp.diff(c._phi_1d_exprs[i], V_SYMBOL).subs(th)
        sol = None
        # solved symbolically when phi' is in the class of symbolic_friendly (a rule, not a timer)
        if c._integral != "quadrature" and symbolic_friendly(d, V_SYMBOL):
            try:
                sol = sp.solveset(sp.Eq(d, 1), V_SYMBOL, domain=sp.S.Reals)
            except (NotImplementedError, ValueError, TypeError):
                sol = None
        if sol is not None:
            if sol is sp.S.EmptySet:
                return "yes", "", []
            if sol == sp.S.Reals:
                return "no", "for every v", []
            if isinstance(sol, sp.FiniteSet) and all(x.is_real for x in sol):
                roots = sorted(float(x) for x in sol)
                return "no", f"at v = {', '.join(f'{r:.6g}' for r in roots)}", roots
    v = np.linspace(-R, R, 4001)
    th = c.theta()
    with np.errstate(all="ignore"):
        f = c._dphi(np.outer(v, c.body.axes[i]), th)[..., i, :] @ c.body.axes[i] - 1.0
    ok = np.isfinite(f)
    f, v = f[ok], v[ok]
    roots = []
    for k in np.nonzero((f[:-1] == 0) | (f[:-1] * f[1:] < 0))[0][:8]:
        roots.append(
            float(v[k])
            if f[k] == 0
            else float(
                brentq(
                    lambda x: float(c._dphi(x * c.body.axes[i][None], th)[0, i] @ c.body.axes[i]) - 1.0,
                    v[k],
                    v[k + 1],
                    xtol=1e-14,
                )
            )
        )
    if roots:
        return "no", f"at v = {', '.join(f'{r:.6g}' for r in roots)} (numeric scan and root refinement)", roots
    return "unknown", f"no v with phi'(v) = 1 found on [-{R:g}, {R:g}] (numeric scan; nothing proved)", []


def _scan_determinant(c: Any, R: float) -> HyperregularityReport:
    rng = np.random.default_rng(5)
    x = rng.normal(size=(4000, 3))
    pts = R * rng.uniform(0, 1, (4000, 1)) ** (1 / 3) * x / np.linalg.norm(x, axis=1, keepdims=True)
    with np.errstate(all="ignore"):
        det = np.linalg.det(np.eye(3) - c.body.A @ c._dphi(pts, c.theta()))
    ok = np.isfinite(det)
    det, pts = det[ok], pts[ok]
    if det.size and (det.min() <= 0 <= det.max()):
        k = int(np.argmin(np.abs(det)))
        return HyperregularityReport(
            "no",
            f"det(I - A Dphi) changes sign on |m| <= {R:g}; smallest |det| "
            f"{abs(det[k]):.3g} at m = {np.round(pts[k], 6).tolist()}",
            tuple(pts[k].tolist()),
        )
    if c.phi_expression is not None:
        D = (sp.eye(3) - c._A_sym * c.phi_expression.jacobian(sp.Matrix(M_SYMBOLS))).det()
        D = sp.simplify(D.subs(dict(zip(c._psyms, c.theta()))))
        if D.is_number and D != 0:
            return HyperregularityReport("yes", f"det(I - A Dphi) = {D} is a nonzero constant", ())
    return HyperregularityReport(
        "unknown", f"det(I - A Dphi) keeps one sign on 4000 samples of |m| <= {R:g} (numeric scan; nothing proved)", ()
    )


# -- a left-invariant H(m) -------------------------------------------------------------------------------
def hamiltonian_hyperregularity(system: Any, R: float) -> HyperregularityReport:
    r"""Whether the fibre derivative :math:`FH: m \mapsto \nabla H(m)` of a left-invariant H is a diffeomorphism of
    :math:`\mathfrak{so}(3)^*` (hyperregular), decided where it can be:

    * a constant Hessian (quadratic H): exactly, by its determinant;
    * a separable :math:`H = \sum_i f_i(m_i)` (every mixed second derivative zero): :math:`FH` is a product of the
      maps :math:`f_i'`, a diffeomorphism exactly when each :math:`f_i''` has no real zero and each :math:`f_i'`
      is onto :math:`\mathbb R` (its limits at :math:`\pm\infty` infinite, of opposite signs), decided by sympy;
      a real zero of :math:`f_i''` is a singular point ("no", with where), a bounded :math:`f_i'` leaves
      momenta without a preimage ("no");
    * otherwise, and where sympy cannot decide: the sign of :math:`\det D^2H` over samples of the ball
      :math:`|m|\le R`; a change of sign is a singular point between two samples, located by bisection ("no",
      with where); one sign throughout is reported as definiteness on that ball, nothing proved ("unknown").
    """
    if system.expression is None:
        return HyperregularityReport("unknown", "H is given by Python callables: there is no formula to decide on", ())
    m = list(M_SYMBOLS)
    subs = {sp.Symbol(k, real=True): v for k, v in system.parameters.items()}
    H = system.expression.subs(subs)
    hess = sp.hessian(H, m)
    if not (hess.free_symbols & set(m)):
        det = sp.simplify(hess.det())
        if det != 0:
            return HyperregularityReport("yes", f"the Hessian is constant with determinant {det} != 0", ())
        return HyperregularityReport("no", "everywhere: the Hessian is constant and singular", ())
    if all(sp.simplify(hess[i, j]) == 0 for i in range(3) for j in range(3) if i != j):
        report = _separable(H, m, R)
        if report is not None:
            return report
    return _scan_hessian(system, R)


def _separable(H: sp.Expr, m: list, R: float) -> HyperregularityReport | None:
    """The verdict for :math:`H = \\sum f_i(m_i)`, or None where sympy cannot decide a component."""
    proofs = []
    for i, x in enumerate(m):
        f1 = sp.diff(H, x).subs({y: 0 for y in m if y is not x})
        f2 = sp.diff(f1, x)
        try:
            zeros = sp.solveset(sp.Eq(f2, 0), x, domain=sp.S.Reals)
        except (NotImplementedError, ValueError, TypeError):
            return None
        if zeros == sp.S.Reals:
            return HyperregularityReport("no", f"everywhere: d^2H/dm{i + 1}^2 = 0 identically", ())
        if isinstance(zeros, sp.FiniteSet) and zeros and all(z.is_real for z in zeros):
            roots = sorted(float(z) for z in zeros)
            point = [0.0, 0.0, 0.0]
            point[i] = roots[0]
            return HyperregularityReport(
                "no",
                f"the Hessian is singular where m{i + 1} = {', '.join(f'{r:.10g}' for r in roots)} "
                f"(d^2H/dm{i + 1}^2 = {f2} vanishes there)",
                tuple(point),
            )
        if zeros is not sp.S.EmptySet:
            return None
        try:
            lo, hi = sp.limit(f1, x, -sp.oo), sp.limit(f1, x, sp.oo)
        except (NotImplementedError, ValueError, TypeError):
            return None
        if {lo, hi} != {sp.oo, -sp.oo}:
            return HyperregularityReport(
                "no",
                f"dH/dm{i + 1} = {f1} runs from {lo} to {hi}: grad H is not onto so(3)*, angular velocities "
                "beyond that range have no momentum",
                (),
            )
        proofs.append(f"f{i + 1}'' != 0, f{i + 1}' onto R")
    return HyperregularityReport(
        "yes", f"H = f1(m1) + f2(m2) + f3(m3) with {'; '.join(proofs)} (sympy): grad H is a diffeomorphism", ()
    )


def _scan_hessian(system: Any, R: float) -> HyperregularityReport:
    rng = np.random.default_rng(5)
    x = rng.normal(size=(4000, 3))
    pts = R * rng.uniform(0, 1, (4000, 1)) ** (1 / 3) * x / np.linalg.norm(x, axis=1, keepdims=True)
    pts = np.concatenate([np.zeros((1, 3)), pts])

    def det(p: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            return np.linalg.det(system.hessian(p))

    d = det(pts)
    ok = np.isfinite(d)
    d, pts = d[ok], pts[ok]
    if d.size and d.min() <= 0 <= d.max():
        # a sign change between two samples: bisect the segment between them for a singular point
        a, b = pts[int(np.argmax(d))], pts[int(np.argmin(d))]
        da = float(det(a[None])[0])
        for _ in range(80):
            c = 0.5 * (a + b)
            dc = float(det(c[None])[0])
            if dc == 0:
                a = b = c
                break
            if np.sign(dc) == np.sign(da):
                a, da = c, dc
            else:
                b = c
        c = 0.5 * (a + b)
        return HyperregularityReport(
            "no",
            f"det D^2H changes sign on |m| <= {R:g}: the Hessian is singular at m = {np.round(c, 8).tolist()} "
            "(bisection between samples of opposite sign)",
            tuple(float(v) for v in c),
        )
    sign = "positive" if d.size and d.min() > 0 else "negative"
    return HyperregularityReport(
        "unknown",
        f"det D^2H is {sign} on 4001 samples of |m| <= {R:g} (definite there as far as sampled; nothing proved "
        "beyond, and H is not separable)",
        (),
    )

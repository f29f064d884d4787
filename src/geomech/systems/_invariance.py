"""G-invariance of a nonholonomic system's Lagrangian and constraint distribution, checked exactly at random
points, with a report that names the terms and constraints that break it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from ..symbolic.compile import evaluate

__all__ = ["InvarianceReport", "invariance_report"]

#: Relative tolerance of the numeric invariance tests (random points, exact formulas: round-off only).
_INVARIANCE_RTOL = 1e-9


@dataclass(frozen=True)
class InvarianceReport:
    """Outcome of the G-invariance checks of the Lagrangian and of the constraint distribution."""

    group: str
    lagrangian_invariant: bool
    lagrangian_breaking_terms: tuple[sp.Expr, ...]
    constraints_invariant: bool
    breaking_constraints: tuple[int, ...]

    @property
    def ok(self) -> bool:
        return self.lagrangian_invariant and self.constraints_invariant

    def message(self) -> str:
        parts = []
        if not self.lagrangian_invariant:
            terms = ", ".join(str(t) for t in self.lagrangian_breaking_terms) or "(terms not isolated)"
            parts.append(
                f"the Lagrangian is not invariant under {self.group}: written in body velocities it still "
                f"depends on the group variables through the term(s) {terms}"
            )
        if not self.constraints_invariant:
            which = ", ".join("#" + str(i) for i in self.breaking_constraints)
            parts.append(
                f"the constraint distribution is not invariant under {self.group}: constraint(s) {which} "
                "(0-based) change with the group variables beyond a re-combination of the others"
            )
        return "; ".join(parts) if parts else f"L and the constraints are invariant under {self.group}"

    def to_dict(self) -> dict:
        return {
            "ok": self.ok,
            "lagrangian_invariant": self.lagrangian_invariant,
            "lagrangian_breaking_terms": [str(t) for t in self.lagrangian_breaking_terms],
            "constraints_invariant": self.constraints_invariant,
            "breaking_constraints": list(self.breaking_constraints),
            "message": self.message(),
        }

    def to_json(self, **kwargs: Any) -> str:
        import json

        return json.dumps(self.to_dict(), **kwargs)

    def to_latex(self) -> str:
        terms = r",\; ".join(sp.latex(t) for t in self.lagrangian_breaking_terms) or r"\text{none}"
        return rf"\text{{{self.message().split(':')[0]}}}:\; {terms}"

    def __str__(self) -> str:
        return self.message()


def invariance_report(system: Any, *, samples: int = 3, seed: int = 11) -> InvarianceReport:
    """The G-invariance checks of
    :meth:`~geomech.systems.nonholonomic.NonholonomicSystem.check_invariance` (its docstring says how)."""
    rng = np.random.default_rng(seed)
    gq = system.group.coordinates
    L_body = system.lagrangian_in_body_velocity
    L_id = L_body.xreplace(system.reference_substitution)
    variables = list(gq + system.shape + system.xi + system.shape_dot)
    names = variables + list(system.parameter_symbols)
    pts = [system._random_point(rng, variables) for _ in range(samples)]
    # a few points: evaluated on the formulas' graph (compiling the Lagrangian took longer than checking it)
    both = evaluate([L_body, L_id], names, np.array([[pt[s] for s in names] for pt in pts], dtype=float))
    a, b = both[:, 0], both[:, 1]
    lag_ok = bool(np.all(np.abs(a - b) <= _INVARIANCE_RTOL * np.maximum(1.0, np.maximum(np.abs(a), np.abs(b)))))
    terms: tuple = ()
    if not lag_ok:
        diff = sp.expand(sp.expand_trig(L_body - L_id))
        vel = list(system.xi + system.shape_dot)
        poly = sp.Poly(diff, *vel)
        found = []
        for mon, coeff in zip(poly.monoms(), poly.coeffs()):
            cs = sp.simplify(coeff)
            if cs != 0:
                found.append(cs * sp.prod([v**e for v, e in zip(vel, mon)]))
        terms = tuple(found)
    bad_rows: list[int] = []
    if system.c:
        Lam_inv = system.group.body_velocity_inverse
        Abody = sp.Matrix(system.constraint_matrix[:, : system.k]) * Lam_inv
        Abody = sp.Matrix.hstack(Abody, sp.Matrix(system.constraint_matrix[:, system.k :]))
        names = list(gq + system.shape) + list(system.parameter_symbols)
        for _ in range(samples):
            pt = system._random_point(rng, list(gq + system.shape))
            args_g = [pt[s] for s in gq + system.shape] + [pt[s] for s in system.parameter_symbols]
            args_e = (
                [float(v) for v in system.group.reference]
                + [pt[s] for s in system.shape]
                + [pt[s] for s in system.parameter_symbols]
            )
            Ag, Ae = evaluate(Abody, names, np.array([args_g, args_e], dtype=float))
            _, sv, vt = np.linalg.svd(Ae)
            null = vt[np.sum(sv > 1e-12 * max(sv.max(), 1.0)) :].T
            res = np.abs(Ag @ null).max(axis=1) if null.size else np.zeros(system.c)
            scale = np.maximum(np.abs(Ag).max(axis=1), 1.0)
            bad_rows += [int(i) for i in np.nonzero(res > 1e-9 * scale)[0]]
    bad = tuple(sorted(set(bad_rows)))
    return InvarianceReport(system.group.name, lag_ok, terms, not bad, bad)

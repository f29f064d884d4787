r"""Nonholonomic mechanical systems with symmetry: a Lagrangian, linear velocity constraints and a group.

This is the setting of section 1 of the nonholonomic seed (Koon and Marsden, "The geometric structure of
nonholonomic mechanics") and of Bloch, Krishnaprasad, Marsden and Murray, "Nonholonomic mechanical
systems with symmetry", Arch. Rational Mech. Anal. 136 (1996) 21-99 ("BKMM"). The configuration space is
a trivial principal bundle :math:`Q = G \times S` with group variables :math:`g` (coordinates of a
matrix Lie group :math:`G`) and shape variables :math:`r`; the group acts on the left,
:math:`h\cdot(g, r) = (hg, r)`. The velocity is written in body form,

.. math::

    \xi = g^{-1}\dot g = \Lambda(g)\,\dot g \in \mathfrak g, \qquad \dot r,

so that a left-invariant Lagrangian is a function :math:`l(r, \xi, \dot r)` of the shape and the body
velocity only, and an invariant constraint distribution :math:`\mathcal D` is the kernel of one-forms
whose body components :math:`A_\xi(r)\,\xi + A_r(r)\,\dot r = 0` do not depend on :math:`g`.

Groups: any group of :mod:`geomech.lie` with its coordinate names, e.g. ``SE2("x", "y", "theta")``,
``SO3(...)``, ``SE3(...)``, ``Rn(...)``, ``SO2(...)``, their products (``SE2(...) * SO2(...)``), or a
:class:`~geomech.lie.MatrixGroup` given by a matrix parametrisation; the system holds its symbolic twin
(:class:`~geomech.symbolic.GroupChart`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError, ShapeError, SymbolicError
from ..symbolic._derivative import derivative
from ..symbolic.cache import DISK_CACHE, MISSING
from ..symbolic.charts import GroupChart, group_chart
from ..symbolic.formula import parse_formula
from ..symbolic.polys import expand_terms
from ..symbolic.simplify import quadratic_coefficients, simplify_expr
from ._invariance import InvarianceReport, invariance_report

__all__ = [
    "NonholonomicSystem",
    "InvarianceReport",
]


def _symbols(names: Sequence[Any], argname: str) -> tuple[sp.Symbol, ...]:
    out = []
    for n in names:
        if isinstance(n, sp.Symbol):
            out.append(n)
        elif isinstance(n, str) and n.isidentifier():
            out.append(sp.Symbol(n, real=True))
        else:
            raise InputError(
                f"Expected `{argname}` to hold coordinate names (identifiers or sympy Symbols), got {n!r}."
            )
    return tuple(out)


# --------------------------------------------------------------------------------------------------
# Parsing user formulas
# --------------------------------------------------------------------------------------------------
def _parse(
    expr: Any, names: dict[str, sp.Symbol], params: dict[str, sp.Symbol], argname: str, dyn: dict | None = None
) -> sp.Expr:
    if isinstance(expr, str):
        local = dict(names)
        local.update(params)
        # Every identifier that is not a known function or pi is a symbol: I (an inertia) and E (a modulus)
        # are not the imaginary unit and Euler's number.
        parsed = parse_formula(expr, argname, local)
    elif isinstance(expr, (sp.Basic, int, float)):
        parsed = sp.sympify(expr)
    else:
        raise SymbolicError(f"Expected `{argname}` to be a sympy expression or a string, got {type(expr).__name__}.")
    if dyn and parsed.has(sp.Derivative, sp.core.function.AppliedUndef):
        # written with dynamicsymbols: their first derivatives are the velocities (any other derivative is an
        # error: replaced structurally, it would differentiate a symbol to zero)
        other = parsed.atoms(sp.Derivative) - set(dyn["derivatives"])
        if other:
            raise SymbolicError(
                f"`{argname}` holds derivatives other than the first derivatives of the coordinates: "
                f"{sorted(map(str, other))}; a Lagrangian and its constraints take positions and velocities only."
            )
        parsed = parsed.xreplace({**dyn["derivatives"], **dyn["functions"]})
    if any(isinstance(f, sp.core.function.AppliedUndef) for f in parsed.atoms(sp.Function)):
        raise SymbolicError(
            f"`{argname}` contains undefined functions {sorted(map(str, parsed.atoms(sp.Function)))}; "
            "write it in the coordinate and velocity symbols (or dynamicsymbols of the coordinates)."
        )
    rename = {}
    for s in parsed.free_symbols:
        if s.name in names:
            rename[s] = names[s.name]
        elif s.name in params:
            rename[s] = params[s.name]
        else:
            params[s.name] = s if s.is_real else sp.Symbol(s.name, real=True)
            rename[s] = params[s.name]
    parsed = parsed.xreplace(rename)
    if parsed.has(sp.I, sp.zoo, sp.oo, sp.nan):
        raise SymbolicError(f"`{argname}` must be a finite real expression, got {parsed}.")
    return parsed


def _checked_values(symbols: Mapping[str, sp.Symbol], values: Mapping[str, Any], owner: str) -> dict[str, float]:
    """Parameter values as finite floats (:func:`geomech._validate.parameter_update`); a symbol declared positive
    (a mass, a length) takes only values > 0."""
    positive = {k for k, s in symbols.items() if s.is_positive}
    return V.parameter_update(values, symbols, owner, positive)


# --------------------------------------------------------------------------------------------------
# The system
# --------------------------------------------------------------------------------------------------
def _random_values(symbols: Sequence[sp.Symbol], rng: np.random.Generator) -> dict:
    # Parameters drawn positive (masses, lengths); coordinates and velocities anywhere in a unit box.
    return {s: float(rng.uniform(0.6, 1.7)) for s in symbols}


@dataclass(frozen=True, eq=False)
class NonholonomicSystem:
    r"""A Lagrangian system on :math:`Q = G \times S` with linear homogeneous velocity constraints.

    Build it with :meth:`from_lagrangian`. The coordinates are ``q = (group coordinates, shape)``,
    velocities ``qdot``; ``lagrangian`` is :math:`L = \tfrac12 \dot q^T \mathbb M(q)\dot q - V(q)` and the
    constraints are :math:`\omega^a(q)\,\dot q = 0`, the rows of ``constraint_matrix`` (c x n).

    ``parameters`` holds the numeric values known so far (derivations are symbolic in every parameter;
    numeric functions ask for the values of those not given here).
    """

    name: str
    group: GroupChart
    shape: tuple[sp.Symbol, ...]
    qdot: tuple[sp.Symbol, ...]
    lagrangian: sp.Expr
    constraint_matrix: sp.ImmutableMatrix
    parameter_symbols: tuple[sp.Symbol, ...]
    parameters: Mapping[str, float] = field(default_factory=dict)
    shape_angles: tuple[int, ...] = ()
    description: str = ""
    body_basis: sp.ImmutableMatrix | None = None
    basis_note: str = ""

    # ---------------- construction ----------------
    @classmethod
    def from_lagrangian(
        cls,
        lagrangian: Any,
        group: Any,
        shape: Sequence[Any] = (),
        constraints: Sequence[Any] = (),
        *,
        parameters: Mapping[str, float] | None = None,
        velocities: Sequence[Any] | Mapping[Any, Any] | None = None,
        shape_angles: Sequence[int] | None = None,
        name: str = "system",
        description: str = "",
        basis: Any = None,
        basis_note: str = "",
        check: bool = True,
    ) -> NonholonomicSystem:
        r"""Describe a nonholonomic system with symmetry.

        Parameters
        ----------
        lagrangian : sympy expression or str
            :math:`L(q, \dot q)`, kinetic (quadratic in the velocities) minus potential, in the coordinate
            symbols and the velocity symbols (default ``<name>_dot``: ``x_dot``, ``theta_dot``); sympy
            ``dynamicsymbols`` of the coordinates are accepted too. Every other symbol is a parameter.
        group : LieGroup or GroupChart
            The symmetry group with the names of its coordinates, e.g. ``geomech.lie.SE2("x", "y", "theta")``.
        shape : sequence of str or Symbol
            The shape variables :math:`r`.
        constraints : sequence
            One-forms :math:`\omega^a`: each either an expression linear and homogeneous in the velocities
            (``"-sin(theta)*x_dot + cos(theta)*y_dot"``) or the row of its ``n`` coefficients in the order
            ``q = (group coordinates, shape)``.
        parameters : mapping, optional
            Numeric values of (some of) the parameters.
        velocities : sequence or mapping, optional
            Names of the velocity symbols, in the order of ``q``, or a mapping coordinate -> velocity name for
            those that do not follow the default ``<name>_dot``.
        shape_angles : sequence of int, optional
            Indices (in ``shape``) of the shape variables that are angles; default: those whose name is a
            Greek letter.
        basis : k x m matrix, optional
            The body-fixed basis :math:`e_i(r)` of :math:`S_q` (columns, in the shape variables) that
            :func:`geomech.reduction.nonholonomic.bkmm_reduction` uses by default; ``basis_note`` says where
            it comes from (the nonholonomic momentum scales with it).
        check : bool
            Check G-invariance of L and of the constraint distribution (raise :class:`SymbolicError`
            naming the term that breaks it) and the regularity of the kinetic energy and constraints.

        Raises
        ------
        InputError
            Coordinates that do not match the group, repeated names, constraints that are not linear
            homogeneous in the velocities, dependent constraints.
        SymbolicError
            A Lagrangian that is not kinetic minus potential, or that (or the constraints) is not
            G-invariant.
        """
        group = group_chart(group)
        r = _symbols(list(shape), "shape")
        q = group.coordinates + r
        qnames = [s.name for s in q]
        dup = sorted({n for n in qnames if qnames.count(n) > 1})
        if dup:
            raise InputError(
                f"Expected distinct coordinate names, got {dup} both as group and as shape variables "
                f"(group {group.name} uses {[s.name for s in group.coordinates]})."
            )
        if isinstance(velocities, Mapping):
            given = {str(k): str(v) for k, v in velocities.items()}
            unknown = sorted(set(given) - set(qnames))
            if unknown:
                raise InputError(f"`velocities` names {unknown}, which are not coordinates ({qnames}).")
            vnames = [given.get(n, f"{n}_dot") for n in qnames]
        else:
            vnames = list(velocities) if velocities is not None else [f"{n}_dot" for n in qnames]
        if len(vnames) != len(q):
            raise InputError(f"Expected {len(q)} velocity names (one per coordinate {qnames}), got {len(vnames)}.")
        qd = _symbols(vnames, "velocities")
        names = {s.name: s for s in q + qd}
        if len(names) != 2 * len(q):
            raise InputError(f"Expected velocity names distinct from the coordinates, got {vnames}.")
        dyn = _dynamic_map(q, qd)
        params: dict[str, sp.Symbol] = {}
        L = _parse(lagrangian, names, params, "lagrangian", dyn)
        parsed_constraints = []
        for i, con in enumerate(constraints):
            if isinstance(con, (list, tuple, sp.MatrixBase, np.ndarray)):
                coeffs = [_parse(cf, names, params, f"constraints[{i}][{j}]", dyn) for j, cf in enumerate(list(con))]
                if len(coeffs) != len(q):
                    raise ShapeError(
                        f"Expected constraint #{i} to have {len(q)} coefficients (one per coordinate "
                        f"{qnames}), got {len(coeffs)}."
                    )
                if any(c.free_symbols & set(qd) for c in coeffs):
                    raise InputError(f"Constraint #{i}: the coefficients of a one-form must not contain velocities.")
                parsed_constraints.append(coeffs)
            else:
                parsed_constraints.append(_parse(con, names, params, f"constraints[{i}]", dyn))
        # before the constraints' form is judged: an undeclared velocity there would read as a parameter, and the
        # constraint as "not homogeneous", when the real fault is the shape/group split
        stray = sorted(p for p in params if p.endswith("_dot") or p.endswith("_ddot"))
        if stray:
            raise InputError(
                f"{name}: the formulas use {stray}, velocities of coordinates that are neither group "
                f"coordinates of {group.name} {[s.name for s in group.coordinates]} nor shape variables "
                f"{[s.name for s in r]}; declare them (a shape/group split that does not match L)."
            )
        rows = [c if isinstance(c, list) else _one_form(c, qd, i) for i, c in enumerate(parsed_constraints)]
        pvals = dict(parameters or {})
        unknown = sorted(set(pvals) - set(params))
        if unknown:
            raise InputError(
                f"`parameters` names {unknown}, which appear neither in the Lagrangian nor in the "
                f"constraints (parameters found: {sorted(params)})."
            )
        pvals = _checked_values(params, pvals, name)
        if shape_angles is None:
            greek = set(
                "alpha beta gamma delta epsilon zeta eta theta iota kappa lambda mu nu xi omicron pi rho "
                "sigma tau upsilon phi chi psi omega varphi vartheta".split()
            )
            shape_angles = [i for i, s in enumerate(r) if s.name.lower().rstrip("0123456789_") in greek]
        cmat = (
            sp.ImmutableMatrix(len(rows), len(q), [c for row in rows for c in row])
            if rows
            else sp.ImmutableMatrix(sp.zeros(0, len(q)))
        )
        E = None
        if basis is not None:
            # entries parsed one by one (sp.Matrix of strings would sympify them: eval)
            rows = (
                basis.tolist()
                if isinstance(basis, sp.MatrixBase)
                else [list(row) if isinstance(row, (list, tuple)) else [row] for row in basis]
            )
            if not rows or len({len(row) for row in rows}) != 1:
                raise ShapeError(f"Expected `basis` to be a matrix (a list of equal rows), got {basis!r}.")
            E = sp.Matrix(
                [
                    [_parse(e, names, params, f"basis[{i}][{j}]", dyn) for j, e in enumerate(row)]
                    for i, row in enumerate(rows)
                ]
            )
            if E.rows != group.dim and E.cols == group.dim:
                E = E.T
            if E.rows != group.dim:
                raise ShapeError(f"Expected `basis` to have {group.dim} rows (dim {group.name}), got shape {E.shape}.")
            E = sp.ImmutableMatrix(E)
        system = cls(
            name=name,
            group=group,
            shape=r,
            qdot=qd,
            lagrangian=L,
            constraint_matrix=cmat,
            parameter_symbols=tuple(sorted(params.values(), key=lambda s: s.name)),
            parameters=pvals,
            shape_angles=tuple(shape_angles),
            description=description,
            body_basis=E,
            basis_note=basis_note,
        )
        if check:
            system._check_mechanical()
            report = system.check_invariance()
            if not report.ok:
                raise SymbolicError(f"{name}: {report.message()}.")
        return system

    def with_parameters(self, **values: float) -> NonholonomicSystem:
        """The same system with more (or other) parameter values."""
        merged = dict(self.parameters)
        merged.update(_checked_values({s.name: s for s in self.parameter_symbols}, values, self.name))
        return dataclasses.replace(self, parameters=merged)

    def legendre_transform(self) -> Any:
        r"""The left-invariant Hamiltonian :math:`H(m)` on :math:`\mathfrak{so}(3)^*` of a system on SO(3) with no
        shape variables and no constraints (a rigid body given by its Lagrangian), for the Serret-Andoyer route.

        The Legendre transform :math:`m = \partial l/\partial\xi = \mathbb I\,\xi` of the reduced Lagrangian
        :math:`l(\xi) = \tfrac12\xi^T\mathbb I\,\xi - V` gives :math:`H(m) = \tfrac12 m^T\mathbb I^{-1}m + V`,
        :math:`m` the body angular momentum in the group's basis of :math:`\mathfrak{so}(3)` (the hat basis,
        :math:`\dot m = m\times\nabla H`). It is hyperregular: :math:`\mathbb I` is constant (G-invariance, no
        shape) and positive definite (checked when the system was built). Returns a
        :class:`~geomech.systems.LeftInvariantSystem` with this system's parameter values.
        """
        from ..lie import SO3
        from ..symbolic.compile import M_SYMBOLS
        from .left_invariant import LeftInvariantSystem

        if not isinstance(self.group.numeric, SO3):
            raise InputError(
                f"The Legendre transform to a left-invariant H(m) on so(3)* needs G = SO(3); {self.name} has "
                f"G = {self.group.name}: reduce it with geomech.reduction.bkmm_reduction instead."
            )
        if self.sigma or self.c:
            raise InputError(
                f"{self.name} has {self.sigma} shape variable(s) and {self.c} constraint(s): its reduced dynamics is "
                "not a Lie-Poisson system on so(3)* alone (H(m) would depend on the shape); reduce it with "
                "geomech.reduction.bkmm_reduction instead."
            )
        l = self.body_lagrangian
        xi = list(self.xi)
        inertia = sp.hessian(l, xi)
        V = sp.simplify(-l.subs({x: 0 for x in xi}))
        m = sp.Matrix(M_SYMBOLS)
        inv = inertia.inv().applyfunc(simplify_expr)
        H = sp.expand((m.T * inv * m)[0, 0] / 2) + V
        names = {s.name for s in H.free_symbols} - {s.name for s in M_SYMBOLS}
        missing = sorted(names - set(self.parameters))
        if missing:
            raise InputError(
                f"{self.name}: H(m) needs values for parameter(s) {missing}; give them with "
                f"with_parameters({', '.join(f'{k}=...' for k in missing)}) first."
            )
        values = {k: v for k, v in self.parameters.items() if k in names}
        return LeftInvariantSystem.from_expression(H, values, name=f"{self.name} (Legendre transform)")

    # ---------------- identity for caches ----------------
    @cached_property
    def key(self) -> tuple:
        """What the symbolic derivations depend on (the parameter values are not part of it)."""
        return (
            self.group.name,
            self.group.coordinates,
            self.group.matrix,
            self.group.basis,
            self.shape,
            self.qdot,
            self.lagrangian,
            self.constraint_matrix,
            self.body_basis,
        )

    @cached_property
    def derived_cache(self) -> dict:
        """Objects derived from this system object, kept with it for its lifetime (its default BKMM reduction, which
        keeps this object's parameter values: not shared with a system equal in content)."""
        return {}

    @cached_property
    def _hash(self) -> int:
        return hash(self.key)

    def __hash__(self) -> int:  # the caches of every derivation ask for it: computed once
        return self._hash

    def __eq__(self, other: object) -> bool:
        return isinstance(other, NonholonomicSystem) and (other is self or self.key == other.key)

    # ---------------- basic objects (made once: every run reads them) ----------------
    @cached_property
    def q(self) -> tuple[sp.Symbol, ...]:
        return self.group.coordinates + self.shape

    @cached_property
    def n(self) -> int:
        return len(self.q)

    @cached_property
    def k(self) -> int:
        """Dimension of the group."""
        return self.group.dim

    @cached_property
    def sigma(self) -> int:
        """Dimension of the shape space."""
        return len(self.shape)

    @cached_property
    def c(self) -> int:
        """Number of constraints."""
        return self.constraint_matrix.rows

    @cached_property
    def shape_dot(self) -> tuple[sp.Symbol, ...]:
        return self.qdot[self.k :]

    @cached_property
    def xi(self) -> tuple[sp.Symbol, ...]:
        """Body velocity symbols :math:`\\xi^1, \\dots, \\xi^k`."""
        return tuple(sp.Symbol(f"xi{a + 1}", real=True) for a in range(self.k))

    @cached_property
    def latex_names(self) -> dict:
        """LaTeX names of the velocity, acceleration and body-velocity symbols."""
        out = {}
        for s, v in zip(self.q, self.qdot):
            base = sp.latex(s)
            out[v] = rf"\dot{{{base}}}"
        for a, x in enumerate(self.xi):
            out[x] = rf"\xi^{{{a + 1}}}"
        return out

    @cached_property
    def mass_matrix(self) -> sp.ImmutableMatrix:
        r"""The kinetic-energy metric :math:`\mathbb M(q) = \partial^2 L / \partial\dot q^2`.

        Read off the Lagrangian's coefficients in one walk (:func:`~geomech.symbolic.quadratic_coefficients`; a
        Hessian by ``diff`` walks it once an entry, a second of the three-link chain's build); by the Hessian where
        L is not a polynomial of degree two in the velocities, which :meth:`_check_mechanical` then refuses by name.
        """
        try:
            c = quadratic_coefficients(self.lagrangian, self.qdot)
        except SymbolicError:
            return sp.ImmutableMatrix(sp.hessian(self.lagrangian, self.qdot))
        return sp.ImmutableMatrix(
            self.n, self.n, lambda i, j: (2 if i == j else 1) * c.get((min(i, j), max(i, j)), sp.Integer(0))
        )

    @cached_property
    def potential(self) -> sp.Expr:
        """:math:`V(q) = -L(q, 0)`."""
        return -self.lagrangian.xreplace({v: sp.Integer(0) for v in self.qdot})

    @cached_property
    def energy(self) -> sp.Expr:
        r""":math:`E = \dot q\cdot\partial L/\partial\dot q - L`."""
        return expand_terms(sum(v * derivative(self.lagrangian, v) for v in self.qdot) - self.lagrangian)

    @cached_property
    def body_substitution(self) -> dict:
        r"""Coordinate rates of the group in terms of the body velocity: :math:`\dot q_G = \Lambda^{-1}\xi`."""
        rates = self.group.body_velocity_inverse * sp.Matrix(self.xi)
        return dict(zip(self.qdot[: self.k], rates))

    @cached_property
    def reference_substitution(self) -> dict:
        """The group coordinates at the chart's regular reference point (the identity where it is regular)."""
        return dict(zip(self.group.coordinates, self.group.reference))

    @cached_property
    def lagrangian_in_body_velocity(self) -> sp.Expr:
        r""":math:`L(g, r, \xi, \dot r)`: the Lagrangian with the group's rates written by the body velocity
        (:attr:`body_substitution`; xreplace, as subs, since no rate appears in a value)."""
        return self.lagrangian.xreplace(self.body_substitution)

    @cached_property
    def body_lagrangian(self) -> sp.Expr:
        r"""The reduced Lagrangian :math:`l(r, \xi, \dot r) = L(e, r, \xi, \dot r)` (G-invariance assumed)."""
        return expand_terms(self.lagrangian_in_body_velocity.xreplace(self.reference_substitution))

    @cached_property
    def body_constraints(self) -> tuple[sp.ImmutableMatrix, sp.ImmutableMatrix]:
        r""":math:`(A_\xi(r), A_r(r))` with :math:`\mathcal D = \{A_\xi\xi + A_r\dot r = 0\}` at the identity."""
        Lam_inv = self.group.body_velocity_inverse.xreplace(self.reference_substitution)
        A = self.constraint_matrix.xreplace(self.reference_substitution)
        Ag = sp.Matrix(A[:, : self.k]) * Lam_inv
        return (sp.ImmutableMatrix(Ag.applyfunc(simplify_expr)), sp.ImmutableMatrix(A[:, self.k :]))

    # ---------------- numeric helpers ----------------
    def parameter_values(self, values: Mapping[str, float] | None = None) -> dict:
        """Values of every parameter symbol (``values`` override ``self.parameters``); raise if one is missing."""
        merged = dict(self.parameters)
        merged.update(values or {})
        missing = sorted(s.name for s in self.parameter_symbols if s.name not in merged)
        if missing:
            raise InputError(
                f"{self.name}: no value for parameter(s) {missing}; pass them as "
                f"parameters={{{', '.join(repr(m) + ': ...' for m in missing)}}}."
            )
        return {s: float(merged[s.name]) for s in self.parameter_symbols}

    def _random_point(self, rng: np.random.Generator, symbols: Sequence[sp.Symbol]) -> dict:
        vals = _random_values(self.parameter_symbols, rng)
        vals.update({s: float(rng.uniform(-1.2, 1.2)) for s in symbols})
        return vals

    def _quadratic_in_velocities(self) -> bool:
        """Whether L is plainly T(q, qdot) - V(q) with T quadratic in qdot: its Hessian in the velocities (the
        mass matrix) free of them, and no term linear in them (the gradient at qdot = 0 is zero as written).
        Cheap, unlike a polynomial in qdot over the field of the coordinates' functions, which
        :meth:`_check_mechanical` builds only when this cannot decide."""
        qdot = set(self.qdot)
        if any(e.free_symbols & qdot for e in self.mass_matrix):
            return False
        at_rest = {v: sp.Integer(0) for v in self.qdot}
        return all(derivative(self.lagrangian, v).xreplace(at_rest) == 0 for v in self.qdot)

    def _check_mechanical(self) -> None:
        L = self.lagrangian
        if L.free_symbols & set(self.qdot) and not self._quadratic_in_velocities():
            try:
                poly = sp.Poly(sp.expand(L), *self.qdot)
            except sp.PolynomialError as exc:
                raise SymbolicError(
                    f"{self.name}: the Lagrangian is not polynomial in the velocities ({exc}); expected kinetic "
                    "energy (quadratic in the velocities) minus a potential."
                ) from exc
            bad = [m for m in poly.monoms() if sum(m) > 2]
            lin = [m for m in poly.monoms() if sum(m) == 1]
            if bad or lin:
                what = "of degree > 2" if bad else "linear"
                terms = [poly.coeff_monomial(m) * sp.prod([v**e for v, e in zip(self.qdot, m)]) for m in (bad or lin)]
                raise SymbolicError(
                    f"{self.name}: expected the Lagrangian to be kinetic energy (quadratic in the "
                    f"velocities) minus a potential; it has terms {what} in the velocities: "
                    f"{', '.join(map(str, terms[:4]))}."
                )
            if any(not (poly.coeff_monomial(m).free_symbols.isdisjoint(self.qdot)) for m in poly.monoms()):
                raise SymbolicError(f"{self.name}: the Lagrangian is not polynomial in the velocities.")
        rng = np.random.default_rng(7)
        pt = self._random_point(rng, self.q)
        # the values given, where they are (products of inertia need not be positive); generic ones elsewhere
        pt.update({s: self.parameters[s.name] for s in self.parameter_symbols if s.name in self.parameters})
        pt = {k: sp.sympify(v) for k, v in pt.items()}  # symbols to numbers: xreplace, a tenth of the time of subs
        M = np.array(self.mass_matrix.xreplace(pt).evalf(), dtype=float)
        A = np.array(self.constraint_matrix.xreplace(pt).evalf(), dtype=float).reshape(self.c, self.n)
        _, sv, vt = np.linalg.svd(A) if self.c else (None, np.zeros(0), np.eye(self.n))
        X = vt[int(np.sum(sv > 1e-10 * max(1.0, sv.max(initial=0.0)))) :].T
        MD = X.T @ M @ X
        if X.size and (np.linalg.eigvalsh(MD).min() <= 1e-12 * max(1.0, np.abs(MD).max())):
            L = self.lagrangian
            absent = [c.name for v, c in zip(self.qdot, self.q) if not (L.has(v) or L.has(c))]
            hint = (
                f" The coordinates {absent} appear nowhere in the "
                "Lagrangian: is the shape/group split right (a group factor or shape variable L does not "
                "depend on)?"
                if absent
                else ""
            )
            raise SymbolicError(
                f"{self.name}: the kinetic energy is not positive definite on the constraint "
                "distribution D at a random configuration; every allowed motion must carry kinetic "
                "energy." + hint
            )
        if self.c:
            if np.linalg.matrix_rank(A, tol=1e-10 * max(1.0, np.abs(A).max())) < self.c:
                raise InputError(
                    f"{self.name}: the {self.c} constraint one-forms are linearly dependent at a random "
                    "configuration; remove the redundant ones."
                )
            Ag = np.array(self.body_constraints[0].xreplace(pt).evalf(), dtype=float)
            if np.linalg.matrix_rank(Ag, tol=1e-10 * max(1.0, np.abs(Ag).max())) < self.c:
                raise InputError(
                    f"{self.name}: the constraints restrict the shape velocities alone (their group "
                    "part has rank < number of constraints), so D_q + T_q(Orb) != T_q Q: BKMM's "
                    "dimension assumption fails. Treat such constraints as part of the shape space."
                )

    def check_invariance(self, *, samples: int = 3, seed: int = 11) -> InvarianceReport:
        r"""Check that :math:`L` and the distribution :math:`\mathcal D` are invariant under :math:`G`.

        The Lagrangian written in body velocities, :math:`L(g, r, \Lambda(g)^{-1}\xi, \dot r)`, must not depend
        on :math:`g`; the constraint rows in body velocities at :math:`g` must annihilate the distribution at
        the identity. Both are tested exactly at random points (the formulas are exact, so a mismatch beyond
        round-off is a real dependence); the report names the terms of :math:`L` that depend on :math:`g`
        (after trigonometric simplification) and the constraints that break invariance. The report is kept (the
        system is immutable; on disk with the derivations): building the system checks, ``derive`` shows the same
        report.
        """
        key = (int(samples), int(seed))
        if key not in self._invariance_reports:
            # on disk too (the checks compile the Lagrangian and constraints): by the symbolic content, the sampling
            # and the values the points take
            stored = ("invariance", *key, tuple(sorted(self.parameters.items())))
            report = DISK_CACHE.load(self.key, stored)
            if report is MISSING:
                report = invariance_report(self, samples=samples, seed=seed)
                DISK_CACHE.save(self.key, stored, report)
            self._invariance_reports[key] = report
        return self._invariance_reports[key]

    @cached_property
    def _invariance_reports(self) -> dict[tuple[int, int], InvarianceReport]:
        return {}

    def __repr__(self) -> str:
        return (
            f"NonholonomicSystem({self.name!r}, group={self.group!r}, shape={[s.name for s in self.shape]}, "
            f"constraints={self.c})"
        )

    def _repr_latex_(self) -> str:
        """Jupyter: the Lagrangian, the constraint one-forms and the parameter values."""
        from .._display import latex_block

        names = self.latex_names
        qd = sp.Matrix(self.qdot)
        lines = [("L", sp.latex(self.lagrangian, symbol_names=names))]
        for a in range(self.c):
            form = (sp.Matrix(self.constraint_matrix)[a, :] * qd)[0, 0]
            lines.append((rf"\omega^{{{a + 1}}}(\dot q)", sp.latex(form, symbol_names=names) + " = 0"))
        lines += [(sp.latex(sp.Symbol(k)), f"{v:g}") for k, v in self.parameters.items()]
        return latex_block(f"{self.name} on {self.group.name} x shapes {[s.name for s in self.shape]}", lines)


def _dynamic_map(q: Sequence[sp.Symbol], qd: Sequence[sp.Symbol]) -> dict:
    t = sp.Symbol("t")
    funcs = {sp.Function(s.name)(t): s for s in q}
    ders = {sp.Derivative(sp.Function(s.name)(t), t): v for s, v in zip(q, qd)}
    return {"functions": funcs, "derivatives": ders}


def _one_form(expr: sp.Expr, qd: Sequence[sp.Symbol], index: int) -> list[sp.Expr]:
    """Coefficients of a constraint given as an expression; it must be linear and homogeneous in ``qd``."""
    e = sp.expand(expr)
    if not (e.free_symbols & set(qd)):
        raise InputError(
            f"Constraint #{index} ({expr}) contains no velocity; a velocity constraint is a one-form "
            "omega(q) . qdot = 0 (a holonomic constraint f(q) = 0 is written as its differential df)."
        )
    try:
        poly = sp.Poly(e, *qd)
    except sp.PolynomialError as exc:
        raise InputError(
            f"Constraint #{index} ({expr}) is not linear in the velocities: it is not even polynomial "
            f"in {[str(v) for v in qd]}."
        ) from exc
    for mon in poly.monoms():
        deg = sum(mon)
        if deg != 1:
            kind = "has a velocity-free term (not homogeneous)" if deg == 0 else f"has a term of degree {deg}"
            raise InputError(
                f"Constraint #{index} ({expr}) is not linear homogeneous in the velocities: it {kind}. "
                "Only constraints omega(q) . qdot = 0 are supported."
            )
    return [poly.coeff_monomial(v) for v in qd]

"""The BKMM equations (1.1)-(1.3) of a Lagrangian system on G x S as one compiled right-hand side ``rhs(y, out,
prm)`` for the compiled Dormand-Prince loops, at the state ``y = (g, r_free, rdot_free, p, W, t)`` (the time
appended, its rate 1: the gait and the torques depend on it).

The function is straight-line code generated for the system's sizes: the reduction's data at the shapes (the
reduced mass matrix, the basis ``e(r)`` of ``S_q``, the body constraints, the gradient of V, and their first
derivatives: :func:`~geomech.reduction.reduced_numeric.reduction_data`), then the linear algebra of
:class:`~geomech.reduction.reduced_numeric.ReducedNumeric` on named intermediate values, entry by entry, the
structural zeros and the structure constants of the group folded in: the connection from :math:`L\\mathcal A =
R` by the adjugate of L, its derivatives, the locked inertia, the momentum equation, the reduced shape metric
and its derivatives, and the shape equations solved for the free shapes' accelerations and the forces that
realise the gait. No matrix is inverted symbolically in the shape variables and nothing is simplified: the cost
of generating is that of writing the formulas. Where L, the locked inertia or the shape equations are singular
(a 1-norm condition number above 1e13) the derivative is NaN and the loop reports the time. The model's
parameters are read from ``prm`` at run time (a sweep over them compiles once), and so are the gait's and the
torques' numbers, each formula written ``c + s f`` (offset, scale, and the numbers inside f): the gaits of one
form (``a sin(w t + phi)``, whatever a, w and phi) share one compilation.

The Lagrange-d'Alembert equations with multipliers (:func:`lda_module`) compile the same way, at the state ``y =
(q_free, qdot_free, W, t)``: the mass matrix, the forces, the constraints and their drift entry by entry, the free
accelerations and the multipliers solved numerically in the function (their matrix is as large as the free
coordinates and the constraints together; inverting it symbolically would cost more than the run).
"""

from __future__ import annotations

import dataclasses
import hashlib
import weakref
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from ..._storage import remember
from ...errors import SymbolicError
from ...reduction.lagrange_dalembert import lagrange_dalembert
from ...reduction.reduced_numeric import reduction_data
from ...symbolic.cache import DISK_CACHE, MISSING
from ...symbolic.compile import StraightLine, number_form
from ...symbolic.taylor import taylor_tape
from ...systems.gait import T_SYMBOL
from .. import _codegen
from .._observe import OBSERVE_ALL
from ..methods._embedded import COMPILED_SOLVERS, compiled_pair

__all__ = [
    "COMPILED_SOLVERS",
    "LagrangianSource",
    "bkmm_module",
    "bkmm_slots",
    "bkmm_source",
    "compiled_pair",
    "lda_module",
    "lda_slots",
    "lda_source",
]


#: Above this 1-norm condition number a matrix of the equations is singular (as in ReducedNumeric).
COND_MAX = 1e13


def _inverse(code: StraightLine, M: sp.Matrix, what: str) -> sp.Matrix:
    """The inverse of the matrix of values ``M`` by its adjugate, with the code that makes the derivative NaN where
    ``M`` is singular."""
    n = M.rows
    if n == 0:
        return sp.zeros(0, 0)
    det = code.value(M.det(method="berkowitz"))
    inv = code.matrix(M.adjugate() / det if n > 1 else sp.Matrix([[1 / det]]))
    if all(e.is_number for e in list(M) + list(inv)):
        # a constant matrix (the identity, where the constraints are those of the chart): nothing to check at
        # run time; singular, its adjugate over a zero determinant is not finite and was refused above
        return inv
    code.flush()

    def norm1(X: sp.Matrix) -> str:
        cols = [" + ".join(f"abs({code.code(X[i, j])})" for i in range(n)) for j in range(n)]
        return cols[0] if n == 1 else "max(" + ", ".join(cols) + ")"

    code.line(
        f"if not ({norm1(M)} * {norm1(inv)} <= {COND_MAX!r}):  # {what} singular\n"
        "    for _i in range(out.shape[0]):\n"
        "        out[_i] = np.nan\n"
        "    return"
    )
    return inv


_SOURCES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_TIME = sp.Symbol("_t")


@dataclass(frozen=True)
class LagrangianSource:
    """The generated module's source (the BKMM equations or the Lagrange-d'Alembert equations) and what each entry
    of its ``prm`` is: the system's parameters (by name), then the numbers of the gait's and the torques' formulas
    (values), then their named coefficients (by name)."""

    source: str
    parameters: tuple[str, ...]
    constants: np.ndarray
    coefficients: tuple[str, ...]
    #: the width of a row of :func:`._observe.observe`'s output: q, qdot, the shape forces, the energy, the constraints
    observed: int
    #: the number of coordinates q (the observation starts with q and qdot)
    n: int = 0
    #: the method whose equations these are, and what is singular where the derivative is NaN
    equations: str = "BKMM"
    singular: str = "the BKMM equations are singular (the locked inertia or the constraints)"
    #: with variational equations: the width of the state before Phi and S (its sensitivities' names in ``wrt``)
    core: int = 0
    wrt: tuple[str, ...] = ()

    def rows(self, values: Mapping[str, Any], B: int) -> np.ndarray:
        """The ``prm`` rows of a batch of ``B`` members (one row where no value is an array): each name's value,
        a scalar or an array of ``B`` (a batch's members, flattened)."""
        names = self.parameters + self.coefficients
        given = [values[n] for n in names]
        if all(type(v) is float for v in given):  # one run's numbers: one row as they are
            k = len(self.parameters)
            return np.array([given[:k] + list(self.constants) + given[k:]])
        arrays = [np.asarray(v, dtype=float).reshape(-1) for v in given]
        n_rows = B if any(a.size > 1 for a in arrays) else 1
        out = np.empty((n_rows, len(names) + len(self.constants)))
        k = len(self.parameters)
        for i, a in enumerate(arrays[:k]):
            out[:, i] = a
        out[:, k : k + len(self.constants)] = self.constants
        for i, a in enumerate(arrays[k:]):
            out[:, k + len(self.constants) + i] = a
        return out


def bkmm_source(
    setup: Any, reduction: Any, taylor: bool = False, wrt: tuple[str, ...] | None = None, work: bool = True
) -> LagrangianSource | None:
    """The compiled right-hand side of ``setup``'s BKMM equations (system, gait, torques) and its observation, and
    the layout of the values they read, or None where the gait or a torque is a Python callable. Generated once per
    system, basis and form of the gait and torques. With ``taylor``, the module also has the Taylor coefficients of
    the equations' solution (``taylor_coeffs``, its work array's rows ``TAYLOR_ROWS``) for Taylor's method; with
    ``wrt`` (names of the system's parameters and the gait's and torques' coefficients), its right-hand side is
    that of the state and its variational equations (the state transition matrix and the sensitivities to them);
    without ``work``, the work's derivative is zero (BKMM's ``work=False``)."""
    basis = sp.ImmutableMatrix(reduction.basis)
    own = [q.name for q in setup.system.parameter_symbols]
    coefficients = list(setup.coefficients)

    def generate(gait: tuple, torques: tuple, n_prm: int, extra: tuple) -> str:
        at = None
        if wrt is not None:  # prm: the system's parameters first, the coefficients last
            at = tuple(own.index(n) if n in own else n_prm - len(coefficients) + coefficients.index(n) for n in wrt)
        return _generate(setup, reduction, gait, torques, n_prm, taylor, at, work)

    kind: tuple = ("bkmm", basis)
    if taylor:
        kind += ("taylor",)
    if not work:
        kind += ("no work",)
    if wrt is not None:
        kind += (("wrt", *wrt),)
    made = _made(setup, kind, (), generate)
    if made is None or wrt is None:
        return made
    core = setup.system.k + 2 * len(setup.free_shapes) + reduction.m + 1
    return dataclasses.replace(made, core=core, wrt=tuple(wrt))


def lda_source(setup: Any, baumgarte: float) -> LagrangianSource | None:
    """The compiled right-hand side of ``setup``'s Lagrange-d'Alembert equations with multipliers (system, gait,
    torques, the Baumgarte rate ``baumgarte`` read at run time) and its observation, and the layout of the values
    they read, or None where the gait or a torque is a Python callable. Generated once per system and form of the
    gait and torques."""
    return _made(
        setup,
        ("lda",),
        (float(baumgarte),),
        lambda gait, torques, n_prm, extra: _generate_lda(setup, gait, torques, n_prm, extra[0]),
    )


_MADE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _made(setup: Any, kind: tuple, numbers: tuple[float, ...], generate: Any) -> LagrangianSource | None:
    """The source of one kind of equations (``kind``: a tag and what else decides the source) for ``setup``, its
    run-time ``numbers`` (appended to the gait's and torques' numbers, the symbols the generator reads), cached by
    system."""
    gait_forms, torques = setup.gait_forms, setup.torques
    if torques.expressions is None or (setup.prescribed and gait_forms is None):
        return None
    given = (
        kind,
        numbers,
        tuple(gait_forms or ()),
        tuple(torques.expressions),
        tuple(setup.free_shapes),
        tuple(setup.prescribed),
        setup.coefficients,
    )
    made = _MADE.setdefault(setup.system, {})
    if given in made:
        return made[given]
    return remember(made, given, _source(setup, kind, numbers, generate), 64)


def _source(setup: Any, kind: tuple, numbers: tuple[float, ...], generate: Any) -> LagrangianSource:
    gait_forms, torques, system = setup.gait_forms, setup.torques, setup.system
    own = {q.name: sp.Symbol(f"_p{i}") for i, q in enumerate(system.parameter_symbols)}
    first = len(own)

    def named(e: sp.Expr) -> sp.Expr:
        return e.xreplace(
            {
                q: own.get(q.name, sp.Symbol(f"_c_{q.name}"))
                for q in e.free_symbols
                if q.name in own or q.name in setup.coefficients
            }
        )

    table: dict[sp.Symbol, float] = {}
    gait_forms = tuple(number_form(named(e).xreplace({T_SYMBOL: _TIME}), table, first) for e in gait_forms or ())
    torque_forms = tuple(number_form(named(e), table, first) for e in torques.expressions)
    extra = []
    for x in numbers:
        extra.append(sp.Symbol(f"_p{first + len(table)}"))
        table[extra[-1]] = x
    slots = {
        sp.Symbol(f"_c_{name}"): sp.Symbol(f"_p{first + len(table) + j}") for j, name in enumerate(setup.coefficients)
    }
    gait_forms = tuple(e.xreplace(slots) for e in gait_forms)
    torque_forms = tuple(e.xreplace(slots) for e in torque_forms)
    n_prm = first + len(table) + len(slots)
    key = (kind, gait_forms, torque_forms, tuple(setup.free_shapes), tuple(setup.prescribed), n_prm, tuple(extra))
    known = _SOURCES.setdefault(system, {})
    if key not in known:
        # on disk too: a later process that runs the same equations loads the text numba's cache knows (generating
        # it walks the derived equations and their Taylor pass: a third of a second for the snakeboard)
        stored = ("generated source", _generator_fingerprint(), key)
        text = DISK_CACHE.load(system.key, stored)
        if text is MISSING:
            text = generate(gait_forms, torque_forms, n_prm, tuple(extra))
            DISK_CACHE.save(system.key, stored, text)
        known[key] = text
    return LagrangianSource(
        known[key],
        tuple(own),
        np.array(list(table.values()), dtype=float),
        setup.coefficients,
        2 * system.n + system.sigma + 1 + system.c,
        system.n,
        *_NAMES[kind[0]],
    )


@lru_cache(maxsize=1)
def _generator_fingerprint() -> str:
    """A digest of the modules that print the generated source (with the derivations the disk cache's own key
    covers): an edited printer never reads a source the code before it made."""
    root = Path(__file__).resolve().parent.parent.parent
    h = hashlib.sha256()
    for rel in _GENERATORS:
        h.update((root / rel).read_bytes())
    return h.hexdigest()


#: The modules whose code decides a generated source, beside the derivations (``symbolic.cache._SOURCES``).
_GENERATORS = (
    "integrators/nonholonomic/_compiled.py",
    "integrators/nonholonomic/_compiled_discrete.py",
    "integrators/_codegen.py",
    "integrators/_observe.py",
    "reduction/reduced_numeric.py",
    "symbolic/compile.py",
    "symbolic/taylor.py",
    "systems/gait.py",
)


_NAMES = {
    "bkmm": ("BKMM", "the BKMM equations are singular (the locked inertia or the constraints)"),
    "lda": (
        "LagrangeDAlembert",
        "the Lagrange-d'Alembert equations are singular (the matrix of the accelerations and multipliers)",
    ),
    "dlda": (
        "DiscreteLagrangeDAlembert",
        "the discrete Lagrange-d'Alembert equations are singular (Newton's matrix)",
    ),
}


def _generate(
    setup: Any,
    reduction: Any,
    gait_forms: tuple,
    torque_forms: tuple,
    n_prm: int,
    taylor: bool = False,
    wrt: tuple[int, ...] | None = None,
    work: bool = True,
) -> str:
    """The module of the BKMM equations (``rhs``, ``observe``), of the state ``(g, r_F, rdot_F, p, W, t)``; with
    ``wrt`` (indices into ``prm``), of the state and its variational equations ``(y, Phi, S, t)`` (:func:`_forward`),
    the time last as always; with ``taylor``, Taylor's coefficients too (:func:`_taylor_closed`); without ``work``,
    W' = 0."""
    system = setup.system
    k, s, m, c = system.k, system.sigma, reduction.m, system.c
    F, P = list(setup.free_shapes), list(setup.prescribed)
    nF = len(F)
    d = k + 2 * nF + m + 1
    t_index = d if wrt is None else d * (1 + d + len(wrt))
    code = StraightLine()
    # the state, the parameters (the system's, then the gait's and torques' numbers), and the time
    t = _TIME
    g = [sp.Symbol(f"_g{a}") for a in range(k)]
    p = sp.Matrix(m, 1, [sp.Symbol(f"_m{i}") for i in range(m)])
    r: list[Any] = [None] * s
    rd: list[Any] = [None] * s
    reads = [f"_t = y[{t_index}]"] + [f"_g{a} = y[{a}]" for a in range(k)]
    for jj, j in enumerate(F):
        r[j], rd[j] = sp.Symbol(f"_r{j}"), sp.Symbol(f"_rd{j}")
        reads += [f"_r{j} = y[{k + jj}]", f"_rd{j} = y[{k + nF + jj}]"]
    reads += [f"_m{i} = y[{k + 2 * nF + i}]" for i in range(m)]
    params = {q: sp.Symbol(f"_p{i}") for i, q in enumerate(system.parameter_symbols)}
    reads += [f"_p{i} = prm[{i}]" for i in range(n_prm)]
    code.line("\n".join(reads))
    # the gait: prescribed shapes, velocities, accelerations
    rdd_p = []
    for jj, j in enumerate(P):
        e = gait_forms[jj]
        r[j], rd[j] = code.value(e), code.value(e.diff(t))
        rdd_p.append(code.value(e.diff(t, 2)))
    shapes = dict(zip(reduction.r, r))
    # the reduction's data at the shapes
    data = {
        name: code.matrix(sp.Matrix(X).xreplace(params).xreplace(shapes))
        for name, X in reduction_data(reduction).items()
    }
    n = k + s
    Mf, dMf = data["M"], data["dM"]
    Il, G, mrr = Mf[:k, :k], Mf[:k, k:], Mf[k:, k:]
    dIl = [dMf[al * n : al * n + k, :k] for al in range(s)]
    dG = [dMf[al * n : al * n + k, k:] for al in range(s)]
    dmrr = [dMf[al * n + k : (al + 1) * n, k:] for al in range(s)]
    E = data["E"]
    dE = [data["dE"][al * k : (al + 1) * k, :] for al in range(s)]
    Axi, Ar = data["Axi"], data["Ar"]
    dAxi = [data["dAxi"][al * c : (al + 1) * c, :] for al in range(s)]
    dAr = [data["dAr"][al * c : (al + 1) * c, :] for al in range(s)]
    dV = data["dV"]
    rdv = sp.Matrix(s, 1, rd)
    # the connection: L A = R, L = (A_xi; e^T I_loc), R = (A_r; e^T Gamma); d_al A = L^-1 (d_al R - d_al L A)
    L = code.matrix(sp.Matrix.vstack(Axi, E.T * Il))
    R = code.matrix(sp.Matrix.vstack(Ar, E.T * G))
    Linv = _inverse(code, L, "the connection's L")
    A = code.matrix(Linv * R)
    dA = []
    for al in range(s):
        dL = sp.Matrix.vstack(dAxi[al], dE[al].T * Il + E.T * dIl[al])
        dR = sp.Matrix.vstack(dAr[al], dE[al].T * G + E.T * dG[al])
        dA.append(code.matrix(Linv * code.matrix(dR - dL * A)))
    # Omega = I^-1 p, I = e^T I_loc e; xi = -A rd + e Omega (1.1); mu = I_loc xi + Gamma rd
    Om = code.matrix(_inverse(code, code.matrix(E.T * Il * E), "the locked inertia") * p) if m else sp.zeros(0, 1)
    xi = code.matrix(-A * rdv + E * Om)
    mu = code.matrix(Il * xi + G * rdv)
    C = system.group.structure_constants
    # (1.2): pdot_i = <mu, [xi, e_i] + d_be e_i rd^be>
    pdot = [
        code.value(
            sum(C[a][b][d] * mu[a] * xi[b] * E[d, i] for a in range(k) for b in range(k) for d in range(k))
            + sum(mu[a] * dE[be][a, i] * rd[be] for a in range(k) for be in range(s))
        )
        for i in range(m)
    ]
    # the group coordinates' rates and the torques at (t, q, qdot)
    rates = sp.Matrix(system.group.body_velocity_inverse).xreplace(dict(zip(system.group.coordinates, g)))
    gdot = code.matrix(code.matrix(rates.xreplace(params)) * xi)
    at = {T_SYMBOL: t, **dict(zip(system.q, list(g) + r)), **dict(zip(system.qdot, list(gdot) + rd))}
    tau_f = [code.value(e.xreplace(at).xreplace(params)) for e in torque_forms]
    # (1.3): M rdd = delta + tau, solved for the free accelerations and the forces that keep the gait
    z: list[Any] = []
    if s:
        At, Gt = A.T, G.T
        Ms = code.matrix(mrr - Gt * A - At * G + At * Il * A)
        dM = [
            code.matrix(
                dmrr[be]
                - dG[be].T * A
                - Gt * dA[be]
                - dA[be].T * G
                - At * dG[be]
                + dA[be].T * Il * A
                + At * dIl[be] * A
                + At * Il * dA[be]
            )
            for be in range(s)
        ]
        delta = []
        for al in range(s):
            chris = sum((dM[be][al, ga] - dM[al][be, ga] / 2) * rd[be] * rd[ga] for be in range(s) for ga in range(s))
            curv = sum(
                mu[a]
                * (
                    dA[al][a, be]
                    - dA[be][a, al]
                    - sum(C[a][b][d] * A[b, al] * A[d, be] for b in range(k) for d in range(k))
                )
                * rd[be]
                for a in range(k)
                for be in range(s)
            )
            inertia = (Om.T * (dE[al].T * Il * E + E.T * dIl[al] * E + E.T * Il * dE[al]) * Om)[0, 0] / 2 if m else 0
            coupling = sum(
                mu[a]
                * (dE[al][a, j] + sum(C[a][b][d] * E[b, j] * A[d, al] for b in range(k) for d in range(k)))
                * Om[j]
                for a in range(k)
                for j in range(m)
            )
            delta.append(code.value(-chris - dV[al] + curv + inertia - coupling))
        z, tau_v = _shape_solve(code, Ms, delta, tau_f, rdd_p, F, P)
    else:
        tau_v = []
    # what a saved state shows (observe): q, qdot, the shape forces, the energy and the constraints A(q) qdot
    seen = code.copy()
    qdot = sp.Matrix(list(gdot) + rd)
    energy = sp.sympify(system.energy).xreplace(at).xreplace(params)
    residual = (sp.Matrix(system.constraint_matrix).xreplace(at).xreplace(params) * qdot) if c else sp.zeros(0, 1)
    observed = seen.values(list(g) + r + list(qdot) + tau_v + [energy] + list(residual))
    seen.line("\n".join(f"out[{i}] = {seen.code(v)}" for i, v in enumerate(observed)))
    outputs = (
        list(gdot)
        + [rd[j] for j in F]
        + z[:nF]
        + pdot
        + [code.value(sum(tau_v[j] * rd[j] for j in range(s))) if work else sp.Integer(0)]
        + [sp.Integer(1)]
    )
    values = code.values(outputs)
    if wrt is not None:  # the state's derivative, then Phi's and S's, then the time's
        state = list(g) + [r[j] for j in F] + [rd[j] for j in F] + list(p) + [None]
        values = values[:-1] + _forward(code, state, wrt, values[:-1]) + values[-1:]
    code.line("\n".join(f"out[{i}] = {code.code(v)}" for i, v in enumerate(values)))
    series = _taylor_closed(setup, reduction, gait_forms, torque_forms, n_prm, work) if taylor else ""
    return _module_text(code.body(), seen.body()) + series


def _forward(code: StraightLine, state: list, wrt: tuple[int, ...], f: list) -> list:
    """The variational equations of ``y' = f(y, prm)`` by forward differentiation of the straight-line code so far:
    the derivatives of Phi = dy/dy0 (row-major, d x d) and S = dy/dprm[wrt] (d x len(wrt)), read from ``y`` after
    the state (``state[i]`` the symbol of y_i, None where f does not read it). Each assignment ``v = e(a, b, ...)``
    carries its tangents ``dv = sum_a de/da da`` in every direction (the d initial values, then the parameters),
    structural zeros dropped: Phi' = f_y Phi, S' = f_y S + f_p."""
    d, nw = len(state), len(wrt)
    nd = d + nw
    tangents: dict[sp.Symbol, list[Any]] = {}
    reads = []
    for i, sym in enumerate(state):
        if sym is None:
            continue
        row = []
        for j in range(nd):
            name = sp.Symbol(f"_dy{i}_{j}")
            at = d + i * d + j if j < d else d + d * d + i * nw + (j - d)
            reads.append(f"{name} = y[{at}]")
            row.append(name)
        tangents[sym] = row
    for l, index in enumerate(wrt):
        seed: list[Any] = [None] * nd
        seed[d + l] = sp.Integer(1)
        tangents[sp.Symbol(f"_p{index}")] = seed
    if reads:
        code.line("\n".join(reads))
    for v, e in list(code.assignments):
        dep = [a for a in e.free_symbols if a in tangents]
        if not dep:
            continue
        partial = {a: e.diff(a) for a in dep}
        row = []
        for j in range(nd):
            terms = [partial[a] * tangents[a][j] for a in dep if tangents[a][j] is not None]
            row.append(code.value(sp.Add(*terms)) if terms else None)
        if any(x is not None for x in row):
            tangents[v] = row
    zero: list[Any] = [None] * nd
    of_f = [tangents.get(e, zero) if isinstance(e, sp.Symbol) else zero for e in f[:d]]
    # Phi's rows, then S's (each row-major)
    columns = [range(d), range(d, nd)]
    return [sp.Integer(0) if t[j] is None else t[j] for cols in columns for t in of_f for j in cols]


def _shape_solve(
    code: StraightLine, Ms: sp.Matrix, delta: list, tau_f: list, rdd_p: list, F: list, P: list
) -> tuple[list, list]:
    """Eq. (1.3), ``Ms rdd = delta + tau``, solved for the free shapes' accelerations and the forces that keep the
    prescribed shapes on their gait: returns (the unknowns: accelerations, then forces; every shape's force)."""
    s, nF = Ms.rows, len(F)
    K = sp.zeros(s, s)
    for jj, j in enumerate(F):
        K[:, jj] = Ms[:, j]
    for jj, j in enumerate(P):
        K[j, nF + jj] = -1
    rhs_b = sp.Matrix(delta)
    for jj, j in enumerate(F):
        rhs_b[j] += tau_f[jj]
    for jj, j in enumerate(P):
        rhs_b -= Ms[:, j] * rdd_p[jj]
    z = list(code.matrix(_inverse(code, code.matrix(K), "the shape equations' matrix") * rhs_b))
    tau_v: list[Any] = [0] * s
    for jj, j in enumerate(F):
        tau_v[j] = tau_f[jj]
    for jj, j in enumerate(P):
        tau_v[j] = z[nF + jj]
    return z, tau_v


def _taylor_closed(
    setup: Any, reduction: Any, gait_forms: tuple, torque_forms: tuple, n_prm: int, work: bool = True
) -> str:
    """The Taylor coefficients of the BKMM equations' solution (``taylor_coeffs``, and ``TAYLOR_ROWS`` the rows of its
    work array), from the reduction's closed forms: the reconstruction (1.1) and the momentum equation (1.2), and
    for the shapes the shape mass and forces of (1.3), as sympy simplified them. The same equations as
    :func:`_generate`'s (the tests meet the two), in far fewer operations for the recurrences than its numeric
    linear algebra on the reduction's matrices: the snakeboard's are 43 series, 15 products, against 193 and 102."""
    system = setup.system
    k, s, m = system.k, system.sigma, reduction.m
    F, P = list(setup.free_shapes), list(setup.prescribed)
    code = StraightLine()
    t = _TIME
    g = [sp.Symbol(f"_g{a}") for a in range(k)]
    pm = [sp.Symbol(f"_m{i}") for i in range(m)]
    r: list[Any] = [None] * s
    rd: list[Any] = [None] * s
    for j in F:
        r[j], rd[j] = sp.Symbol(f"_r{j}"), sp.Symbol(f"_rd{j}")
    params = {q: sp.Symbol(f"_p{i}") for i, q in enumerate(system.parameter_symbols)}
    rdd_p = []
    for jj, j in enumerate(P):
        e = gait_forms[jj]
        r[j], rd[j] = code.value(e), code.value(e.diff(t))
        rdd_p.append(code.value(e.diff(t, 2)))
    at_shape = {
        **params,
        **dict(zip(reduction.r, r)),
        **dict(zip(reduction.rdot, rd)),
        **dict(zip(reduction.p, pm)),
    }

    def closed(X: Any) -> sp.Matrix:
        return code.matrix(sp.Matrix(X).xreplace(at_shape))

    xi = closed(reduction.reconstruction)
    rates = sp.Matrix(system.group.body_velocity_inverse).xreplace(dict(zip(system.group.coordinates, g)))
    gdot = code.matrix(code.matrix(rates.xreplace(params)) * xi)
    pdot = list(closed(reduction.momentum_rhs)) if m else []
    at = {T_SYMBOL: t, **dict(zip(system.q, list(g) + r)), **dict(zip(system.qdot, list(gdot) + rd))}
    tau_f = [code.value(e.xreplace(at).xreplace(params)) for e in torque_forms]
    z: list[Any] = []
    tau_v: list[Any] = []
    if s and (F or work):  # the shape forces: for the free shapes' motion, and the work
        z, tau_v = _shape_solve(
            code, closed(reduction.shape_mass), list(closed(reduction.shape_forces)), tau_f, rdd_p, F, P
        )
    derivatives = (
        list(gdot)
        + [rd[j] for j in F]
        + z[: len(F)]
        + pdot
        + [code.value(sum(tau_v[j] * rd[j] for j in range(s))) if work else sp.Integer(0)]
        + [sp.Integer(1)]
    )
    values = code.values(derivatives)
    code.flush()
    state = g + [r[j] for j in F] + [rd[j] for j in F] + pm + [None, t]
    parameters = [sp.Symbol(f"_p{i}") for i in range(n_prm)]
    return taylor_tape(code.assignments, state, values, parameters).module_source()


def _module_text(body: str, seen: str) -> str:
    """The generated module of a right-hand side's ``body`` and its observation ``seen``."""
    # the C twin the compiled loops call (geomech.integrators._fptr) is this body on the pointers, compiled once;
    # rhs, the same body on arrays, compiles only if a loop calls it by name
    c_twin = (
        "def _rhs_c(y_, out_, prm_, d, n_prm):\n"
        "    y = numba.carray(y_, (d,))\n"
        "    out = numba.carray(out_, (d,))\n"
        "    prm = numba.carray(prm_, (n_prm,))\n"
    )
    return (
        "@kernel\ndef rhs(y, out, prm):\n"
        + body
        + "\n\n"
        + c_twin
        + body
        + "\n\n@kernel\ndef observe(y, out, prm):\n"
        + seen
        + OBSERVE_ALL
    )


#: Below this ratio of a pivot to the largest entry, the matrix of the accelerations and multipliers is singular.
RCOND_MIN = 1e-13


def _generate_lda(setup: Any, gait_forms: tuple, torque_forms: tuple, n_prm: int, baumgarte: sp.Symbol) -> str:
    """The Lagrange-d'Alembert equations with multipliers, index-reduced, at the state ``y = (q_free, qdot_free, W,
    t)`` (the coordinates not prescribed by the gait, their rates, the work of the shape forces, the time):
    :math:`\\mathbb M\\ddot q - A^T\\lambda = f + B\\tau`, :math:`A\\ddot q = -\\dot A\\dot q - 2\\beta A\\dot q`,
    the prescribed shapes' accelerations given by the gait. The mass matrix, the forces, the constraints and their
    drift are written entry by entry; the free accelerations and the multipliers are solved numerically
    (elimination with partial pivoting, ``solve_checked``: NaN where the matrix is singular), the forces that keep
    the gait follow from the prescribed shapes' rows."""
    system = setup.system
    lda = lagrange_dalembert(system)
    n, k, c, sigma = system.n, system.k, system.c, system.sigma
    pr = [k + j for j in setup.prescribed]
    fr = [i for i in range(n) if i not in pr]
    nf = len(fr)
    code = StraightLine()
    t = _TIME
    q: list[Any] = [None] * n
    qd: list[Any] = [None] * n
    reads = [f"_t = y[{2 * nf + 1}]"]
    for ii, i in enumerate(fr):
        q[i], qd[i] = sp.Symbol(f"_q{i}"), sp.Symbol(f"_qd{i}")
        reads += [f"_q{i} = y[{ii}]", f"_qd{i} = y[{nf + ii}]"]
    reads += [f"_p{i} = prm[{i}]" for i in range(n_prm)]
    code.line("\n".join(reads))
    rdd: dict[int, Any] = {}
    for jj, i in enumerate(pr):
        e = gait_forms[jj]
        q[i], qd[i] = code.value(e), code.value(e.diff(t))
        rdd[i] = code.value(e.diff(t, 2))
    params = {p: sp.Symbol(f"_p{i}") for i, p in enumerate(system.parameter_symbols)}
    at = {T_SYMBOL: t, **dict(zip(system.q, q)), **dict(zip(system.qdot, qd))}

    def values(X: Any) -> sp.Matrix:
        return code.matrix(sp.Matrix(X).xreplace(at).xreplace(params))

    M, f = values(lda.mass_matrix), values(lda.forces)
    A, drift = (values(lda.constraint_matrix), values(lda.constraint_drift)) if c else (sp.zeros(0, n), sp.zeros(0, 1))
    tau_f = [code.value(e.xreplace(at).xreplace(params)) for e in torque_forms]
    F = list(f)
    for jj, j in enumerate(setup.free_shapes):
        F[k + j] += tau_f[jj]
    # the free accelerations and the multipliers: [[M_ff, -A_f^T], [A_f, 0]] z = b
    N = nf + c
    K = sp.zeros(N, N)
    b: list[Any] = []
    for ii, i in enumerate(fr):
        for jj, j in enumerate(fr):
            K[ii, jj] = M[i, j]
        for a in range(c):
            K[ii, nf + a] = -A[a, i]
        b.append(F[i] - sum(M[i, j] * rdd[j] for j in pr))
    for a in range(c):
        for jj, j in enumerate(fr):
            K[nf + a, jj] = A[a, j]
        stab = 2 * baumgarte * sum(A[a, j] * qd[j] for j in range(n))
        b.append(-drift[a] - sum(A[a, j] * rdd[j] for j in pr) - stab)
    K, b = code.matrix(K), code.values(b)
    z: list[Any] = []
    if N:
        fill = [f"_K[{i}, {j}] = {code.code(K[i, j])}" for i in range(N) for j in range(N) if K[i, j] != 0]
        code.line(
            f"_K = np.zeros(({N}, {N}))\n_b = np.empty({N})\n"
            + "\n".join(fill + [f"_b[{i}] = {code.code(b[i])}" for i in range(N)])
            + f"\nif not solve_checked(_K, _b, {N}, {RCOND_MIN!r}):  # the accelerations' matrix singular\n"
            "    for _i in range(out.shape[0]):\n"
            "        out[_i] = np.nan\n"
            "    return\n" + "\n".join(f"_z{i} = _b[{i}]" for i in range(N))
        )
        z = [sp.Symbol(f"_z{i}") for i in range(N)]
    qdd: list[Any] = [None] * n
    for ii, i in enumerate(fr):
        qdd[i] = z[ii]
    for i in pr:
        qdd[i] = rdd[i]
    lam = z[nf:]
    tau_v: list[Any] = [0] * sigma
    for jj, j in enumerate(setup.free_shapes):
        tau_v[j] = tau_f[jj]
    for i in pr:  # the prescribed rows: tau = (M qdd)_i - f_i - (A^T lambda)_i
        tau_v[i - k] = code.value(
            sum(M[i, j] * qdd[j] for j in range(n)) - f[i] - sum(A[a, i] * lam[a] for a in range(c))
        )
    seen = code.copy()
    energy = sp.sympify(system.energy).xreplace(at).xreplace(params)
    residual = [sum(A[a, j] * qd[j] for j in range(n)) for a in range(c)]
    observed = seen.values(q + qd + tau_v + [energy] + residual)
    seen.line("\n".join(f"out[{i}] = {seen.code(v)}" for i, v in enumerate(observed)))
    outputs = [qd[i] for i in fr] + [qdd[i] for i in fr] + [sum(tau_v[j] * qd[k + j] for j in range(sigma)), 1]
    out = code.values(outputs)
    code.line("\n".join(f"out[{i}] = {code.code(v)}" for i, v in enumerate(out)))
    return _module_text(code.body(), seen.body())


def bkmm_slots(setup: Any, m: int) -> list[str | None]:
    """The names of the BKMM state's entries ``(g, r_F, rdot_F, p, W, t)`` (None for the work)."""
    s, F = setup.system, setup.free_shapes
    return (
        [q.name for q in s.q[: s.k]]
        + [s.q[s.k + i].name for i in F]
        + [s.qdot[s.k + i].name for i in F]
        + [f"p{i}" for i in range(m)]
        + [None, "t"]
    )


def lda_slots(setup: Any) -> list[str | None]:
    """The names of the Lagrange-d'Alembert state's entries ``(q_F, qdot_F, W, t)`` (None for the work)."""
    s, fr = setup.system, setup.free_coordinates()
    return [s.q[i].name for i in fr] + [s.qdot[i].name for i in fr] + [None, "t"]


def bkmm_module(
    setup: Any, reduction: Any, taylor: bool = False, wrt: tuple[str, ...] | None = None, work: bool = True
) -> tuple[Any, LagrangianSource] | None:
    """The compiled module of ``setup``'s BKMM equations (with ``wrt``, and their variational equations; see
    :func:`bkmm_source`) and the layout of the values ``prm`` it reads (the system's parameters, the gait's and the
    torques' numbers, their coefficients), or None where they cannot be compiled (numba missing, a callable gait or
    torque, a function numba lacks; with ``taylor``, a function with no Taylor recurrence)."""
    return _module(lambda: bkmm_source(setup, reduction, taylor, wrt, work), "bkv" if wrt is not None else "bk")


def lda_module(setup: Any, baumgarte: float) -> tuple[Any, LagrangianSource] | None:
    """The compiled module of ``setup``'s Lagrange-d'Alembert equations with multipliers (Baumgarte rate
    ``baumgarte``) and the layout of the values ``prm`` it reads, or None where they cannot be compiled (numba
    missing, a callable gait or torque, a function numba lacks)."""
    return _module(lambda: lda_source(setup, baumgarte), "ld")


def _module(source: Any, tag: str) -> tuple[Any, LagrangianSource] | None:
    if not _codegen.numba_available():
        return None
    try:
        made = source()
    except (NotImplementedError, SymbolicError):
        # a function numba lacks, or a matrix singular for every shape: the Python equations say where and why
        return None
    if made is None:
        return None
    return _codegen.compiled_module(made.source, tag), made

"""Taylor's method: the Taylor coefficients generated from straight-line code (symbolic/taylor.py) against the
repeated Lie derivatives of the same right-hand side by sympy (a second route to every coefficient), and the
compiled Taylor loop of the BKMM equations against the compiled DOP853 on the same equations at a tighter
tolerance, its convergence in the tolerance, and the energy of a coasting Chaplygin sleigh."""

import ctypes
import math

import numpy as np
import pytest
import sympy as sp
from scipy.special import ellipk

import geomech as gm
from geomech import solve
from geomech.errors import InputError
from geomech.integrators import BKMM, Event, Status, Taylor, _codegen, _runners, _taylor_llvm
from geomech.integrators._codegen import python_header, python_helpers
from geomech.integrators._taylor_llvm import unrolled_address
from geomech.integrators.methods import taylor_order
from geomech.symbolic.compile import StraightLine
from geomech.symbolic.taylor import taylor_tape
from geomech.systems.nonholonomic_examples import chaplygin_sleigh, roller_racer, simplified_bicycle, snakeboard

x, y, t, a = sp.symbols("x y t a", real=True)

# right-hand sides that use every function and power the Taylor code knows, with a parameter a (read from prm)
FIELDS = {
    "trigonometric": (
        sp.sin(x) * y + sp.exp(-t) / (1 + y**2) - sp.tan(x / 3),
        sp.sqrt(2 + x**2) * sp.cos(t) - sp.atan(x) + a * sp.tanh(y) + (1 + x**2) ** sp.Rational(-3, 2),
    ),
    "inverse and hyperbolic": (
        sp.asin(x / 3) * sp.cosh(y) - sp.acos(y / 4) + sp.asinh(x * y) + sp.acosh(1 + y**2) - sp.atanh(x / 2),
        sp.log(2 + x**2) * sp.sinh(y) + y**3 / (2 + sp.cos(x)) + x**5 + sp.coth(y) - sp.acot(x),
    ),
    "reciprocal trigonometric": (sp.cot(x) * sp.sec(y), sp.csc(x + t) - y),
    "powers": (
        (2 + x**2) ** a - y ** sp.Rational(5, 2) + 3 ** (x * t),
        x ** (-2) * y + sp.exp(a * x) / y**3 + (x + y) ** sp.Rational(1, 3),
    ),
    # products of three and four rows sharing their common parts, a reciprocal and its square, constant factors
    "shared products": (
        a * x * y * sp.sin(x) * sp.cos(x) - 2 * x * y * sp.sin(x) + 3 * a * sp.sin(t) / (1 + x**2),
        (1 + x**2) ** -2 + a * x * y * sp.sin(x) * sp.exp(-y) - 1 / (1 + x**2),
    ),
}
POINT = {x: 0.7, y: 1.3, t: 0.4, a: 0.8}


def _tape(fields):
    code = StraightLine()
    values = code.values(fields)
    code.flush()
    return taylor_tape(code.assignments, [x, y, t], [*values, 1], [a])


def _coefficients(fields, order, form="loop"):
    """The generated Taylor coefficients of (x, y, t)' = (f, g, 1) at POINT: the loop over the orders run as
    Python, or the code unrolled for ``order`` compiled by LLVM and called through its address."""
    tape = _tape(fields)
    namespace = dict(python_helpers())
    source = tape.source("coeffs") + "\n\n" + tape.constants_source("constants")
    exec(compile(python_header() + source, "<taylor>", "exec"), namespace)
    X = np.zeros((3, order + 1))
    X[:, 0] = [POINT[x], POINT[y], POINT[t]]
    prm = np.array([POINT[a]])
    if form == "loop":
        namespace["coeffs"](X, np.zeros((max(tape.n_rows, 1), order + 1)), order, prm)
    else:
        K = np.zeros(max(len(tape.constants), 1))
        namespace["constants"](K, prm)
        _call_unrolled(unrolled_address(tape, order), X, K, prm)
    return X


def _call_unrolled(address, X, K, prm):
    double_p = ctypes.POINTER(ctypes.c_double)
    f = ctypes.CFUNCTYPE(None, double_p, double_p, double_p, ctypes.c_int64, ctypes.c_int64)(address)
    f(X.ctypes.data_as(double_p), K.ctypes.data_as(double_p), prm.ctypes.data_as(double_p), X.shape[0], prm.size)


@pytest.mark.parametrize("form", ["loop", "unrolled"])
@pytest.mark.parametrize("name", FIELDS)
def test_generated_coefficients_are_the_lie_derivatives(name, form):
    f, g = FIELDS[name]
    order = 5
    X = _coefficients((f, g), order, form)
    # x^[k] = (L^(k-1) f)(point) / k!, L the derivative along the field
    for i, h in enumerate((f, g)):
        for k in range(1, order + 1):
            exact = float(h.subs(POINT).evalf(30)) / math.factorial(k)
            assert abs(X[i, k] - exact) <= 1e-12 * max(1.0, abs(exact)), (name, i, k)
            h = sp.diff(h, x) * f + sp.diff(h, y) * g + sp.diff(h, t)
    np.testing.assert_array_equal(X[2, 1:], [1.0] + [0.0] * (order - 1))


def test_the_unrolled_code_agrees_with_the_loop_at_high_order_and_loads_from_disk(monkeypatch):
    """Order 24 (sums of 25 terms, the structural zeros of t's series dropped): the two forms agree to round-off
    of the coefficients' scale; the machine code, written to the cache, is loaded again without LLVM."""
    fields = FIELDS["trigonometric"]
    order = 24
    loop = _coefficients(fields, order)
    unrolled = _coefficients(fields, order, "unrolled")
    scale = np.abs(loop).max(axis=1, keepdims=True)
    np.testing.assert_allclose(unrolled, loop, rtol=0, atol=1e-12 * scale.max())
    assert list(_codegen.cache_dir().glob("gm_taylor_*.o"))

    def no_llvm(*args):
        raise AssertionError("compiled again instead of loaded from the cache")

    monkeypatch.setattr(_taylor_llvm, "_compile", no_llvm)
    monkeypatch.setattr(_taylor_llvm, "_ADDRESSES", {})
    np.testing.assert_array_equal(_coefficients(fields, order, "unrolled"), unrolled)


def test_products_share_their_common_factors_and_constant_factors_fold_into_sums():
    """Each product of rows made once whatever its factors' order and grouping (x y sin x inside x y sin x cos x),
    1/b^2 the square of 1/b, and parameters multiplying a row folded into the sums that read it rather than
    written to rows of their own: the tape's operations counted, its coefficients checked as Lie derivatives
    above."""
    z, u = sp.symbols("z u", real=True)
    b = 1 + x**2
    fields = [x * y * sp.sin(x), x * y * sp.sin(x) * sp.cos(x), 1 / b, b**-2 + a * x * y * sp.sin(x) + 2 * a * y]
    tape = taylor_tape([], [x, y, z, u], fields, [a])
    kinds = [op[0] for op in tape.ops]
    # sin x, cos x; x y, (x y) sin x, ((x y) sin x) cos x, x^2, (1/b)^2; 1/b; -sin x, 1 + x^2, the last sum
    assert (kinds.count("int"), kinds.count("mul"), kinds.count("quot"), kinds.count("lin")) == (2, 5, 1, 3)
    # the last derivative, one sum of 1/b^2, y (its coefficient 2 a) and x y sin x (its coefficient a)
    assert tape.ops[-1][0] == "lin" and tape.outputs[-1] == tape.ops[-1][1]
    assert {r for _, r in tape.ops[-1][2]} == {tape.ops[-2][1], "_x1", tape.outputs[0]}
    assert dict(tape.constants)[dict((r, c) for c, r in tape.ops[-1][2])["_x1"]] == "2*_p0"


def test_tan_is_one_function_whose_derivative_its_square_gives():
    """tan by its own recurrence (w' = (1 + w^2) a'): one function and one product, 1 + tan^2 the derivative's row
    itself, where sin / cos took two functions and a quotient (its coefficients are checked as Lie derivatives
    above, FIELDS["trigonometric"])."""
    tape = taylor_tape([], [x, y], [sp.tan(x / 3), 1 + sp.tan(x / 3) ** 2], [])
    kinds = [op[0] for op in tape.ops]
    assert (kinds.count("int"), kinds.count("mul"), kinds.count("quot")) == (1, 1, 0)
    (tan,) = [op for op in tape.ops if op[0] == "int"]
    assert tan[2] == "tan" and tape.outputs[1] == tan[4]


def test_a_function_without_a_recurrence_is_refused_by_name():
    code = StraightLine()
    values = code.values([sp.Abs(x), y])
    code.flush()
    with pytest.raises(NotImplementedError, match="Abs"):
        taylor_tape(code.assignments, [x, y], values, [])


def test_the_order_follows_the_tolerance():
    assert taylor_order((1e-10, 1e-12)) == 15  # ceil(-ln(1e-12) / 2) + 1
    assert taylor_order((1e-16, 1e-16)) == 20
    assert taylor_order((1e-2, 1e-2)) == 4  # the least
    assert taylor_order((1e-300, 1e-300)) == 40  # the most


SNAKE = dict(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
GAIT = {"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}
RACER = dict(m1=1.0, m2=0.8, I1=0.3, I2=0.2, d1=0.5, d2=0.6)


@pytest.mark.parametrize(
    "build, kw",
    [
        (lambda: snakeboard(**SNAKE), dict(shapes=GAIT)),
        # a free shape under a torque of the state
        (lambda: roller_racer(**RACER), dict(tau={"phi": "0.3*sin(3*t) - 0.05*phi_dot"}, q0={"phi": 0.2})),
        # one shape prescribed, one free (the lean), a potential, and a momentum
        (
            lambda: simplified_bicycle(m=1.0, h=0.8, c=0.3, b=1.0, g=9.81, J_s=0.05),
            dict(shapes={"sigma": "0.05*sin(2*t)"}, q0={"phi": 0.02}, p0=[1.0]),
        ),
    ],
    ids=["snakeboard", "roller_racer", "bicycle"],
)
def test_taylor_and_dop853_agree_and_taylor_converges_in_its_tolerance(build, kw):
    s = build()
    common = dict(t_final=3.0, saveat=13, **kw)
    ref = solve(s, BKMM(), rtol=1e-13, atol=1e-15, **common)
    errors = []
    for tol in (1e-6, 1e-9, 1e-12):
        sol = solve(s, BKMM(solver="taylor"), rtol=tol, atol=tol * 1e-2, **common)
        assert sol.stats["backend"] == "numba" and sol.status is Status.SUCCESS
        scale = max(1.0, float(np.abs(ref.q).max()))
        errors.append(float(np.abs(sol.q - ref.q).max()) / scale)
        # every saved state (by the step's polynomial, between the steps) to the tolerance's scale
        assert errors[-1] <= 100 * tol
        for name in ("p", "work", "energy"):
            r = getattr(ref, name)
            assert np.abs(getattr(sol, name) - r).max() <= 100 * tol * max(1.0, float(np.abs(r).max())), name
    assert errors[2] < 1e-3 * errors[0]
    # a few dozen steps of high order where DOP853 takes hundreds
    dop = solve(s, BKMM(), rtol=1e-12, atol=1e-14, **common)
    assert sol.stats["n_internal_steps"] < dop.stats["n_internal_steps"] / 2


def test_the_coasting_sleigh_keeps_its_energy_and_meets_dop853():
    # no shape: the momentum equation is the whole dynamics, its energy a first integral
    s = chaplygin_sleigh(m=1.5, I_c=0.4, a=0.6)
    common = dict(t_final=10.0, saveat=21, p0=[0.3, 0.5])
    ref = solve(s, BKMM(), rtol=1e-13, atol=1e-15, **common)
    sol = solve(s, BKMM(solver="taylor"), rtol=1e-12, atol=1e-14, **common)
    np.testing.assert_allclose(sol.q, ref.q, rtol=0, atol=1e-10 * max(1.0, float(np.abs(ref.q).max())))
    np.testing.assert_allclose(sol.p, ref.p, rtol=0, atol=1e-10)
    assert np.ptp(sol.energy) <= 1e-11 * abs(sol.energy[0])


def test_a_batch_by_taylor_is_each_member_alone():
    s = snakeboard(**SNAKE)
    gait = {"psi": "a*sin(2*pi*t)", "phi": "b*sin(2*pi*t)"}
    amplitudes = np.array([0.6, 1.0, 1.4])
    kw = dict(t_final=2.0, saveat=5, rtol=1e-11, atol=1e-13)
    batch = solve(s, BKMM(solver="taylor"), shapes=gait, parameters={"a": amplitudes, "b": 0.5}, threads=2, **kw)
    assert batch.batch_shape == (3,) and batch.status is Status.SUCCESS
    for i, amp in enumerate(amplitudes):
        one = solve(s, BKMM(solver="taylor"), shapes={"psi": f"{amp}*sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}, **kw)
        np.testing.assert_allclose(batch.q[i], one.q, rtol=0, atol=1e-9)


def test_what_taylor_cannot_do_is_refused_by_name():
    s = snakeboard(**SNAKE)
    with pytest.raises(InputError, match="runs compiled only"):
        solve(s, BKMM(solver="taylor"), t_final=1.0, shapes=GAIT, backend="python")
    racer = roller_racer(**RACER)
    with pytest.raises(InputError, match="Taylor recurrence"):
        solve(racer, BKMM(solver="taylor"), t_final=1.0, tau={"phi": "0.3*abs(sin(3*t))"})
    with pytest.raises(InputError, match="solver"):
        BKMM(solver="taylr")


def test_a_run_past_its_budget_stops_with_the_states_reached():
    s = snakeboard(**SNAKE)
    sol = solve(
        s, BKMM(solver="taylor"), t_final=5.0, saveat=11, shapes=GAIT, max_evaluations=200, raise_on_failure=False
    )
    assert sol.status is Status.BUDGET_EXHAUSTED and "evaluations" in sol.message
    reached = sol.t <= sol.failures[0].time
    assert reached.sum() >= 1 and np.all(np.isfinite(sol.q[reached])) and np.all(np.isnan(sol.q[~reached]))


# -- Taylor's method for any system given by formulas (`"taylor"`) -------------------------------------------------
BODY = gm.RigidBody([3.0, 2.0, 1.0])
M0 = np.array([1.0, 0.3, 0.2])


@pytest.mark.parametrize("compact", [False, True])
def test_the_free_body_meets_its_elliptic_solution_in_a_few_hundred_steps(compact):
    """Both forms of the coefficients' code: unrolled for the order (the default for equations this small) and the
    loop over the orders."""
    t = np.linspace(0.0, 100.0, 21)
    method = Taylor(compact=compact)
    sol = gm.solve(BODY, method, m0=M0, saveat=t, t_final=100.0, rtol=1e-13, atol=1e-15)
    exact = BODY.exact_solution(M0).momentum(t)
    np.testing.assert_allclose(sol.m, exact, rtol=0, atol=1e-11)
    np.testing.assert_allclose(np.linalg.norm(sol.m, axis=1), np.linalg.norm(M0), rtol=0, atol=1e-12)
    dop = gm.solve(BODY, "dop853", m0=M0, saveat=t, t_final=100.0, rtol=1e-13, atol=1e-15)
    assert sol.stats["n_internal_steps"] < dop.stats["n_internal_steps"] / 3


def test_equations_too_large_to_unroll_run_the_loop(monkeypatch):
    """The unrolled code is bounded before it is made: past UNROLL_LIMIT multiply-adds a pass, the loop over the
    orders runs (the same steps as compact=True's)."""
    kw = dict(m0=M0, t_final=10.0, saveat=3, rtol=1e-12, atol=1e-14)
    monkeypatch.setattr(_runners, "UNROLL_LIMIT", 0)
    monkeypatch.setattr(_taylor_llvm, "_compile", lambda *a: pytest.fail("compiled the unrolled code"))
    monkeypatch.setattr(_taylor_llvm, "_ADDRESSES", {})
    for module in list(_codegen._MODULES.values()):  # the choices made before, per module and order
        monkeypatch.delitem(module.__dict__, "_TAYLOR_CODES", raising=False)
    chosen = gm.solve(BODY, "taylor", **kw)
    loop = gm.solve(BODY, Taylor(compact=True), **kw)
    np.testing.assert_array_equal(chosen.m, loop.m)


def test_a_compact_that_is_not_a_choice_is_refused_by_name():
    with pytest.raises(InputError, match="compact"):
        Taylor(compact="yes")


def test_the_pendulums_period_from_events_on_the_steps_polynomials():
    """H = p^2/2 - cos q from (q, p) = (a, 0): q = 0 is crossed upwards every T = 4 K(sin^2(a/2))."""
    pendulum = gm.CanonicalSystem.from_expression("p**2/2 - cos(q)", ["q"], ["p"])
    a = 2.0
    sol = gm.solve(
        pendulum, "taylor", y0=[a, 0.0], t_final=60.0, rtol=1e-12, atol=1e-13, events={"up": Event("q", direction=1)}
    )
    times = sol.events["up"][:, 1]
    assert len(times) >= 5
    np.testing.assert_allclose(np.diff(times), 4.0 * ellipk(np.sin(a / 2) ** 2), rtol=0, atol=1e-9)
    np.testing.assert_allclose(sol.events["up"][:, 3], np.sqrt(2 * (1 - np.cos(a))), rtol=1e-10)
    # a terminal event ends the run there
    stop = gm.solve(
        pendulum,
        "taylor",
        y0=[a, 0.0],
        t_final=60.0,
        saveat=61,
        rtol=1e-12,
        atol=1e-13,
        events={"up": Event("q", direction=1, terminal=True)},
    )
    assert stop.status == "success" and len(stop.events["up"]) == 1
    np.testing.assert_allclose(stop.events["up"][0, 1], times[0], rtol=0, atol=1e-10)
    after = stop.t > times[0]
    assert np.isnan(stop.states[after]).all() and np.isfinite(stop.states[~after]).all()


def test_a_batch_of_inertias_is_each_member_alone():
    inertias = np.array([2.4, 2.7, 3.0])
    kw = dict(m0=M0, t_final=20.0, saveat=5, rtol=1e-12, atol=1e-14)
    batch = gm.solve(BODY, "taylor", parameters={"I1": inertias}, threads=2, **kw)
    for i, I1 in enumerate(inertias):
        one = gm.solve(gm.RigidBody([I1, 2.0, 1.0]), "taylor", **kw)
        np.testing.assert_allclose(batch.m[i], one.m, rtol=0, atol=1e-12)


def test_leaving_the_chart_is_located_on_the_polynomial():
    # the blow-up system H = -q p^2 / 2, p = 2 / (2 - t) from p0 = 1, on the chart p < 1.5: it ends at
    # t = 2 - 2/1.5 = 2/3, where q = (1 - t/2)^2 (q' = -q p)
    q, p = sp.symbols("q p", real=True)
    system = gm.CanonicalSystem.from_expression(-q * p**2 / 2, (q,), (p,), name="blow-up", chart=((1, -10.0, 1.5),))
    sol = gm.solve(
        system, "taylor", y0=[1.0, 1.0], t_final=3.0, saveat=31, rtol=1e-12, atol=1e-12, raise_on_failure=False
    )
    assert sol.status is Status.LEFT_CHART
    failure = sol.failures[0]
    assert abs(failure.time - 2.0 / 3.0) < 1e-12 and failure.step == 7  # the first output not reached: t = 0.7
    inside = sol.t < 2.0 / 3.0
    np.testing.assert_allclose(sol.states[inside, 0], (1 - sol.t[inside] / 2) ** 2, rtol=0, atol=1e-10)
    np.testing.assert_allclose(sol.states[inside, 1], 2 / (2 - sol.t[inside]), rtol=0, atol=1e-10)
    assert np.all(np.isnan(sol.states[~inside]))
    # a start outside the chart ends at once; a run that stays inside is a success
    outside = gm.solve(system, "taylor", y0=[1.0, 1.6], t_final=1.0, raise_on_failure=False)
    assert outside.status is Status.LEFT_CHART and outside.failures[0].time == 0.0
    assert gm.solve(system, "taylor", y0=[1.0, 0.5], t_final=1.5).status is Status.SUCCESS


def test_the_python_backend_is_refused_by_name():
    with pytest.raises(InputError, match="runs compiled"):
        gm.solve(BODY, "taylor", m0=M0, t_final=1.0, backend="python")


# -- several members at once: the coefficients of a batch in the lanes of the vector unit --------------------------
@pytest.mark.parametrize("lanes", [2, 4])
@pytest.mark.parametrize("name", FIELDS)
def test_each_lane_computes_its_own_members_coefficients(name, lanes):
    """The code for ``lanes`` members at once (every value a vector; the functions without a vector form called
    lane by lane) gives each lane what the code for one member gives at that lane's point and parameter."""
    tape = _tape(FIELDS[name])
    order = 12
    namespace = dict(python_helpers())
    exec(compile(python_header() + tape.constants_source("constants"), "<taylor>", "exec"), namespace)
    points = [(0.7 + 0.05 * lane, 1.3 - 0.1 * lane, 0.4 + 0.2 * lane, 0.8 + 0.1 * lane) for lane in range(lanes)]
    n_k = max(len(tape.constants), 1)
    XV, KV, PV = np.zeros((3, order + 1, lanes)), np.zeros((n_k, lanes)), np.zeros((1, lanes))
    alone = []
    for lane, (x0, y0, t0, a0) in enumerate(points):
        X, K, prm = np.zeros((3, order + 1)), np.zeros(n_k), np.array([a0])
        X[:, 0] = XV[:, 0, lane] = (x0, y0, t0)
        namespace["constants"](K, prm)
        KV[:, lane], PV[:, lane] = K, prm
        _call_unrolled(unrolled_address(tape, order), X, K, prm)
        alone.append(X)
    _call_unrolled(unrolled_address(tape, order, lanes), XV, KV, PV)
    for lane, X in enumerate(alone):
        scale = np.abs(X).max(axis=1, keepdims=True)
        np.testing.assert_allclose(XV[:, :, lane], X, rtol=0, atol=1e-13 * scale.max(), err_msg=f"lane {lane}")


@pytest.mark.parametrize("lanes", [1, 4])
def test_the_lanes_new_states_are_their_polynomials_at_their_steps(lanes):
    """Horner's rule on the lanes at once (the state's advance of a pass) against numpy's polynomial of each row
    of each lane at that lane's step."""
    d, order = 3, 9
    rng = np.random.default_rng(5)
    X = rng.uniform(-1.0, 1.0, (d, order + 1, lanes))
    H = rng.uniform(-0.5, 0.5, lanes)
    Y = np.zeros((d, lanes))
    _call_unrolled(_taylor_llvm.horner_address(d, order, lanes), X, H, Y)
    for lane in range(lanes):
        for i in range(d):
            exact = np.polynomial.polynomial.polyval(H[lane], X[i, :, lane])
            assert abs(Y[i, lane] - exact) <= 1e-14 * np.abs(X[i, :, lane]).sum(), (i, lane)


def _through_lanes(monkeypatch, lanes):
    """Runs of a batch compute the coefficients ``lanes`` members at a time; the widths asked for are recorded."""
    asked = []

    def unrolled(tape, order, width=1):
        asked.append(width)
        return unrolled_address(tape, order, width)

    monkeypatch.setattr(_runners, "simd_lanes", lambda: lanes)
    monkeypatch.setattr(_runners, "unrolled_address", unrolled)
    for module in list(_codegen._MODULES.values()):
        monkeypatch.delitem(module.__dict__, "_TAYLOR_CODES", raising=False)
    return asked


def _assert_members_alone(batch, system, Y, **kw):
    for i in range(Y.shape[0]):
        one = gm.solve(system, "taylor", y0=Y[i], **kw)
        np.testing.assert_array_equal(np.isnan(batch.states[i]), np.isnan(one.states), err_msg=f"member {i}")
        np.testing.assert_allclose(batch.states[i], one.states, rtol=0, atol=1e-12, err_msg=f"member {i}")
        mine = [f for f in batch.failures if f.batch_index == (i,)]
        assert [(f.kind, f.time) for f in mine] == [(f.kind, f.time) for f in one.failures], i


def test_a_batch_in_lanes_ends_each_member_where_it_ends_alone(monkeypatch):
    """The blow-up of the chart test from 14 momenta, 4 lanes refilled as members end: one reaches the end, four
    spend their budget at different times, seven leave the chart at different times, two start outside it. Each
    member's states, status and time of failure are those of the member run alone (one lane)."""
    q, p = sp.symbols("q p", real=True)
    system = gm.CanonicalSystem.from_expression(-q * p**2 / 2, (q,), (p,), name="blow-up", chart=((1, -10.0, 1.5),))
    p0 = np.linspace(0.3, 1.6, 14)
    Y = np.stack([np.ones_like(p0), p0], axis=1)
    kw = dict(t_final=3.0, saveat=31, rtol=1e-12, atol=1e-12, max_evaluations=80, raise_on_failure=False)
    asked = _through_lanes(monkeypatch, 4)
    batch = gm.solve(system, "taylor", y0=Y, threads=1, **kw)
    assert 4 in asked
    kinds = [f.kind for f in batch.failures]
    assert kinds.count(Status.BUDGET_EXHAUSTED) == 4 and kinds.count(Status.LEFT_CHART) == 9
    _assert_members_alone(batch, system, Y, **kw)


def test_events_in_lanes_are_each_members_own(monkeypatch):
    """Pendulums of 10 amplitudes, 2 lanes: each records its own upward crossings of q = 0, those swinging past
    q = 2.5 stop there (a terminal event) after one, the others run on; as alone."""
    pendulum = gm.CanonicalSystem.from_expression("p**2/2 - cos(q)", ["q"], ["p"])
    Y = np.stack([np.linspace(1.0, 2.8, 10), np.zeros(10)], axis=1)
    events = {"up": Event("q", direction=1), "stop": Event("q - 5/2", direction=1, terminal=True)}
    kw = dict(t_final=30.0, saveat=31, rtol=1e-12, atol=1e-13, events=events)
    _through_lanes(monkeypatch, 2)
    batch = gm.solve(pendulum, "taylor", y0=Y, threads=1, **kw)
    for i in range(Y.shape[0]):
        one = gm.solve(pendulum, "taylor", y0=Y[i], **kw)
        for name in events:  # rows (trajectory, t, state)
            mine = batch.events[name][batch.events[name][:, 0] == i]
            period = 4.0 * ellipk(np.sin(Y[i, 0] / 2) ** 2)
            crossings = 1 if Y[i, 0] > 2.5 else int(30.0 / period - 0.75) + 1
            expected = int(Y[i, 0] > 2.5) if name == "stop" else crossings
            assert len(mine) == len(one.events[name]) == expected, (name, i, len(mine))
            np.testing.assert_allclose(mine[:, 1:], one.events[name][:, 1:], rtol=0, atol=1e-12)
        # the first upward crossing at three quarters of the period 4 K(sin^2(a/2))
        first = batch.events["up"][batch.events["up"][:, 0] == i][0, 1]
        assert abs(first - 3.0 * ellipk(np.sin(Y[i, 0] / 2) ** 2)) < 1e-9
    _assert_members_alone(batch, pendulum, Y, **kw)


@pytest.mark.parametrize("solver, backend", [("taylor", "auto"), ("DOP853", "auto"), ("DOP853", "python")])
def test_bkmm_without_the_work_integrates_the_same_motion(solver, backend):
    """BKMM(work=False): the same motion and momentum (within the tolerance: the work no longer enters the error
    control), the shape forces still observed, no `work`; a batch too. Where every shape is prescribed, Taylor's
    pass has no shape forces in it (fewer operations in the tape)."""
    s = snakeboard(**SNAKE)
    common = dict(t_final=2.0, saveat=9, shapes=GAIT, rtol=1e-11, atol=1e-13, backend=backend)
    ref = solve(s, BKMM(solver=solver), **common)
    sol = solve(s, BKMM(solver=solver, work=False), **common)
    assert sol.stats["backend"] == ("python" if backend == "python" else "numba")
    for a, b in [(sol.q, ref.q), (sol.p, ref.p), (sol.quantities["tau"], ref.quantities["tau"])]:
        assert np.abs(a - b).max() <= 1e-8 * max(1.0, float(np.abs(b).max()))
    assert "work" not in sol.quantities and abs(ref.work[-1]) > 1e-3
    with pytest.raises(AttributeError, match="work=False"):
        _ = sol.work
    if backend == "python":
        return
    batch = solve(
        s,
        BKMM(solver=solver, work=False),
        **{**common, "shapes": {"psi": "a*sin(2*pi*t)", "phi": GAIT["phi"]}},
        parameters={"a": [1.0, 0.5]},
    )
    assert "work" not in batch.quantities
    np.testing.assert_allclose(batch.q[0], ref.q, rtol=0, atol=1e-8 * max(1.0, float(np.abs(ref.q).max())))
    if solver == "taylor":
        from geomech.integrators.nonholonomic._compiled import bkmm_module
        from geomech.integrators.nonholonomic._inputs import _setup
        from geomech.reduction import bkmm_reduction
        from geomech.symbolic.taylor import TaylorTape

        def heavy(work):
            setup = _setup(s, GAIT, None, None)
            module, _ = bkmm_module(setup, bkmm_reduction(s), True, None, work)
            return sum(op[0] != "lin" for op in TaylorTape.from_data(module.TAYLOR_TAPE).ops)

        assert heavy(False) <= heavy(True) - 6


def test_bkmm_work_is_true_or_false():
    with pytest.raises(InputError, match="`work`"):
        BKMM(work="no")

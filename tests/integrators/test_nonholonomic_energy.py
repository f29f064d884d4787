"""Energy conservation with free shapes and no shape forces, for the examples the other simulation tests leave
out: the Getz-Marsden bicycle (the only example with a potential: gravity acts on the lean), the geared body
(integrable constraint, also in its rescaled form), the kinematic car (principally kinematic: no momentum, the
shapes move freely and carry the body) and Chaplygin's ball.

The energy is recomputed here from the Lagrangian, E = q' . dL/dq' - L, at the recorded states: the simulators'
own energy column is not used. The LagrangeDAlembert and BKMM methods (DOP853, rtol 1e-10) must keep it to 1e-9
relative; the discrete Lagrange-d'Alembert integrator (midpoint, second order) to O(h^2): its largest energy error
over the run, and its error in the final state, must fall by about four when h is halved.
"""

import numpy as np
import pytest
import sympy as sp

from geomech import solve
from geomech.integrators import BKMM, DiscreteLagrangeDAlembert, LagrangeDAlembert
from geomech.systems.nonholonomic_examples import chaplygin_ball, geared_body, kinematic_car, simplified_bicycle

# (builder, parameters, initial data). Starts are chosen so the motion is non-trivial (every coordinate moves)
# and stays away from the charts' singularities (the ball's theta = 0, the car's and bicycle's steering pi/2).
CASES = {
    "simplified_bicycle": (
        simplified_bicycle,
        dict(m=1.0, h=0.8, c=0.3, b=1.0, g=9.81, J_s=0.05),
        dict(q0={"phi": 0.1, "sigma": 0.2}, rdot0={"phi": 0.3, "sigma": -0.4}, p0=[1.5]),
    ),
    "geared_body": (
        geared_body,
        dict(m=1.2, J=0.3, J0=0.2, k=0.7, a=0.4),
        dict(q0={"psi": 0.3}, rdot0={"psi": 1.1}, p0=[0.6, -0.4]),
    ),
    "geared_body_scaled": (
        lambda **kw: geared_body(scaled=True, **kw),
        dict(m=1.2, J=0.3, J0=0.2, k=0.7, a=0.4),
        dict(q0={"psi": 0.3}, rdot0={"psi": 1.1}, p0=[0.6, -0.4]),
    ),
    "kinematic_car": (
        kinematic_car,
        dict(m=1.0, I=0.2, R=0.3, ell=1.0, J=0.1, K=0.1),
        dict(q0={"phi": 0.2}, rdot0={"psi": 2.0, "phi": 0.3}),
    ),
    "chaplygin_ball": (
        chaplygin_ball,
        dict(m=1.3, r=0.8, I1=0.4, I2=0.5, I3=0.7),
        dict(q0={"theta": 1.0, "psi": 0.3}, rdot0={"theta": 0.5, "psi": 1.0}, p0=[0.3]),
    ),
}
T_FINAL = 2.0
#: The ball's BKMM reduction (needed for its initial state and momentum) takes ~15 s to derive.
SLOW = {"chaplygin_ball"}


def _names(slow=frozenset()):
    return [pytest.param(n, marks=[pytest.mark.slow] if n in slow else []) for n in CASES]


def _energy(system, q, qd):
    """E = q' . dL/dq' - L from the Lagrangian, at each recorded state."""
    L = system.lagrangian.subs(system.parameter_values())
    E = sum(v * sp.diff(L, v) for v in system.qdot) - L
    f = sp.lambdify(list(system.q) + list(system.qdot), E, "numpy")
    return np.array([float(f(*a, *b)) for a, b in zip(q, qd)])


def _build(name):
    build, params, init = CASES[name]
    return build(**params), init


@pytest.mark.parametrize("name", _names(SLOW))
def test_full_and_reduced_simulators_conserve_energy(name):
    s, init = _build(name)
    full = solve(s, LagrangeDAlembert(), t_final=T_FINAL, saveat=41, **init)
    reduced = solve(s, BKMM(), t_final=T_FINAL, saveat=41, **init)
    E0 = _energy(s, full.q[:1], full.qdot[:1])[0]
    assert E0 > 0.1
    for tr in (full, reduced):
        E = _energy(s, tr.q, tr.qdot)
        assert np.abs(E - E0).max() < 1e-9 * E0, f"{tr.method!r}: energy drift {np.abs(E - E0).max():.3g}"
        assert np.all(tr.tau == 0) and np.all(tr.work == 0)  # free shapes, no forces
    assert np.abs(full.constraint_residual).max() < 1e-9 and np.abs(reduced.constraint_residual).max() < 1e-12
    np.testing.assert_allclose(full.q, reduced.q, atol=1e-8)
    # the motion is not trivial: the shapes and the group move
    assert np.ptp(full.q[:, s.k :], axis=0).min() > 0.05 and np.ptp(full.q[:, : s.k], axis=0).max() > 0.1


@pytest.mark.parametrize("name", _names(SLOW))
def test_discrete_simulator_energy_error_is_second_order(name):
    s, init = _build(name)
    ref = solve(s, LagrangeDAlembert(), t_final=T_FINAL, saveat=3, **init)
    E0 = _energy(s, ref.q[:1], ref.qdot[:1])[0]
    errs, finals = [], []
    for h in (0.02, 0.01):
        tr = solve(s, DiscreteLagrangeDAlembert(), t_final=T_FINAL, h=h, **init)
        E = _energy(s, tr.q, tr.qdot)
        errs.append(np.abs(E - E0).max() / E0)
        finals.append(np.abs(tr.q[-1] - ref.q[-1]).max())
        assert np.all(tr.work == 0)
    assert errs[1] < 1e-3, errs
    # second order: halving h divides the energy error and the final-state error by about four
    assert 2.8 < errs[0] / errs[1] < 5.7, errs
    assert 2.8 < finals[0] / finals[1] < 5.7 and finals[1] < 1e-3, finals

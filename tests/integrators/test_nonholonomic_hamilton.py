"""Hamilton's equations on the constraint momentum submanifold through ``solve`` (:class:`NonholonomicHamilton`):
the almost-Poisson, Bates-Sniatycki and full-tensor forms each give the Lagrange-d'Alembert flow, computed by an
independent route (the multipliers solved in the coordinates), with torques acting on the shapes, for the
snakeboard, the roller racer and a system of the tests' own."""

from __future__ import annotations

import numpy as np
import pytest
from own_systems import free_body_in_euler_angles, knife_edge_with_rotor

from geomech import solve
from geomech.errors import InputError
from geomech.integrators import LagrangeDAlembert, NonholonomicHamilton
from geomech.systems.nonholonomic_examples import roller_racer, snakeboard_bkmm

FLOWS = {
    "snakeboard": (
        lambda: snakeboard_bkmm(m=1.0, r=1.0, J0=0.3, J1=0.1),
        dict(q0={"phi": 0.2}, rdot0={"psi": 1.0, "phi": 0.3}, p0=[0.3]),
        {"psi": "-psi - 0.1*psi_dot", "phi": "-2*phi + 0.3*sin(3*t)"},
    ),
    "roller_racer": (
        lambda: roller_racer(m1=1.0, m2=0.8, I1=0.3, I2=0.2, d1=0.5, d2=0.6),
        dict(q0={"phi": 0.3}, rdot0={"phi": 0.5}, p0=[0.4]),
        {"phi": "-3*phi - 0.2*phi_dot*theta_dot"},
    ),
    "own": (
        knife_edge_with_rotor,
        dict(q0={"phi": 0.4}, rdot0={"phi": -0.6}, p0=[0.5, -0.2]),
        {"phi": "0.5*cos(2*t) - 0.1*x"},
    ),
}
FORMS = ["almost_poisson", "bates_sniatycki", "full"]


@pytest.fixture(scope="module", params=list(FLOWS))
def flow(request):
    make, start, tau = FLOWS[request.param]
    system = make()
    kw = dict(t_final=1.2, saveat=7, tau=tau, **start)
    return system, kw, solve(system, LagrangeDAlembert(), rtol=1e-12, atol=1e-13, **kw)


@pytest.mark.parametrize("form", FORMS)
def test_every_form_is_the_lagrange_dalembert_flow(flow, form):
    system, kw, ref = flow
    sol = solve(system, NonholonomicHamilton(form=form), **kw)
    assert sol.success and sol.method.key == {"full": "full_almost_poisson"}.get(form, form)
    scale = np.abs(ref.q).max() + np.abs(ref.qdot).max()
    np.testing.assert_allclose(sol.q, ref.q, atol=1e-8 * scale)
    np.testing.assert_allclose(sol.qdot, ref.qdot, atol=1e-8 * scale)
    np.testing.assert_allclose(sol.p, ref.p, atol=1e-8 * scale)
    # the torques do work: the energy changes, and by exactly that work
    assert np.ptp(sol.energy) > 1e-3
    assert np.abs(sol.energy - sol.energy[0] - sol.work).max() < 1e-8 * np.abs(sol.energy).max()
    assert np.abs(sol.constraint_residual).max() < 1e-9 * scale


def test_forms_by_their_registry_keys_and_free_motion_keeps_energy():
    make, start, _ = FLOWS["own"]
    system = make()
    runs = [solve(system, key, t_final=2.0, saveat=5, **start) for key in ("bates_sniatycki", "full_almost_poisson")]
    for sol in runs:
        assert np.ptp(sol.energy) < 1e-9 * abs(sol.energy[0]) and np.all(sol.work == 0)
    np.testing.assert_allclose(runs[0].q, runs[1].q, atol=1e-8)


def test_a_gait_is_refused_with_the_methods_that_take_one():
    make, start, _ = FLOWS["roller_racer"]
    with pytest.raises(InputError, match="prescribed gait.*BKMM"):
        solve(make(), NonholonomicHamilton(), t_final=1.0, shapes={"phi": "0.3*sin(t)"}, q0={"x": 0.0})


def test_the_full_tensor_needs_constraints_and_bad_options_are_named():
    with pytest.raises(InputError, match="no constraints.*almost_poisson"):
        solve(free_body_in_euler_angles(), NonholonomicHamilton(form="full"), t_final=0.1, q0=[0.1, 1.0, 0.2])
    with pytest.raises(InputError, match="`form`"):
        NonholonomicHamilton(form="vm")
    with pytest.raises(InputError, match="`basis`"):
        NonholonomicHamilton(basis="orthogonal")


@pytest.mark.parametrize("form", FORMS)
def test_the_force_response_is_the_field_under_a_force(form, rng):
    """``field(z, F) = free + R F`` with ``(free, R) = response(z)``: the engine's one evaluation a step under torques
    is the twin's field, at random states and forces, and ``R`` leaves the velocity rows alone."""
    from geomech.integrators.nonholonomic._hamiltonian import _field

    system = knife_edge_with_rotor()
    field, response, _ = _field(system, form, "bkmm", None)
    n = system.n
    z = rng.normal(size=(5, 2 * n if form == "full" else n + system.n - system.c)) * 0.5
    F = rng.normal(size=(5, n))
    free, R = response(z)
    np.testing.assert_allclose(free, field(z), rtol=1e-12, atol=1e-12)
    expected = field(z, F)
    np.testing.assert_allclose(
        free + np.einsum("bij,bj->bi", R, F), expected, rtol=1e-10, atol=1e-10 * np.abs(expected).max()
    )
    assert np.abs(R[:, :n]).max() <= 1e-12 * np.abs(R).max()

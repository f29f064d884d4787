"""The compiled Lie-Poisson splitting merges consecutive sub-flows about one body axis (inside a step, across
the stages of a composition, and across steps unless a state is saved between them). The flow of f_i(m_i)
keeps m_i, so such flows compose exactly: the merged scheme must equal the plain composition of every
Strang sub-flow, done here independently in numpy, to round-off (its order 4 is fitted in
test_lie_poisson_methods.py)."""

import numpy as np
import pytest
import sympy as sp

import geomech as gm
from geomech.integrators._problem import make_problem
from geomech.integrators.methods import composition_weights
from geomech.integrators.solve import solve


def _unmerged(system, m0, h, n_steps, order, composition, axis_order):
    m = gm.M_SYMBOLS
    H = system.expression.subs({sp.Symbol(k, real=True): v for k, v in system.parameters.items()})
    d = [sp.lambdify(m[i], sp.diff(H, m[i]).subs({m[j]: 0 for j in range(3) if j != i}), "numpy") for i in range(3)]
    a, b, c = axis_order
    y = np.array(m0, dtype=float)
    out = [y.copy()]
    for _ in range(n_steps):
        for g in composition_weights(order, composition):
            for axis, frac in ((a, 0.5), (b, 0.5), (c, 1.0), (b, 0.5), (a, 0.5)):
                theta = g * frac * h * float(d[axis](y[axis]))
                j, k = (axis + 1) % 3, (axis + 2) % 3
                y[j], y[k] = np.cos(theta) * y[j] + np.sin(theta) * y[k], np.cos(theta) * y[k] - np.sin(theta) * y[j]
        out.append(y.copy())
    return np.array(out)


@pytest.mark.parametrize("composition", ["yoshida", "suzuki"])
@pytest.mark.parametrize("every", [1, 7, 40])
def test_merged_equals_unmerged_to_round_off(closed_loop, m_start, composition, every):
    method = gm.integrators.LiePoissonSplitting(4, composition)
    rng = np.random.default_rng(3)
    m0 = np.vstack([m_start, rng.normal(size=(3, 3)) * 0.6])
    # every `every`-th of the 40 steps saved, and the last
    saved = np.arange(0, 41, every)
    saved = np.append(saved, 40) if saved[-1] != 40 else saved
    saveat = 0.05 * saved
    saveat[-1] = 2.0
    sol = solve(closed_loop, method, m0=m0, h=0.05, t_final=2.0, saveat=saveat, threads=1)
    assert sol.t.size == saved.size
    axis_order = make_problem(closed_loop, attitude=False).split_axis_order
    steps = np.round((sol.t - sol.t[0]) / 0.05).astype(int)
    for b in range(m0.shape[0]):
        ref = _unmerged(closed_loop, m0[b], 0.05, 40, 4, composition, axis_order)[steps]
        np.testing.assert_allclose(sol.m[b], ref, atol=1e-13, rtol=0)  # 40 steps of |m| ~ 1: round-off, not O(h^p)
        # |m| is kept to round-off by both
        np.testing.assert_allclose(np.linalg.norm(sol.m[b], axis=-1), np.linalg.norm(m0[b]), rtol=1e-14)


def test_merging_saves_sub_flows(closed_loop):
    """Suzuki's five Strang stages have 25 sub-flows; merged in the step, 21; across steps (FSAL), 20 a step."""
    seq = gm.integrators.LiePoissonSplitting(4, "suzuki").sequence((0, 1, 2))
    assert len(seq) == 21 and seq[0][0] == seq[-1][0]
    assert sum(f for a, f in seq if a == 2) == pytest.approx(1.0, abs=1e-15)  # each axis flows for h in all
    sol = solve(closed_loop, "splitting_4_suzuki", m0=[0.3, 0.2, 0.9], h=0.01, t_final=1.0, saveat=2)
    assert sol.stats["n_rhs"] == 100 * 21  # flows counted as in one step's sequence (before FSAL)

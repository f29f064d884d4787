"""The methods table of docs/integrators.md, built from the registry (so the docs cannot drift)."""

from __future__ import annotations

from .methods import REGISTRY, methods_table

HEADER = """# Integrators

`geomech.solve(system, method, *, t_final, saveat, h | rtol, atol, <initial state>, ...)` integrates a system
with a method; a method is a small immutable value with its kind, order and traits, and the structure it
needs. Times are given one way: the end `t_final`, the output times `saveat` (a number of equally spaced
times or the times themselves), and the step `h` of a fixed-step method or the tolerances `rtol`/`atol` of
an adaptive one; an exact propagator takes neither. The initial state is `y0 = (q, p)` for a canonical
system, `m0` (and `R0` for the attitude) for a left-invariant one, `m0` and `Gamma0` for a body with rotors,
`q0` with `qdot0` (or `rdot0` and `p0`) for a Lagrangian system on G x S (with constraints or none), `g0` (an
element or its coordinates) for a body velocity on a group (`GroupFlow`, the reconstruction equation
`g^-1 g' = xi(t, g)`). An incompatible pair fails before any work
(`IncompatibleMethodError`, which names the methods that would apply). Numerical failure (a Newton iteration
that does not converge, a non-finite state, an adaptive solver that gives up, an exhausted budget) is status
data in the `Solution`, raised by default with the step, the time and the residual, the partial solution
attached.

Fixed-step methods on Hamiltonian systems and the Dormand-Prince pairs (`dop853`, `dopri5`: error control,
dense output at any `saveat`, the same steps as scipy's solvers of those names) run in loops compiled with
numba from the symbolic model (cached on disk), over a batch of initial states in threads. The high orders
that keep the structure: Gauss-Legendre collocation up to s = 6 stages (order 12), the symmetric
compositions `Composition(order, scheme, stages)` of the midpoint rule (`midpoint_s9_6`, `midpoint_s17_8`,
`midpoint_s35_10`) or of Gauss-Legendre steps, and the Lie-Poisson splitting composed to order 10
(`LiePoissonSplitting(order, composition)`); `composition_weights` gives the weights. Gauss-Legendre solves
its stages by Newton's method with one factorisation a step (from s d = 24 unknowns on, of (s + 1)/2 complex
d x d blocks in the eigenbasis of its A, several times cheaper), runs the iteration a hundred times below
`newton_tol` (a composition's J sub-steps J times lower again) and steps by y + h sum b_i f(Y_i) at the
converged stages, summed with compensation, so that its energy error over 1e5 steps and more stays at round-off
(a step by d = b^T A^{-1}, which saves s evaluations, drifts). Taylor's method
(`taylor`) generates the Taylor coefficients of the solution from the system's formulas (`geomech.symbolic.taylor`)
and steps them at the order of the tolerances, with dense output and events on each step's polynomial: a few dozen
steps where DOP853 takes hundreds. Its coefficients' code is written out for the order and compiled by LLVM
(`geomech.integrators._taylor_llvm`, about a second per order, cached on disk), or, for large equations or with
`Taylor(compact=True)`, a loop over the orders. A batch computes the coefficients of 4 members at once (the lanes
of an AVX vector unit; 8 with AVX-512, 2 without AVX), each member stepping on its own and its lane taking the next
member where it ends: 2.5 times less time a member than one at a time. The compiled loops of `solve` (the
fixed-step methods, the Dormand-Prince pairs, Taylor's method, the discrete Lagrange-d'Alembert map, RKMK, the
periodic-orbit propagator), the model's functions they call and the observation of the saved states also keep
machine code of their own beside numba's cache (`geomech.integrators._native`, on Linux): a later process loads
and runs them without importing numba, so that a compiled model from a warm cache gives its first result in
0.04-0.15 s instead of 0.4-1.2 s. Adaptive Adams wraps scipy's VODE/LSODA.
Events (`events={"apex": Event("m1", direction=-1)}`) are located on the continuous extension of the step that
crosses them by the Dormand-Prince pairs, Taylor's method and scipy's solvers (`SolveIVP("Radau")`, ...).
The Lagrangian methods (BKMM, Lagrange-d'Alembert, the discrete Lagrange-d'Alembert map with either discrete
Lagrangian, the group's on SO(2), R^n, SE(2), SO(3), SE(3) and their products) run compiled where the gait and
torques are formulas, BKMM also by Taylor's method (`BKMM(solver="taylor")`, from the reduction's closed
forms), and otherwise under scipy's solve_ivp solvers. The Runge-Kutta-Munthe-Kaas methods step on the group in
exponential coordinates about a moving centre. The exact propagators give the state of a one-degree-of-freedom
system at any time from one period, at a cost that does not grow with t. Speed and accuracy beside scipy and heyoka:
`benchmarks/README.md`.

Where the time goes: `sol.stats` has `compile_time` (numba's or LLVM's, once per model and method, then a load
from the disk cache), `run_time`, and for a compiled run `loop_time`, the calls into the compiled loop alone;
the rest of `run_time` and of the call is the Python around the loop (the set-up, the initial state, the bound on
the work, the quantities at the saved times, the Solution: 0.3 to 0.6 ms a call, where a small problem's loop
takes tens of microseconds). Many small runs are faster as one call over a batch, which pays it once. Runs one
after another (an optimiser's, a Monte Carlo loop's) take a prepared problem, as heyoka's integrator object is
built once and propagated many times: `prepared = geomech.prepare(system, method, t_final=..., rtol=...)` checks
the method against the system, the times, the tolerances, the torque law and the events, and finds the compiled
model, once; `prepared.solve(m0=..., parameters=...)` then runs from each start with each parameters' values
(`attitude=True` to give `R0` at each call). `solve(...)` is `prepare(...).solve(...)`: the same checks and the
same run; it keeps the last few problems it prepared for a system (by their options' values; a function by
identity), so that `solve` called in a loop with the same options prepares once and costs about a prepared call
(10-20 microseconds more, the options compared). A prepared problem's single runs by a compiled adaptive method
(`dop853`, `dopri5`, `taylor`, BKMM, Lagrange-d'Alembert) start from the compiled loop bound to the first run's
buffers, its arguments checked and gathered once: each later run writes its start into the bound row, calls the
loop and the observation of its saved states, and copies the output into its Solution (a run that fails, or
outgrows its pilot's budget, is made again the general way, which reports it).

Ensembles and sensitivities: the leading axes of the initial state are a batch, and so are those of
`parameters={name: array}` (the named parameters of a system built from a formula: each trajectory reads its
own values in the same compiled call); `sensitivities=True` integrates the variational equations with an
explicit method and returns the state transition matrix `dy(t)/dy(t0)` as the quantity `stm`, and
`sensitivities=("I1", ...)` adds `parameter_sensitivity`, `dy(t)/dp` (for a Lagrangian system, with BKMM
compiled: its state's, to the system's parameters and the gait's and torques' coefficients;
`docs/nonholonomic.md`):

```python
import numpy as np
import geomech as gm

body = gm.RigidBody([2.5, 2.0, 1.0])
sol = gm.solve(body, "dop853", m0=[1.0, 0.3, 0.2], t_final=10.0, rtol=1e-12, atol=1e-12,
               parameters={"I1": np.linspace(2.2, 2.8, 4)}, sensitivities=("I1",))
print(sol.states.shape, sol.quantities["stm"].shape, sol.quantities["parameter_sensitivity"].shape)
m, Phi = sol.m[:, -1], sol.quantities["stm"][:, -1]
print(np.abs(np.einsum("bi,bij->bj", m, Phi) - [1.0, 0.3, 0.2]).max() < 1e-9)  # |m|^2 is a Casimir
```

This table is generated from `geomech.integrators.REGISTRY` (`python -m geomech.integrators._docs`).

"""


def _summary(key: str) -> str:
    return REGISTRY[key].summary


def _order(row: dict) -> str:
    if row["order"] is None:
        return "none (exact up to `tol`)"
    if row["variable_order"]:
        return f"1-{row['order']} (variable)"
    return str(row["order"])


def table_markdown() -> str:
    rows = [
        "| key | method | kind | order | structure needed | explicit | symplectic | symmetric | keeps Casimirs |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    yes = {True: "yes", False: "no", None: "-"}
    for r in methods_table():
        rows.append(
            f"| `{r['key']}` | {_summary(r['key'])} | {r['kind']} | {_order(r)} | {r['structure']} | "
            f"{yes[r['explicit']]} | {yes[r['symplectic']]} | {yes[r['symmetric']]} | {yes[r['preserves_casimirs']]} |"
        )
    return "\n".join(rows) + "\n"


FOOTER = """
## The generating-function method: its h^2 term

Section 8.1 of the Serret-Andoyer paper steps the reduced system by `l_k = dS/dL_k`,
`L_{k+1} = dS/dl_{k+1}` with `S(L_k, l_{k+1}) = l_{k+1} L_k - h H(l_{k+1}, L_k) + O(h^2)` and does not print
the `h^2` term. Write `Q = l_{k+1}`, `p = L_k` and `S = p Q + h S1(Q, p) + h^2 S2(Q, p) + O(h^3)`. The map
`q = dS/dp`, `P = dS/dQ` is the flow of `H` for time `h` exactly when `S` solves the Hamilton-Jacobi equation

    dS/dh (Q, p, h) = -H(Q, dS/dQ(Q, p, h)).

Expanding the right side, `-H(Q, p + h dS1/dQ + ...) = -H(Q, p) - h H_p(Q, p) dS1/dQ + O(h^2)`, and matching
powers of `h`: `S1 = -H` and `2 S2 = -H_p dS1/dQ = H_q H_p`, so

    S(p, Q) = p Q - h H(Q, p) + (h^2 / 2) H_q(Q, p) H_p(Q, p)      (a dot product for n > 1).

Without the `h^2` term the method is symplectic Euler (order 1); with it the map agrees with the flow to
`O(h^3)` per step (order 2). It is not the implicit midpoint rule: it is not symmetric, and one step of the
two differs at `O(h^3)`. Tests: `tests/integrators/test_canonical_methods.py` derives `S2` from the equation
above with sympy, checks the map against the Taylor series of the exact flow, and measures the order and the
asymmetry.
"""


def document() -> str:
    return HEADER + table_markdown() + FOOTER


if __name__ == "__main__":  # pragma: no cover
    print(document(), end="")

"""Quick speed check of the compiled integrators (the full work-precision benchmark is separate).

    PYTHONPATH=src python benchmarks/integrators_smoke.py

Measures, on the reduced closed loop of section 8 of the Serret-Andoyer paper (lambda1 = 3, lambda2 = 2,
I3 = 1, phi(v) = 2 tan(v/G), p = 0, G = 1, from (l, L) = (0.3, 0.2)), the cost of a step of each fixed-step
canonical method at h = 1e-3, and the throughput of the Lie-Poisson splitting on a batch of 1e5 initial
momenta of the closed loop H_c on 1 and 2 threads. Times are the best of several repeats (the machine may
be shared); compile times are reported apart.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import sympy as sp

import geomech as gm
from geomech.integrators.solve import solve


def closed_loop_reduced(G: float = 1.0) -> gm.CanonicalSystem:
    l, L = sp.symbols("l L", real=True)
    lam1, lam2, I3 = 3, 2, 1
    # h_p = 1/2 (G^2 - L^2)(sin^2 l/lam1 + cos^2 l/lam2) + L^2/(2 I3) - (1/I3) int_0^L 2 tan(v/G) dv
    hp = (
        sp.Rational(1, 2) * (G**2 - L**2) * (sp.sin(l) ** 2 / lam1 + sp.cos(l) ** 2 / lam2)
        + L**2 / (2 * I3)
        + 2 * G * sp.log(sp.cos(L / G)) / I3
    )
    return gm.CanonicalSystem.from_expression(hp, (l,), (L,), name="closed-loop h_p", angle_coordinates=(0,))


def closed_loop() -> gm.LeftInvariantSystem:
    m1, m2, m3 = gm.M_SYMBOLS
    return gm.LeftInvariantSystem.from_expression(
        m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + 2 * sp.log(sp.cos(m3)), name="closed loop H_c"
    )


def best_run_time(fn, repeats: int) -> float:
    return min(fn().stats["run_time"] for _ in range(repeats))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=200_000)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--batch", type=int, default=100_000)
    args = parser.parse_args()

    red = closed_loop_reduced()
    y0 = [0.3, 0.2]
    print(f"reduced closed loop, h = 1e-3, {args.steps} steps, best of {args.repeats}")
    for key in (
        "implicit_midpoint",
        "gauss_legendre_1",
        "gauss_legendre_2",
        "gauss_legendre_3",
        "generating_function",
        "symplectic_euler",
        "rk4",
        "abm4",
    ):
        t = time.perf_counter()
        first = solve(red, key, y0=y0, h=1e-3, t_final=10 * 1e-3)
        setup = time.perf_counter() - t
        best = best_run_time(
            lambda key=key: solve(red, key, y0=y0, h=1e-3, t_final=args.steps * 1e-3, saveat=2), args.repeats
        )
        print(
            f"  {key:22s} {best / args.steps * 1e9:8.1f} ns/step   (compile {first.stats['compile_time']:.2f} s, "
            f"first call {setup:.2f} s)"
        )

    hc = closed_loop()
    rng = np.random.default_rng(0)
    m0 = rng.normal(size=(args.batch, 3))
    m0 /= np.linalg.norm(m0, axis=1, keepdims=True)
    n = 200
    for key in ("strang", "splitting_4_suzuki"):
        solve(hc, key, m0=m0[:2], h=1e-2, t_final=2 * 1e-2)
        for threads in (1, 2):
            best = best_run_time(
                lambda key=key, threads=threads: solve(
                    hc, key, m0=m0, h=1e-2, t_final=n * 1e-2, saveat=2, threads=threads
                ),
                max(2, args.repeats // 2),
            )
            rate = args.batch * n / best
            print(f"  {key:22s} batch {args.batch}, {threads} thread(s): {rate:.3g} trajectory-steps/s")


if __name__ == "__main__":
    main()

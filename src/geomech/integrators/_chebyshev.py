"""Adaptive piecewise Chebyshev interpolation, with antiderivatives (Clenshaw-Curtis) and error estimates:
the representation behind :mod:`geomech.integrators.quadrature`."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.polynomial import chebyshev as _cheb

from ..errors import ConvergenceError

_EPS = float(np.finfo(float).eps)
#: Evaluation chunk: bounds the temporary arrays of a batched evaluation.
_CHUNK = 8192


def _cheb_points(n: int) -> np.ndarray:
    return np.cos(np.pi * np.arange(n) / (n - 1))


def _cheb_coefficients(values: np.ndarray) -> np.ndarray:
    """Chebyshev coefficients from values at :func:`_cheb_points` (a DCT-I through the FFT)."""
    n = values.shape[0]
    ext = np.concatenate([values, values[-2:0:-1]], axis=0)
    c = np.fft.rfft(ext, axis=0).real / (n - 1)
    c[0] /= 2
    c[-1] /= 2
    return c


def _chebeval(coeffs: np.ndarray, idx: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Evaluate piece ``idx[i]`` of ``coeffs`` (K, D, m) at ``x[i]`` in [-1, 1]; returns (N, m)."""
    return np.einsum("nd,ndm->nm", _cheb.chebvander(x, coeffs.shape[1] - 1), coeffs[idx])


class _Piecewise:
    """A piecewise Chebyshev interpolant of an ``m``-vector function on ``[edges[0], edges[-1]]``.

    ``root[j]`` is the index of the initial interval that piece ``j`` was cut from.
    """

    __slots__ = ("edges", "coeffs", "root", "noise")

    def __init__(self, edges: np.ndarray, coeffs: np.ndarray, root: np.ndarray):
        self.edges, self.coeffs, self.root, self.noise = edges, coeffs, root, 0.0

    @classmethod
    def fit(
        cls,
        fun: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]],
        edges: np.ndarray,
        floor: np.ndarray,
        ctol: float,
        what: str,
        ladder: tuple[int, ...] = (17, 33, 65),
    ) -> _Piecewise:
        """Adapt to ``fun(s, root) -> (values, noise)``, both ``(N, m)``: a piece is accepted when the last
        three Chebyshev coefficients of every component are below ``ctol`` times its size (at least
        ``floor``) or below the rounding noise of the values, and is halved when the finest rung of
        ``ladder`` does not reach that. The largest accepted tail relative to the size is kept in ``noise``.
        """
        pending = [(float(a), float(b), j) for j, (a, b) in enumerate(zip(edges[:-1], edges[1:])) if b > a]
        min_width = 1e-13 * (edges[-1] - edges[0])
        done: list[tuple[float, float, int, np.ndarray]] = []
        worst = 0.0
        while pending:
            for n in ladder:
                if not pending:
                    break
                x = _cheb_points(n)
                s = np.concatenate([a + (x + 1) / 2 * (b - a) for a, b, _ in pending])
                roots = np.repeat([j for _, _, j in pending], n)
                vals, noise = fun(s, roots)
                vals = np.asarray(vals, dtype=float).reshape(len(pending), n, -1)
                noise = np.broadcast_to(noise, (len(pending) * n, vals.shape[2])).reshape(vals.shape)
                still = []
                for (a, b, j), v, e in zip(pending, vals, noise):
                    c = _cheb_coefficients(v)
                    size = np.maximum(np.abs(v).max(axis=0), floor)
                    tail = np.abs(c[-3:]).max(axis=0)
                    # the median, not the maximum: one noisy node must not excuse an unresolved piece
                    if np.all(tail <= np.maximum(ctol * size, np.median(e, axis=0))):
                        done.append((a, b, j, c))
                        worst = max(worst, float(np.max(tail / size)))
                    else:
                        still.append((a, b, j))
                pending = still
            split = []
            for a, b, j in pending:
                if b - a < min_width or len(done) + len(pending) > 5000:
                    raise ConvergenceError(
                        f"The {what} could not be resolved near {a:.15g}: the Chebyshev coefficients do not "
                        "decay on ever smaller intervals. Is the level curve at a critical point of H?"
                    )
                mid = 0.5 * (a + b)
                split += [(a, mid, j), (mid, b, j)]
            pending = split
        done.sort(key=lambda d: d[0])
        D, m = max(d[3].shape[0] for d in done), done[0][3].shape[1]
        coeffs = np.zeros((len(done), D, m))
        for k, d in enumerate(done):
            coeffs[k, : d[3].shape[0]] = d[3]
        out = cls(np.array([d[0] for d in done] + [done[-1][1]]), coeffs, np.array([d[2] for d in done]))
        out.noise = worst
        return out

    def locate(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        idx = np.clip(np.searchsorted(self.edges, s, side="right") - 1, 0, len(self.edges) - 2)
        a, b = self.edges[idx], self.edges[idx + 1]
        return idx, (2 * s - a - b) / (b - a)

    def __call__(self, s: np.ndarray) -> np.ndarray:
        s = np.asarray(s, dtype=float)
        flat = s.ravel()
        out = np.empty((flat.size, self.coeffs.shape[2]))
        for k in range(0, flat.size, _CHUNK):
            idx, x = self.locate(flat[k : k + _CHUNK])
            out[k : k + _CHUNK] = _chebeval(self.coeffs, idx, x)
        return out.reshape(s.shape + (self.coeffs.shape[2],))

    def antiderivative(self) -> tuple[_Piecewise, np.ndarray]:
        """The antiderivative from ``edges[0]`` and its values at the edges ``(K + 1, m)`` (compensated sums
        of the pieces' Clenshaw-Curtis integrals)."""
        C = _cheb.chebint(self.coeffs, lbnd=-1, axis=1) * (np.diff(self.edges) / 2)[:, None, None]
        increments = C.sum(axis=1)  # the values at x = 1
        at_edges = np.array([[math.fsum(col[:j]) for col in increments.T] for j in range(len(C) + 1)])
        C[:, 0] += at_edges[:-1]
        return _Piecewise(self.edges, C, self.root), at_edges


# -- results -----------------------------------------------------------------------------------------

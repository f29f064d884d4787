r"""Lagrangian systems on G x S with velocity constraints through :func:`~geomech.solve`: methods that agree as
the step shrinks.

* :class:`~geomech.integrators.LagrangeDAlembert`: the Lagrange-d'Alembert equations in coordinates, the
  multipliers solved at every evaluation from the differentiated constraints (the index-reduced DAE
  :math:`\mathbb M\ddot q - A^T\lambda = f + B\tau`, :math:`A\ddot q + \dot A\dot q = 0`), stepped by scipy;
  the constraint residual :math:`A(q)\dot q` is recorded (it drifts, slowly, since only its derivative is
  enforced; ``baumgarte=alpha`` adds :math:`2\alpha A\dot q` to damp the drift).
* :class:`~geomech.integrators.BKMM`: the BKMM equations (1.1)-(1.3) of the nonholonomic seed: momentum and
  shape equations for :math:`(r, \dot r, p)` and the reconstruction :math:`\dot q_G = \Lambda(q_G)^{-1}\xi`;
  the velocity satisfies the constraints exactly at every instant. Compiled (``_compiled``: straight-line code
  generated for the system, run by the compiled Dormand-Prince loops; its saved states observed by ``_observe``) where
  the gait and torques are formulas.
* :class:`~geomech.integrators.NonholonomicHamilton`: Hamilton's equations on :math:`\mathbb FL(\mathcal D)` in
  the almost-Poisson, Bates-Sniatycki or full-tensor form of :mod:`geomech.reduction` (``_hamiltonian``), with
  the torques as a generalised force, stepped by scipy.
* :class:`~geomech.integrators.DiscreteLagrangeDAlembert`: a discrete Lagrange-d'Alembert integrator with the
  midpoint discrete Lagrangian :math:`L_d(q_0, q_1) = hL\big(\tfrac{q_0+q_1}{2}, \tfrac{q_1-q_0}{h}\big)`
  (or the group's, :math:`h\ell(\bar r, \log(g_0^{-1}g_1)/h, (r_1 - r_0)/h)`, invariant in any chart),

  .. math::

      D_2L_d(q_{k-1}, q_k) + D_1L_d(q_k, q_{k+1}) + h\,\bar F_k + h\,A(q_k)^T\lambda_k = 0, \qquad
      A\big(\tfrac{q_k+q_{k+1}}{2}\big)(q_{k+1} - q_k) = 0,

  (Cortes and Martinez, Nonlinearity 14 (2001) 1365; McLachlan and Perlmutter, J. Nonlinear Sci. 16 (2006)
  283), second order, symmetric; :math:`\bar F_k` is the average of the shape forces at the two adjacent
  midpoints. One Newton solve of size (free coordinates + constraints) per step.

Shape variables are either prescribed functions of time (a gait, given as formulas in ``t``: their
derivatives are exact) or free, driven by torques :math:`\tau(t, q, \dot q)` (zero when not given). For
prescribed shapes the torques that realise the gait are computed, and the work they do is integrated
(:math:`W = \int \tau\cdot\dot r\,dt`; with no gait and no torque the energy is conserved).
"""

from __future__ import annotations

from .._adaptive import MAX_EVALUATIONS
from ._inputs import initial_state

__all__ = ["initial_state", "MAX_EVALUATIONS"]

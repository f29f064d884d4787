r"""
A nonholonomic system of your own
=================================

This tutorial follows the nonholonomic seed (Koon and Marsden) on a system that is not one of its examples: a
Chaplygin sleigh (a rigid body on the plane on a knife edge that cannot slip sideways) carrying a rotor that it can
spin back and forth. From its Lagrangian and its constraint, geomech derives the nonholonomic momentum and its
momentum equation, the connection and the reconstruction equation (eqs. 1.1 to 1.3), the almost-Poisson bracket
and its Jacobiator; then the sleigh is simulated by two independent routes, and the rotor's oscillation is shown
to make it crawl: a gait.

The sleigh's contact point is at :math:`(x, y)`, its heading :math:`\theta`, its centre of mass a distance
:math:`a` ahead of the contact point along the knife edge; the rotor (inertia :math:`J_r`) turns by
:math:`\varphi` relative to the sleigh:

.. math::

    L = \tfrac m2\bigl[(\dot x - a\sin\theta\,\dot\theta)^2 + (\dot y + a\cos\theta\,\dot\theta)^2\bigr]
        + \tfrac I2\dot\theta^2 + \tfrac{J_r}2(\dot\theta + \dot\varphi)^2,
    \qquad -\sin\theta\,\dot x + \cos\theta\,\dot y = 0 .

The group is :math:`SE(2)` (moving and turning the plane changes neither), the shape is :math:`\varphi`.
"""

# %%
# The description
# ---------------
# Velocities are named ``<coordinate>_dot``; every other symbol is a parameter, with its value given by name.
# The text is parsed by a whitelist (no Python is evaluated).
import matplotlib.pyplot as plt
import numpy as np

from geomech import NonholonomicSystem, solve
from geomech.analysis import analyse_gait
from geomech.integrators import BKMM, LagrangeDAlembert
from geomech.lie import SE2
from geomech.plot import gait_paths
from geomech.reduction import bkmm_reduction, lagrange_dalembert
from geomech.reduction.almost_poisson import almost_poisson


# sphinx_gallery_start_ignore
class Math:
    """Shows a value's LaTeX (its ``_repr_latex_``, as Jupyter would) in the gallery, typeset by the page's MathJax."""

    def __init__(self, value):
        self.latex = value._repr_latex_().strip().strip("$")

    def _repr_html_(self):
        import html

        return f'<div class="math notranslate nohighlight">\\[{html.escape(self.latex)}\\]</div>'


# sphinx_gallery_end_ignore


sleigh = NonholonomicSystem.from_lagrangian(
    "m/2*((x_dot - a*sin(theta)*theta_dot)**2 + (y_dot + a*cos(theta)*theta_dot)**2)"
    " + I/2*theta_dot**2 + Jr/2*(theta_dot + varphi_dot)**2",
    SE2("x", "y", "theta"),
    ["varphi"],
    ["-sin(theta)*x_dot + cos(theta)*y_dot"],
    parameters={"m": 1.0, "I": 0.2, "a": 0.4, "Jr": 0.1},
    name="sleigh with a rotor",
)

# %%
# What is derived
# ---------------
# The constrained directions that are also symmetry directions carry the nonholonomic momentum :math:`p`
# (here one: the sleigh's motion along its knife edge combined with its turning). BKMM's reduction gives its
# momentum equation :math:`\dot p = \dot r^T H \dot r + \dot r^a K_a p + \dots`, the connection that tells how the
# group moves, and the reduced shape dynamics.
red = bkmm_reduction(sleigh)
Math(red)

# %%
# The Lagrange-d'Alembert equations with their multipliers (the constraint force, here the knife edge's lateral
# reaction) are derived too:
Math(lagrange_dalembert(sleigh).multipliers)

# %%
# The almost-Poisson bracket of section 1.2 (van der Schaft and Maschke) reproduces the dynamics on the constraint
# manifold, but it is not Poisson: its Jacobiator does not vanish, and its curvature term is why.
ap = almost_poisson(sleigh)
print("Jacobi identity holds:", ap.satisfies_jacobi)

# %%
# Two routes to the same motion
# -----------------------------
# The rotor is driven through :math:`\varphi(t) = 1.2\sin(2\pi t)` (a prescribed shape, a gait). The full
# Lagrange-d'Alembert equations with multipliers and the reduced BKMM equations (momentum equation and
# reconstruction) are integrated independently through :func:`geomech.solve`; they agree to their tolerances.
gait = {"varphi": "1.2*sin(2*pi*t)"}
full = solve(sleigh, LagrangeDAlembert(), t_final=6.0, shapes=gait, saveat=601)
reduced = solve(sleigh, BKMM(), t_final=6.0, shapes=gait, saveat=601)
print(f"max |q_full - q_reduced| over 6 periods: {np.abs(full.q - reduced.q).max():.2e}")
print(f"largest constraint residual along the full solution: {np.abs(full.constraint_residual).max():.2e}")

# %%
# The gait: the sleigh crawls
# ---------------------------
# Starting from rest, each period of the rotor's oscillation moves the sleigh. :func:`geomech.analysis.analyse_gait`
# integrates the reduced equations over whole periods and reports the net motion, split into what the
# connection does and what the momentum built by the forcing does.
analysis = analyse_gait(sleigh, {"varphi": "1.2*sin(2*pi*t/T)"}, period=1.0, periods=6)
print("net (dx, dy, dtheta) over 6 periods, body frame at the start:", np.round(analysis.net_displacement, 4))
ax = gait_paths(analysis)
ax.set_title("sleigh with an oscillating rotor: path of the contact point")

fig, ax2 = plt.subplots(figsize=(7, 3.2))
ax2.plot(reduced.t, reduced.p[:, 0], lw=1.2)
ax2.set_xlabel("t")
ax2.set_ylabel("nonholonomic momentum p")
ax2.set_title("the momentum that the rotor's oscillation builds")
fig.tight_layout()

r"""
Connections, curvature and phases
=================================

Section 2 of the nonholonomic seed: a system on :math:`Q = G\times S` with a symmetry group :math:`G` and shape
variables :math:`r` carries a mechanical connection :math:`\mathcal A(r)`, and its spatial momentum :math:`\mu` is
conserved. When the shape runs a closed loop, the group moves by a geometric phase (the holonomy of the connection,
the curvature integrated over the enclosed region, independent of the timing) plus a dynamic phase (from
:math:`\mu`, which depends on the timing): Theorem 2.2. This tutorial computes the pieces on the seed's examples
and on a spacecraft that turns itself with zero angular momentum, as a falling cat does.
"""

# %%
# Two bodies pinned together
# --------------------------
# Two bodies turning about a common pin: :math:`\theta` the angle of body 1, :math:`\psi` the angle of body 2
# relative to it. The Lagrangian is written directly; the locked inertia and the connection are derived:
# :math:`\mathcal A = I_2/(I_1 + I_2)\,d\psi`, flat (:math:`S = S^1` has no area), so one turn of body 2 relative
# to body 1 turns body 1 back by :math:`2\pi I_2/(I_1 + I_2)`, and a momentum adds :math:`\mu T/(I_1 + I_2)`.
import matplotlib.pyplot as plt
import numpy as np

from geomech import Gait
from geomech.analysis import curvature_integral, geometric_phase, phases, reconstruct, rigid_body_phase
from geomech.lie import so3
from geomech.plot import curvature_map, phase_split
from geomech.reduction import bkmm_reduction
from geomech.systems import HolonomicSystem, RigidBody, spacecraft_with_rotors, three_link_chain

bodies = HolonomicSystem.from_lagrangian(
    "I1*theta_dot**2/2 + I2*(theta_dot + psi_dot)**2/2",
    "S1",
    ["psi"],
    parameters={"I1": 1.0, "I2": 3.0},
    shape_angles=[0],
    name="two pinned bodies",
)
print("connection:", bkmm_reduction(bodies).connection)
turn = Gait.from_expressions({"psi": "2*pi*t/T - 0.4*sin(2*pi*t/T)"}, period=5.5)
split = phases(bodies, turn, mu=-2.5)
print(f"geometric {split.geometric:+.10f}   closed form -2 pi I2/(I1+I2) = {-2 * np.pi * 0.75:+.10f}")
print(f"dynamic   {split.dynamic:+.10f}   closed form mu T/(I1+I2)     = {-2.5 * 5.5 / 4:+.10f}")
ax = phase_split(bodies, turn, mu=-2.5)
ax.set_title("two pinned bodies: the phase over one turn, geometric + dynamic")

# %%
# The free rigid body: Montgomery's formula
# -----------------------------------------
# For the free rigid body the shape is the body momentum on its sphere. After one period :math:`T` of
# :math:`m(t)` the attitude has turned about the spatial momentum by
# :math:`\Delta\theta = -\Lambda + 2ET/|\mu|`, :math:`\Lambda` the solid angle that :math:`m(t)/|m|` encloses,
# computed here from the Serret-Andoyer variables and checked against a direct integration of the attitude.
phase = rigid_body_phase(RigidBody([3.0, 2.0, 1.0]), [1.0, 0.3, 0.2])
phase

# %%
# The planar three-link chain: curvature over the shape plane
# -----------------------------------------------------------
# Three links joined by two pins, free in the plane with zero momentum: the chain reorients itself by moving its
# joints, the planar version of the falling cat. The curvature of the connection's rotational component over the
# joint angles :math:`(\alpha_1, \alpha_2)` tells which loops turn it most; by Stokes' theorem, the rotation
# after a loop, :math:`-\oint\mathcal A`, is minus the curvature :math:`B = d\mathcal A` integrated over the
# enclosed region (for SE(2) the bracket term has no rotation part).
chain = three_link_chain()
loop = Gait.ellipse([0.3, -0.2], [0.6, 0.5], 1.0)
rotation = geometric_phase(chain, loop)[2]
stokes = curvature_integral(chain, loop)[2]
print(f"net rotation by the connection {rotation:+.10f}; minus the enclosed curvature {-stokes:+.10f}")
ax = curvature_map(chain, component=2, loop=loop, bounds=[-1.5, 1.5, -1.5, 1.5])
ax.set_title("three-link chain: curvature of the rotational connection, with the loop")

# %%
# A spacecraft that turns itself: the falling cat on SO(3)
# --------------------------------------------------------
# A spacecraft with two rotors on its body axes 1 and 2 and zero angular momentum: spinning the rotors through a
# closed loop of their angles returns them to their start but leaves the body rotated. With constant locked
# connection :math:`A_{loc} = \mathbb I^{-1}[J_1 a_1, J_2 a_2]` the curvature is the bracket term alone,
# :math:`B = -[A_1, A_2] = -A_1\times A_2`, and for a small loop run counterclockwise the rotation vector is
# :math:`-\iint B = (A_1\times A_2)\,\text{area}` up to terms of third order in the loop's size.
craft = spacecraft_with_rotors()
small = Gait.ellipse([0.0, 0.0], [0.2, 0.1], 1.0)
path = reconstruct(craft, small, mu=np.zeros(3))
angle_vector = so3.log(path.path.element[-1])  # the body's rotation after one loop, as a rotation vector
A = np.linalg.solve(np.diag([3.0, 2.0, 1.0]), np.array([[0.2, 0.0], [0.0, 0.2], [0.0, 0.0]]))
predicted = np.cross(A[:, 0], A[:, 1]) * np.pi * 0.2 * 0.1
print("rotation after the loop (rotation vector):", np.round(angle_vector, 8))
print("-curvature x enclosed area              :", np.round(predicted, 8))

fig, ax = plt.subplots(figsize=(5, 3.2))
t = np.linspace(0, 1, 200)
r = small.r(t)
ax.plot(r[:, 0], r[:, 1])
ax.set_aspect("equal")
ax.set_xlabel("rotor 1 angle (rad)")
ax.set_ylabel("rotor 2 angle (rad)")
ax.set_title("the rotors' loop that turns the spacecraft")
fig.tight_layout()

"""Pictures. Each function takes ``ax=None`` (a new figure is made), draws, and returns the axes; none
calls ``plt.show()``. matplotlib is imported lazily."""

from .gaits import gait_momentum, gait_paths
from .momentum import momentum_sphere, reduced_phase_portrait
from .phases import (
    connection_field,
    curvature_map,
    group_path,
    momentum_solid_angle,
    phase_split,
    winding_numbers,
)
from .stability import equilibria_phase_portrait, stability_map_plot

__all__ = [
    "gait_momentum",
    "gait_paths",
    "connection_field",
    "curvature_map",
    "phase_split",
    "equilibria_phase_portrait",
    "group_path",
    "momentum_solid_angle",
    "momentum_sphere",
    "reduced_phase_portrait",
    "stability_map_plot",
    "winding_numbers",
]

"""Pictures. Each function takes ``ax=None`` (a new figure is made), draws, and returns the axes; none
calls ``plt.show()``. matplotlib is imported lazily."""

from .momentum import momentum_sphere, reduced_phase_portrait
from .stability import equilibria_phase_portrait, stability_map_plot

__all__ = ["equilibria_phase_portrait", "momentum_sphere", "reduced_phase_portrait", "stability_map_plot"]

"""Pictures. Each function takes ``ax=None`` (a new figure is made), draws, and returns the axes; none
calls ``plt.show()``. matplotlib is imported lazily."""

from .momentum import momentum_sphere, reduced_phase_portrait

__all__ = ["momentum_sphere", "reduced_phase_portrait"]

"""Interactive figures in the gallery: an example shows a plotly figure as a script would, with ``fig.show()``;
during the build, that call hands the figure to :class:`GalleryRenderer`, and :func:`plotly_scraper` puts it in
the example's page after the code block that made it, as a ``<div>`` drawn by the one copy of plotly.js the site
serves (``html_js_files`` in conf.py): no page fetches anything from the network.

Both run in the process that executes the example (sphinx-gallery's workers when it runs examples in parallel):
:func:`reset_plotly`, one of sphinx-gallery's ``reset_modules``, makes the renderer the default before each
example.
"""

from __future__ import annotations

from typing import Any

import plotly.io as pio
from plotly.io.base_renderers import ExternalRenderer

_SHOWN: list[str] = []


class GalleryRenderer(ExternalRenderer):
    """Keeps each shown figure as an HTML fragment without plotly.js, for the scraper to place."""

    def render(self, fig_dict: dict) -> None:
        config = {"displaylogo": False, "responsive": True}
        _SHOWN.append(pio.to_html(fig_dict, include_plotlyjs=False, full_html=False, config=config))


def reset_plotly(gallery_conf: dict, fname: str) -> None:
    """Before each example: figures shown go to the gallery, none is left from the last example."""
    pio.renderers["geomech_gallery"] = GalleryRenderer()
    pio.renderers.default = "geomech_gallery"
    _SHOWN.clear()


def plotly_scraper(block: Any, block_vars: dict, gallery_conf: dict) -> str:
    """The figures shown by a code block, as raw HTML in the page (empty when it showed none)."""
    if not _SHOWN:
        return ""
    parts = []
    for fragment in _SHOWN:
        body = "\n".join("    " + line for line in fragment.splitlines())
        parts.append(f'.. raw:: html\n\n    <div class="geomech-plotly">\n{body}\n    </div>\n')
    _SHOWN.clear()
    return "\n" + "\n".join(parts) + "\n"

"""Figures with matplotlib, the same way everywhere: no display, no timestamps in the file.

:func:`figure` makes a figure on the Agg canvas (no window, no ``pyplot`` state);
:func:`save` writes it as PNG or SVG without the metadata that would differ from run to run
(matplotlib's version and creation date), so the same data gives the same bytes.
matplotlib is imported only when a figure is made.
"""

from __future__ import annotations

from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from dsp.text import printable

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["FIGURE_SUFFIXES", "figure", "save"]

FIGURE_SUFFIXES = (".png", ".svg")
"""The figure formats written deterministically."""


def figure(width_in: float, height_in: float, **subplots: Any) -> tuple[Figure, Any]:
    """A new figure and its axes (``Figure.subplots(**subplots)``), not attached to pyplot."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), layout="constrained")
    return fig, fig.subplots(**subplots)


def save(fig: Figure, path: Path | str | IO[bytes], *, fmt: str = "png", dpi: int = 100) -> None:
    """Write ``fig`` to ``path`` (a file name or a binary file) as ``fmt`` (png or svg),
    with no varying metadata. Every text on it is made printable first (a title naming a
    file whose name is not UTF-8 holds a lone surrogate, which the font engine refuses)."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    for text in fig.findobj(Text):
        shown = text.get_text()
        if not shown.isprintable():
            text.set_text(printable(shown, lines=True))
    FigureCanvasAgg(fig)
    if fmt == "png":
        fig.savefig(path, format="png", dpi=dpi, metadata={"Software": None})
    elif fmt == "svg":
        with matplotlib.rc_context({"svg.hashsalt": "dual-sight"}):
            fig.savefig(path, format="svg", metadata={"Date": None, "Creator": None})
    else:
        raise ValueError(f"figure format {fmt!r}; choose png or svg")
